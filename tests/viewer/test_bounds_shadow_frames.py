"""Scene bounds (meshes, robust splat bounds) and directional shadow frames fitted to them: every
point of the scene maps inside [0, 1]^3, nearer the light means smaller depth, and a point's shadow
falls where the analytic projection along the light puts it."""
import numpy as np
import pytest

from viewer.geometry.primitives import plane, sphere
from viewer.lighting.shadow_frames import directional_frame, light_basis
from viewer.scene.bounds import Bounds, content_bounds, points_bounds, splat_bounds


def test_mesh_bounds_union():
    b = content_bounds([sphere(center=(1, 2, 3), radius=0.5),
                        plane(center=(0, 0, 0), size=(4, 2), normal=(0, 1, 0))])
    np.testing.assert_allclose(b.lo, (-2, 0, -1), atol=1e-6)
    np.testing.assert_allclose(b.hi, (2, 2.5, 3.5), atol=1e-6)


def test_splat_bounds_ignore_far_outliers():
    rng = np.random.default_rng(0)
    bulk = rng.normal(0.0, 0.1, (5000, 3))
    floaters = rng.uniform(-200, 200, (20, 3))  # 0.4 %: beyond the 1 % quantiles
    means = np.concatenate([bulk, floaters])
    scales = np.full((len(means), 3), 0.01)
    b = splat_bounds(means, scales)
    assert max(np.abs(b.lo).max(), np.abs(b.hi).max()) < 0.5
    assert points_bounds(means).radius > 100  # the plain bounds are useless


def test_empty_and_nonfinite():
    assert points_bounds(np.zeros((0, 3))) is None
    assert splat_bounds(np.full((4, 3), np.nan)) is None
    assert content_bounds(object()) is None


@pytest.mark.parametrize("direction", [(0, 1, 0), (0.3, 0.8, -0.2), (1, 0.05, 0), (0, -1, 0)])
def test_directional_frame_covers_the_scene(direction):
    d = np.asarray(direction, float) / np.linalg.norm(direction)
    b = Bounds((-2, -0.5, -1), (1, 2, 3))
    f = directional_frame(b, d, resolution=1024)
    uvd = f.project(b.corners())
    assert (uvd >= -1e-9).all() and (uvd <= 1 + 1e-9).all()
    basis = light_basis(d)
    assert np.allclose(basis @ basis.T, np.eye(3))
    # nearer the light -> smaller depth
    c = b.center
    near, far = f.project(np.stack([c + 0.1 * d, c - 0.1 * d]))[:, 2]
    assert near < far
    np.testing.assert_allclose(far - near, 0.2 / f.depth_range, rtol=1e-9)
    assert f.texel_world == pytest.approx(max(f.extent) / 1024)


def test_shadow_of_a_point_lands_on_its_analytic_projection():
    """A point above a floor and where the light's ray through it meets the floor share (u, v):
    the map stores the nearer one, so the floor point reads as shadowed."""
    d = np.array([0.4, 1.0, 0.3])
    d /= np.linalg.norm(d)
    f = directional_frame(Bounds((-3, 0, -3), (3, 2, 3)), d)
    p = np.array([0.2, 1.0, -0.4])
    hit = p - d * (p[1] / d[1])  # along -d to y = 0
    a, b = f.project(np.stack([p, hit]))
    np.testing.assert_allclose(a[:2], b[:2], atol=1e-12)
    assert a[2] < b[2]
