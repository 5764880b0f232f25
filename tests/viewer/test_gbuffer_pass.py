"""The G-buffer fill pass on llvmpipe: a sphere's G-buffer, texture maps, image stacks."""
import numpy as np
import pytest

from viewer.gbuffer import GBufferLayout
from viewer.geometry.imagespace import ImageGBuffer
from viewer.geometry.primitives import plane, sphere
from viewer.passes.gbuffer import GBufferPass, GBufferTargets
from viewer.scene.camera import Camera
from viewer.scene.material import Material

LAYOUT = GBufferLayout()
SIZE = 64


@pytest.fixture
def fill(ctx, programs):
    targets = GBufferTargets.create(ctx, LAYOUT, (SIZE, SIZE))
    gpass = GBufferPass(programs, LAYOUT)
    targets.clear()
    yield targets, gpass
    gpass.release()
    targets.release()


def _camera(**kw):
    return Camera(position=(0.0, 0.0, 3.0), target=(0.0, 0.0, 0.0), fov_y=40.0,
                  size=(SIZE, SIZE), **kw)


def test_sphere_gbuffer(fill):
    targets, gpass = fill
    mat = Material(albedo=(0.2, 0.4, 0.6), roughness=0.3, metallic=0.7, specular=0.25, ao=0.9)
    gpass.draw_meshes(targets, _camera(), [sphere(radius=1.0, material=mat)])
    g = targets.read()
    # The pixel centre nearest the axis is half a pixel off it in x and y.
    centre = {k: v[SIZE // 2 - 1: SIZE // 2 + 1, SIZE // 2 - 1: SIZE // 2 + 1].mean(axis=(0, 1))
              for k, v in g.items()}
    np.testing.assert_allclose(centre["normal"], [0, 0, 1], atol=2e-4)
    np.testing.assert_allclose(g["normal"][SIZE // 2, SIZE // 2], [0, 0, 1], atol=0.02)
    assert centre["depth"][0] == pytest.approx(2.0, abs=1e-3)
    assert centre["alpha"][0] == 1.0
    np.testing.assert_allclose(centre["albedo"], mat.albedo, atol=1e-6)
    for name, want in (("roughness", 0.3), ("metallic", 0.7), ("specular", 0.25), ("ao", 0.9)):
        assert centre[name][0] == pytest.approx(want, abs=1e-6), name
    fg = g["alpha"][..., 0] > 0
    np.testing.assert_allclose(np.linalg.norm(g["normal"][fg], axis=-1), 1.0, atol=1e-5)
    # Normal x grows to the right, y towards the top (row 0).
    assert g["normal"][SIZE // 2, SIZE // 2 + 10, 0] > 0.2
    assert g["normal"][SIZE // 2 - 10, SIZE // 2, 1] > 0.2
    for corner in ((0, 0), (0, -1), (-1, 0), (-1, -1)):
        assert g["alpha"][corner][0] == 0 and g["depth"][corner][0] == 0
        np.testing.assert_array_equal(g["normal"][corner], 0)
        assert g["roughness"][corner][0] == 1.0 and g["specular"][corner][0] == 0.0


def test_back_faces_face_the_viewer(fill):
    targets, gpass = fill
    wall = plane(size=(2, 2), normal=(0, 0, -1))  # facing away from the camera
    gpass.draw_meshes(targets, _camera(), [wall])
    g = targets.read(["normal", "alpha"])
    assert set(g) == {"normal", "alpha"}
    np.testing.assert_allclose(g["normal"][SIZE // 2, SIZE // 2], [0, 0, 1], atol=1e-6)


def _textured_wall(tangents: bool, normal_ts):
    color = np.zeros((16, 16, 3), np.float32)
    color[:8, :8] = (1, 0, 0)  # texture top left quadrant
    color[8:, 8:] = (0, 0, 1)
    nmap = np.full((4, 4, 3), 0.5 * np.asarray(normal_ts, np.float32) + 0.5, np.float32)
    wall = plane(size=(2, 2), normal=(0, 0, 1), material=Material(albedo=(1.0, 1.0, 1.0)))
    if not tangents:
        wall.tangents = None
    wall.textures = {"base_color": color, "normal": nmap}
    return wall


@pytest.mark.parametrize("tangents", [True, False], ids=["tangents", "cotangent_frame"])
def test_normal_and_base_colour_maps(fill, tangents):
    targets, gpass = fill
    s = 0.6
    cam = _camera()
    for n_ts, want in (((s, 0, 0.8), (s, 0, 0.8)), ((0, s, 0.8), (0, s, 0.8))):
        targets.clear()
        wall = _textured_wall(tangents, n_ts)
        assert ("HAS_TANGENTS" in gpass.mesh_defines(wall)) == tangents
        gpass.draw_meshes(targets, cam, [wall])
        g = targets.read()
        # tangent-space +X is +u (right), +Y is -v (up): the wall's world +X and +Y
        np.testing.assert_allclose(g["normal"][SIZE // 2, SIZE // 2], want, atol=2e-3)
    # The quad spans about 2 / (2 * 3 * tan(20 deg)) = 92% of the view; sample inside each quadrant.
    q = SIZE // 4
    np.testing.assert_allclose(g["albedo"][q, q], [1, 0, 0], atol=1e-3)  # top left: red
    np.testing.assert_allclose(g["albedo"][-q, -q], [0, 0, 1], atol=1e-3)


def test_image_stack_round_trips_exactly(fill):
    targets, gpass = fill
    rng = np.random.default_rng(0)
    h = w = SIZE
    alpha = (rng.random((h, w, 1)) > 0.3).astype(np.float32)
    alpha[0, :5] = 1.0  # make the flip visible: top-row foreground
    alpha[-1, :5] = 0.0
    n = rng.normal(size=(h, w, 3)).astype(np.float32)
    n /= np.linalg.norm(n, axis=-1, keepdims=True)
    ch = {"albedo": rng.random((h, w, 3)), "normal": n, "roughness": rng.random((h, w, 1)),
          "metallic": np.zeros((h, w, 1)), "specular": rng.random((h, w, 1)),
          "ao": rng.random((h, w, 1)), "depth": 1 + 50 * rng.random((h, w, 1)), "alpha": alpha}
    ch = {k: v.astype(np.float32) for k, v in ch.items()}
    background = LAYOUT.background(h, w)
    ch = {k: np.where(alpha > 0, v, background[k]) for k, v in ch.items()}
    image = ImageGBuffer(channels=ch, fov_y=30.0)
    gpass.draw_image(targets, image)
    got = targets.read()
    for name, want in ch.items():
        np.testing.assert_array_equal(got[name], want, err_msg=name)


def test_meshes_depth_test_against_a_stack(fill):
    """A stack at depth 2 hides a sphere behind it and is hidden by one in front of it."""
    targets, gpass = fill
    h = w = SIZE
    ones = np.ones((h, w, 1), np.float32)
    image = ImageGBuffer(channels={"albedo": np.full((h, w, 3), 0.5, np.float32),
                                   "normal": np.tile(np.float32([0, 0, 1]), (h, w, 1)),
                                   "depth": 2.0 * ones, "alpha": ones}, fov_y=40.0)
    cam = image.camera()
    gpass.draw_image(targets, image, cam)
    near = sphere(center=(-0.3, 0, -1.0), radius=0.2, material=Material(albedo=(1, 0, 0)))
    far = sphere(center=(0.3, 0, -3.0), radius=0.4, material=Material(albedo=(0, 1, 0)))
    gpass.draw_meshes(targets, cam, [near, far])
    g = targets.read()
    assert g["albedo"][:, :, 0].max() == 1.0  # the near sphere is visible
    assert g["albedo"][:, :, 1].max() == 0.5  # the far one is not
    assert g["depth"][..., 0].min() == pytest.approx(0.8, abs=0.01)
