"""The up-axis guess from an object's shape (viewer.scene.orientation.detect_shape_up, issue 37):
a donut captured in Blender's +Z up, the same donut stored +Y and -Y (COLMAP), with and without
stored normals; a PLY torus mesh; shapes that say nothing; ``--up`` still wins."""
import warnings

import numpy as np
import pytest
from asset_files import capture, to_file_convention

from viewer.errors import AssetNote
from viewer.scene.assets import open_assets
from viewer.scene.orientation import detect_cloud_up, detect_shape_up, up_matrix
from viewer.splats import make_splats, write_ply


def _quat_z_to(n):
    """Unit quaternions (w, x, y, z) turning +Z onto the unit vectors ``n``."""
    z = np.array([0.0, 0.0, 1.0])
    axis = np.cross(z, n)
    w = 1.0 + n @ z
    q = np.c_[w, axis]
    flip = w < 1e-6
    q[flip] = [0.0, 1.0, 0.0, 0.0]
    return q / np.linalg.norm(q, axis=1, keepdims=True)


def donut(seed=0, icing=True, normals=True):
    """A +Y-up donut of flat splats (major radius 1, tube 0.4): the dough all round, denser on
    top where a capture's cameras saw it (a third of the underside missing), and, with
    ``icing``, a glaze over the top half of the tube."""
    rng = np.random.default_rng(seed)

    def tube(n, r, phi_lo, phi_hi):
        theta = rng.uniform(0, 2 * np.pi, n)
        phi = rng.uniform(phi_lo, phi_hi, n)
        ring = np.stack([np.cos(theta), np.zeros(n), np.sin(theta)], -1)
        nrm = ring * np.cos(phi)[:, None] + np.array([0.0, 1.0, 0.0]) * np.sin(phi)[:, None]
        return ring * 1.0 + nrm * r, nrm

    pos, nrm = tube(3000, 0.4, -np.pi, np.pi)
    seen = (nrm[:, 1] > -0.5) | (rng.uniform(size=len(pos)) > 0.33)
    pos, nrm = pos[seen], nrm[seen]
    if icing:
        p2, n2 = tube(1500, 0.42, 0.0, np.pi)
        pos, nrm = np.r_[pos, p2], np.r_[nrm, n2]
    n = len(pos)
    return make_splats(pos, np.tile([0.03, 0.03, 0.003], (n, 1)), _quat_z_to(nrm),
                       np.full(n, 0.9), normals=nrm if normals else None)


@pytest.mark.parametrize("normals", [True, False])
@pytest.mark.parametrize("up", ["+Z", "+Y", "-Y"])
def test_a_donut_capture_is_upright_in_blender_gltf_and_colmap_conventions(up, normals):
    found = detect_cloud_up(to_file_convention(donut(normals=normals), up))
    assert found is not None and found[0] == up, found
    assert "disc" in found[1]


def test_a_plain_torus_takes_the_axis_convention():
    """No side says more: short along Z is Blender's +Z, short along Y a capture's -Y."""
    plain = donut(icing=False, normals=False)
    mirrored = plain.means * np.float32([1, -1, 1])  # the underside as complete as the top
    sym = make_splats(np.r_[plain.means, mirrored], np.r_[plain.scales, plain.scales],
                      np.r_[plain.rotations, plain.rotations],
                      np.r_[plain.opacities, plain.opacities])
    assert detect_cloud_up(to_file_convention(sym, "+Z"))[0] == "+Z"
    assert detect_cloud_up(to_file_convention(sym, "-Y"))[0] == "-Y"
    assert detect_cloud_up(to_file_convention(sym, "+X")) is None  # nobody's convention


def test_shapes_that_say_nothing():
    rng = np.random.default_rng(5)
    ball = rng.normal(size=(2000, 3))
    assert detect_shape_up(ball) is None  # round
    rod = ball * [0.2, 1.0, 0.3]
    assert detect_shape_up(rod) is None  # a figure standing: one long axis, not a disc
    tilt = np.asarray(up_matrix("+Z"))[:3, :3]
    c, s = np.cos(0.6), np.sin(0.6)
    tilted = (ball * [1.0, 1.0, 0.3]) @ np.array([[1, 0, 0], [0, c, -s], [0, s, c]]).T @ tilt
    assert detect_shape_up(tilted) is None  # short axis 34 degrees off every axis


def _open(path, **kw):
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        opened = open_assets([path], **kw)
    return opened, [str(w.message) for w in caught if issubclass(w.category, AssetNote)]


def test_open_a_blender_donut_ply_upright_and_up_wins(tmp_path):
    path = tmp_path / "donut.ply"
    write_ply(path, to_file_convention(donut(), "+Z"))
    opened, notes = _open(path)
    assert opened.scene.objects[0].transform == up_matrix("+Z")
    assert len(notes) == 1 and "+Z up (guessed from its shape" in notes[0] and "--up" in notes[0]
    opened, notes = _open(path, up="-Y")
    assert opened.scene.objects[0].transform == up_matrix("-Y") and not notes


def test_a_colmap_scene_with_a_ground_stays_minus_y(tmp_path):
    path = tmp_path / "scene.ply"
    write_ply(path, to_file_convention(capture(), "-Y"))
    opened, notes = _open(path)
    assert opened.scene.objects[0].transform == up_matrix("-Y") and "dominant plane" in notes[0]


def test_a_ply_torus_mesh_exported_z_up(tmp_path):
    import trimesh

    torus = trimesh.creation.torus(major_radius=1.0, minor_radius=0.35)  # flat in XY: +Z up
    torus.export(tmp_path / "torus.ply")
    opened, notes = _open(tmp_path / "torus.ply")
    assert opened.scene.objects[0].transform == up_matrix("+Z"), notes
    assert "Blender's +Z up" in notes[0]
    standing = trimesh.creation.cylinder(radius=0.3, height=2.0)  # along Z: a rod says nothing
    standing.export(tmp_path / "rod.ply")
    opened, notes = _open(tmp_path / "rod.ply")
    assert opened.scene.objects[0].transform is None and "does not say" in notes[0]
