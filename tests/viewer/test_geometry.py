"""Primitives and the Mesh container: analytic normals, poles, UV layout, the material-ball grid."""
import numpy as np
import pytest

from viewer.errors import InputError
from viewer.geometry.mesh import Mesh, smooth_normals
from viewer.geometry.primitives import material_ball_grid, plane, sphere


def _face_normals(m: Mesh) -> np.ndarray:
    p, t = m.positions.astype(np.float64), m.indices
    return np.cross(p[t[:, 1]] - p[t[:, 0]], p[t[:, 2]] - p[t[:, 0]])


def test_sphere_normals_are_unit_and_radial():
    m = sphere(center=(1.0, -2.0, 0.5), radius=0.7, segments=64, rings=32)
    assert m.positions.dtype == np.float32 and m.indices.dtype == np.uint32
    assert np.isfinite(m.normals).all() and np.isfinite(m.tangents).all()
    np.testing.assert_allclose(np.linalg.norm(m.normals, axis=1), 1.0, atol=1e-6)
    radial = (m.positions - np.float32([1.0, -2.0, 0.5])) / 0.7
    np.testing.assert_allclose(m.normals, radial, atol=1e-5)
    lo, hi = m.bounds()
    np.testing.assert_allclose(lo, [0.3, -2.7, -0.2], atol=1e-5)
    np.testing.assert_allclose(hi, [1.7, -1.3, 1.2], atol=1e-5)


def test_sphere_poles_and_winding():
    m = sphere(segments=16, rings=8)
    assert m.triangle_count == 2 * 16 * 8 - 2 * 16  # one degenerate triangle per pole quad dropped
    fn = _face_normals(m)
    assert (np.linalg.norm(fn, axis=1) > 0).all()  # no zero-area triangle at the poles
    centroid = m.positions[m.indices].mean(axis=1)
    assert (np.einsum("ij,ij->i", fn, centroid) > 0).all()  # counter-clockwise from outside
    top = m.positions[:, 1] > 1 - 1e-6
    np.testing.assert_array_equal(m.normals[top], np.tile([0.0, 1.0, 0.0], (top.sum(), 1)))
    # Tangents are perpendicular to normals and point along +u; u = 0.5 faces +Z.
    np.testing.assert_allclose(np.einsum("ij,ij->i", m.tangents[:, :3], m.normals), 0, atol=1e-6)
    front = np.argmax(m.positions[:, 2])
    assert abs(m.uvs[front, 0] - 0.5) < 1e-6
    np.testing.assert_allclose(m.tangents[front], [1, 0, 0, 1], atol=1e-6)


def test_plane_uvs_and_orientation():
    m = plane(center=(0, 1, 0), size=(4, 2), normal=(0, 1, 0))
    assert m.triangle_count == 2 and m.vertex_count == 4
    fn = _face_normals(m)
    assert (fn @ np.array([0, 1, 0]) > 0).all()
    lo, hi = m.bounds()
    np.testing.assert_allclose(lo, [-2, 1, -1])
    np.testing.assert_allclose(hi, [2, 1, 1])
    # uv (0, 0) is the -X, -Z corner (the image top lies at -Z).
    corner = np.argmin(m.uvs.sum(axis=1))
    np.testing.assert_allclose(m.positions[corner], [-2, 1, -1])
    wall = plane(normal=(0, 0, 1), subdivisions=3)
    assert wall.triangle_count == 18
    assert (_face_normals(wall) @ np.array([0, 0, 1]) > 0).all()
    top_left = np.argmin(wall.uvs.sum(axis=1))
    np.testing.assert_allclose(wall.positions[top_left], [-1, 1, 0])


def test_material_ball_grid_sweeps():
    balls = material_ball_grid(rows=3, cols=5, albedo=(0.9, 0.5, 0.1), segments=16, rings=8)
    assert len(balls) == 15
    rough = np.array([b.material.roughness for b in balls]).reshape(3, 5)
    metal = np.array([b.material.metallic for b in balls]).reshape(3, 5)
    np.testing.assert_allclose(rough[0], [0, 0.25, 0.5, 0.75, 1])
    np.testing.assert_allclose(metal[:, 0], [0, 0.5, 1])
    assert all(b.material.albedo == (0.9, 0.5, 0.1) for b in balls)
    centres = np.array([b.positions.mean(axis=0) for b in balls]).reshape(3, 5, 3)
    assert centres[0, 0, 0] < centres[0, 4, 0] and centres[0, 0, 1] > centres[2, 0, 1]


def test_mesh_validation_names_source():
    m = sphere(segments=8, rings=4)
    m.positions[3, 1] = np.nan
    m.source = "broken.obj"
    with pytest.raises(InputError, match="broken.obj.*NaN/Inf positions"):
        m.validated()


def test_mirror_transform_keeps_front_faces():
    m = sphere(segments=8, rings=4)
    mirrored = m.transformed(np.diag([-1.0, 1.0, 1.0, 1.0]))
    fn = _face_normals(mirrored)
    assert (np.einsum("ij,ij->i", fn, mirrored.positions[mirrored.indices].mean(1)) > 0).all()
    np.testing.assert_allclose(mirrored.normals, mirrored.positions, atol=1e-5)
    assert (mirrored.tangents[:, 3] == -1).all()


def test_smooth_normals_of_a_box_corner_are_diagonal():
    import trimesh

    box = trimesh.creation.box()
    n = smooth_normals(box.vertices, box.faces)
    np.testing.assert_allclose(np.linalg.norm(n, axis=1), 1, atol=1e-6)
    assert (np.sign(n) == np.sign(box.vertices)).all()
