"""Physical properties of lib/brdf.glsl and lib/sampling.glsl, evaluated in GLSL (llvmpipe)."""
import math

import numpy as np
import pytest

from viewer.gl.kernels import evaluate


def _grid(*axes):
    mesh = np.meshgrid(*axes, indexing="ij")
    return [m.ravel().astype(np.float32) for m in mesh]


EXTREME_DOTS = np.array([0.0, 1e-30, 1e-7, 1e-4, 0.5, 0.9999999, 1.0], np.float32)
EXTREME_ALPHA = np.array([0.0, 1e-20, 1e-6, 0.002025, 0.5, 1.0], np.float32)


@pytest.mark.parametrize("name,arity", [("d_ggx", 2), ("v_smith_ggx_correlated", 3),
                                        ("blinn_phong_shininess", 1), ("d_blinn_phong", 2)])
def test_terms_are_finite_at_extremes(programs, name, arity):
    if name == "d_blinn_phong":
        args = _grid(EXTREME_DOTS, np.array([0.0, 1.0, 100.0, 16384.0, 1e30], np.float32))
    else:
        args = _grid(*([EXTREME_DOTS] * (arity - 1) + [EXTREME_ALPHA]))
    out = evaluate(programs, name, *args)
    assert np.isfinite(out).all() and (out >= 0).all()


def test_ggx_ndf_is_normalised(programs):
    # integral of D(h) (n.h) over the hemisphere = 1 (projected microfacet area)
    mu = (np.arange(20000) + 0.5) / 20000  # cos(theta_h), midpoint rule
    for a in (0.1, 0.3, 0.7, 1.0):
        d = evaluate(programs, "d_ggx", mu.astype(np.float32), np.full(mu.size, a, np.float32))
        integral = 2 * math.pi * np.sum(d.astype(np.float64) * mu) / mu.size
        assert abs(integral - 1.0) < 2e-3, (a, integral)


def test_blinn_phong_is_normalised(programs):
    # (s + 2)/(2 pi) NoH^s integrates to 1 against (n.h) over the hemisphere
    mu = (np.arange(20000) + 0.5) / 20000
    for s in (1.0, 10.0, 100.0):
        d = evaluate(programs, "d_blinn_phong", mu.astype(np.float32), np.full(mu.size, s, np.float32))
        integral = 2 * math.pi * np.sum(d.astype(np.float64) * mu) / mu.size
        assert abs(integral - 1.0) < 2e-3, (s, integral)


def test_smith_visibility_smooth_limit(programs):
    # a -> 0: V = 1 / (4 NoV NoL)
    nov = np.array([0.2, 0.5, 1.0], np.float32)
    v = evaluate(programs, "v_smith_ggx_correlated", nov, nov, np.zeros(3, np.float32))
    np.testing.assert_allclose(v, 1.0 / (4.0 * nov * nov), rtol=1e-5)


def test_schlick_endpoints(programs):
    f0 = np.array([[0.04, 0.5, 1.0]] * 2, np.float32)
    out = evaluate(programs, "f_schlick", f0, np.ones(2, np.float32), np.array([1.0, 0.0], np.float32))
    np.testing.assert_allclose(out[0], f0[0], atol=1e-7)  # normal incidence -> f0
    np.testing.assert_allclose(out[1], [1.0, 1.0, 1.0], atol=1e-7)  # grazing -> f90


def test_radical_inverse_and_hammersley(programs):
    i = np.arange(16, dtype=np.float32)
    ri = evaluate(programs, "radical_inverse_vdc", i)
    np.testing.assert_array_equal(ri[:8], [0.0, 0.5, 0.25, 0.75, 0.125, 0.625, 0.375, 0.875])
    pts = evaluate(programs, "hammersley", i, np.full(16, 16, np.float32))
    np.testing.assert_array_equal(pts[:, 0], i / 16)
    # (0,m,2)-net in base 2: each of the 16 strata of [0,1) in y holds exactly one point
    assert sorted(np.floor(pts[:, 1] * 16).astype(int)) == list(range(16))
    assert (evaluate(programs, "radical_inverse_vdc", np.array([16777215.0], np.float32)) < 1.0).all()


def _ggx_theta_cdf(a, theta):
    # analytic: P(theta_h <= theta) = integral 2 pi D(cos t) cos t sin t dt = tan^2 / (a^2 + tan^2)
    t2 = np.tan(theta) ** 2
    return t2 / (a * a + t2)


@pytest.mark.parametrize("a", [0.05, 0.3, 0.8])
def test_importance_sample_ggx_distribution(programs, a):
    n = 4096
    xi = evaluate(programs, "hammersley", np.arange(n, dtype=np.float32), np.full(n, n, np.float32))
    h = evaluate(programs, "importance_sample_ggx", xi, np.full(n, a, np.float32))
    np.testing.assert_allclose(np.linalg.norm(h, axis=1), 1.0, atol=2e-6)
    assert (h[:, 2] >= 0).all()
    theta = np.sort(np.arccos(np.clip(h[:, 2].astype(np.float64), -1, 1)))
    empirical = (np.arange(n) + 0.5) / n
    ks = np.abs(_ggx_theta_cdf(a, theta) - empirical).max()
    assert ks < 2.0 / n, ks  # a low-discrepancy set: KS distance ~ 1/n (measured ~1.2e-4)
    # azimuth uniform: mean of cos/sin phi ~ 0
    assert abs(h[:, 0].mean()) < 1e-3 and abs(h[:, 1].mean()) < 1e-3
    # mean of n.h over the samples = integral of (n.h) D(h) (n.h) dw (quadrature with d_ggx)
    mu = (np.arange(20000) + 0.5) / 20000
    d = evaluate(programs, "d_ggx", mu.astype(np.float32), np.full(mu.size, a, np.float32))
    expected = 2 * math.pi * np.sum(d.astype(np.float64) * mu * mu) / mu.size
    assert abs(h[:, 2].astype(np.float64).mean() - expected) < 1e-3, (h[:, 2].mean(), expected)


def test_tangent_to_world_is_orthonormal(programs):
    rng = np.random.default_rng(0)
    n = rng.normal(size=(512, 3))
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    n[:4] = [(0, 0, 1), (0, 0, -1), (1, 0, 0), (0, 0.99999994, -0.0003452669)]
    n = n.astype(np.float32)
    ez = evaluate(programs, "tangent_to_world", np.tile([0, 0, 1], (512, 1)), n)
    np.testing.assert_allclose(ez, n, atol=1e-6)
    ex = evaluate(programs, "tangent_to_world", np.tile([1, 0, 0], (512, 1)), n)
    ey = evaluate(programs, "tangent_to_world", np.tile([0, 1, 0], (512, 1)), n)
    for e in (ex, ey):
        np.testing.assert_allclose(np.linalg.norm(e, axis=1), 1.0, atol=1e-5)
        np.testing.assert_allclose(np.sum(e * n, axis=1), 0.0, atol=1e-5)
    np.testing.assert_allclose(np.sum(ex * ey, axis=1), 0.0, atol=1e-5)
    np.testing.assert_allclose(np.cross(ex, ey), n, atol=2e-5)  # right-handed
