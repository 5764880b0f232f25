"""Assets opened without a scene file (viewer.scene.assets): kinds, up axes (markers, detection,
conventions), framing, floors, and 8-bit environments decoded from sRGB."""
import warnings

import numpy as np
import pytest
from asset_files import (
    BOX_HI,
    BOX_LO,
    box_gltf,
    capture,
    capture_ply,
    to_file_convention,
)

from viewer.errors import AssetNote, InputError, SceneError
from viewer.scene.assets import asset_kind, is_scene_file, open_assets
from viewer.scene.bounds import Bounds
from viewer.scene.framing import FILL, frame_camera
from viewer.scene.orientation import UP_AXES, detect_splat_up, marked_up, up_matrix
from viewer.splats import make_splats


def _quiet(fn, *a, **kw):
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        out = fn(*a, **kw)
    return out, caught


@pytest.mark.parametrize("up", UP_AXES)
def test_up_matrix_is_a_rotation_taking_up_to_y(up):
    m = np.asarray(up_matrix(up))
    r = m[:3, :3]
    axis = np.zeros(3)
    axis["XYZ".index(up[1])] = 1.0 if up[0] == "+" else -1.0
    np.testing.assert_array_equal(r @ axis, [0.0, 1.0, 0.0])
    assert np.linalg.det(r) == pytest.approx(1.0)  # no mirror image
    np.testing.assert_array_equal(m[3], [0, 0, 0, 1])


@pytest.mark.parametrize("line, up", [
    ("comment up +Z", "+Z"), ("comment up_axis: -y", "-Y"), ("obj_info upAxis=X", "+X"),
    ("comment up-axis -Z", "-Z"), ("comment Created by Blender 4.1", "+Z")])
def test_ply_header_markers(line, up):
    assert marked_up(["comment made by a scanner", line])[0] == up


def test_no_marker_in_unrelated_comments():
    assert marked_up(["comment upload date 2024", "comment zebra"]) is None


@pytest.mark.parametrize("up", UP_AXES)
def test_detects_the_up_of_a_capture_in_every_convention(up):
    found = detect_splat_up(to_file_convention(capture(), up))
    assert found is not None and found[0] == up, found


def test_a_shapeless_cloud_says_nothing():
    rng = np.random.default_rng(1)
    n = 500
    blob = make_splats(rng.normal(size=(n, 3)), np.full((n, 3), 0.05),
                       np.tile([1.0, 0, 0, 0], (n, 1)), np.full(n, 0.9))
    assert detect_splat_up(blob) is None


def test_kinds_by_extension_and_ply_header(tmp_path):
    import trimesh

    mesh_ply = tmp_path / "mesh.ply"
    trimesh.creation.box().export(mesh_ply)
    splat_ply = capture_ply(tmp_path / "cloud.ply")
    assert asset_kind(mesh_ply) == "mesh" and asset_kind(splat_ply) == "splats"
    assert asset_kind(box_gltf(tmp_path / "b.glb")) == "mesh"
    assert asset_kind(tmp_path) == "gbuffer"
    (tmp_path / "s.toml").write_text("[camera]\n")
    (tmp_path / "scene.txt").write_text("[[objects]]\ntype = 'sphere'\n")
    assert is_scene_file(tmp_path / "s.toml") and is_scene_file(tmp_path / "scene.txt")
    assert not is_scene_file(splat_ply)
    with pytest.raises(InputError, match="file not found"):
        asset_kind(tmp_path / "missing.glb")
    (tmp_path / "a.xyz").write_text("1 2 3")
    with pytest.raises(InputError, match="unknown asset extension '.xyz'"):
        asset_kind(tmp_path / "a.xyz")
    (tmp_path / "bad.ply").write_bytes(b"\x00\x01garbage")
    with pytest.raises(InputError, match="not a PLY file"):
        asset_kind(tmp_path / "bad.ply")


def _projected(camera, points):
    """Normalised device x, y of ``points`` and their depths."""
    v = np.c_[points, np.ones(len(points))] @ camera.view_matrix().T
    tx, ty = camera.tan_half_fov()
    depth = -v[:, 2]
    return v[:, 0] / depth / tx, v[:, 1] / depth / ty, depth


@pytest.mark.parametrize("size", [(64, 64), (128, 48), (40, 120)])
def test_framing_fits_the_box_tightly(size):
    box = Bounds(tuple(BOX_LO), tuple(BOX_HI))
    cam = frame_camera(box, 40.0, size)
    x, y, depth = _projected(cam, box.corners())
    reach = np.maximum(np.abs(x), np.abs(y))
    assert reach.max() == pytest.approx(FILL, abs=1e-9)  # touches 90 % of the frame: no slack
    # centred: equal margins either side (perspective: a fixed point, to 1e-3 of the frame)
    assert x.max() + x.min() == pytest.approx(0.0, abs=1e-3)
    assert y.max() + y.min() == pytest.approx(0.0, abs=1e-3)
    assert (depth > cam.near).all() and (depth < cam.far).all()
    assert cam.position[1] > box.center[1]  # a little above


def test_open_a_gltf_framed_with_a_floor(tmp_path):
    opened, caught = _quiet(open_assets, [box_gltf(tmp_path / "b.glb")], env="sky", floor=True,
                            size=(80, 60))
    scene = opened.scene
    assert [o.type for o in scene.objects] == ["mesh", "plane"]
    assert scene.objects[0].transform is None and not opened.notes  # glTF is +Y by spec
    floor = scene.objects[1]
    assert floor.center[1] == pytest.approx(BOX_LO[1]) and floor.size[0] >= 3 * 2.0
    assert floor.catcher  # a bare --floor: the shadow catcher (tests/viewer/test_ground.py)
    assert scene.camera.size == (80, 60) and scene.environment.procedural == "sky"
    target = np.asarray(scene.camera.target)  # the box's centre, moved to centre its silhouette
    assert (target > BOX_LO).all() and (target < BOX_HI).all()
    assert not [w for w in caught if issubclass(w.category, AssetNote)]


def test_forced_up_wins_and_notes_say_what_was_assumed(tmp_path):
    path = capture_ply(tmp_path / "c.ply", "+Z", comments=["up -X"])
    opened, caught = _quiet(open_assets, [path])
    notes = [str(w.message) for w in caught if issubclass(w.category, AssetNote)]
    assert len(notes) == 1 and "-X up" in notes[0] and "--up" in notes[0]
    assert "read from its header" in notes[0]
    opened, caught = _quiet(open_assets, [path], up="+Z")
    assert not opened.notes
    np.testing.assert_array_equal(opened.scene.objects[0].transform, up_matrix("+Z"))
    with pytest.raises(SceneError, match="up must be one of"):
        open_assets([path], up="sideways")


def test_shapeless_cloud_falls_back_to_the_capture_convention(tmp_path):
    from viewer.splats import write_ply

    rng = np.random.default_rng(2)
    n = 300
    write_ply(tmp_path / "blob.ply", make_splats(rng.normal(size=(n, 3)), np.full((n, 3), 0.05),
                                                np.tile([1.0, 0, 0, 0], (n, 1)), np.full(n, 0.9)))
    opened, _ = _quiet(open_assets, [tmp_path / "blob.ply"])
    assert len(opened.notes) == 1 and "-Y up (assumed: COLMAP" in opened.notes[0]


def test_8bit_environment_is_decoded_from_srgb(tmp_path):
    from viewer.environment.maps import EnvironmentSpec, load_environment
    from viewer.geometry.mesh import srgb_to_linear
    from viewer.imageio import write_exr, write_png

    rng = np.random.default_rng(3)
    u8 = rng.integers(0, 256, (32, 64, 3), dtype=np.uint8)
    write_png(tmp_path / "env.png", u8)
    write_exr(tmp_path / "env.exr", srgb_to_linear(u8 / 255.0))
    png, caught = _quiet(load_environment, EnvironmentSpec(path=str(tmp_path / "env.png")))
    exr, clean = _quiet(load_environment, EnvironmentSpec(path=str(tmp_path / "env.exr")))
    np.testing.assert_allclose(png, exr, atol=1e-6)
    assert len(caught) == 1 and "decoded from sRGB to linear" in str(caught[0].message)
    assert "clipped" in str(caught[0].message) and not clean
