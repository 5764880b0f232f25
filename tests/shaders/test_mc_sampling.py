"""Samplers of lib/mc.glsl and lib/env_sampling.glsl against their stated pdfs (GLSL on llvmpipe):
chi-square goodness of fit on independent uniform inputs (pbrt / Mitsuba style), pdfs integrating
to one, and the per-pixel (0, 2)-sequence."""
import math

import numpy as np
import pytest
from scipy import stats

from viewer.gl.kernels import evaluate

N = 200_000  # samples per chi-square test
ALPHA = 1e-3  # significance level of each goodness-of-fit test


def _sphere_bins(nz=20, nphi=40, lo=-1.0):
    """Equal-area bins in (z, phi) over z in [lo, 1]; returns edges and fine sub-directions per
    bin for integrating a pdf (midpoint rule, 8 x 8 per bin) -> dirs [bins, 64, 3], dw."""
    z_edges = np.linspace(lo, 1.0, nz + 1)
    phi_edges = np.linspace(0.0, 2 * math.pi, nphi + 1)
    sub = (np.arange(8) + 0.5) / 8
    zc = (z_edges[:-1, None] + np.diff(z_edges)[:, None] * sub[None]).ravel()  # [nz*8]
    pc = (phi_edges[:-1, None] + np.diff(phi_edges)[:, None] * sub[None]).ravel()
    Z, P = np.meshgrid(zc, pc, indexing="ij")
    r = np.sqrt(np.clip(1 - Z * Z, 0, 1))
    dirs = np.stack([r * np.cos(P), r * np.sin(P), Z], -1)  # [nz*8, nphi*8, 3]
    dirs = dirs.reshape(nz, 8, nphi, 8, 3).transpose(0, 2, 1, 3, 4).reshape(nz * nphi, 64, 3)
    dw = (z_edges[1] - z_edges[0]) / 8 * (phi_edges[1] - phi_edges[0]) / 8
    return z_edges, phi_edges, dirs, dw


def _histogram(d, z_edges, phi_edges):
    phi = np.mod(np.arctan2(d[:, 1], d[:, 0]), 2 * math.pi)
    h, _, _ = np.histogram2d(np.clip(d[:, 2], -1, 1), phi, bins=(z_edges, phi_edges))
    return h.ravel()


def _chi2_pvalue(observed, expected):
    """Pearson chi-square with bins of expected count < 5 pooled (Mitsuba's approach)."""
    small = expected < 5
    obs = np.append(observed[~small], observed[small].sum())
    exp = np.append(expected[~small], expected[small].sum())
    keep = exp > 0
    stat = float(((obs[keep] - exp[keep]) ** 2 / exp[keep]).sum())
    return stats.chi2.sf(stat, keep.sum() - 1), stat


def _uniform(n, seed):
    return np.random.default_rng(seed).uniform(size=(n, 2)).astype(np.float32)


def _goodness_of_fit(samples, pdf_of_dirs, lo=-1.0):
    z_edges, phi_edges, dirs, dw = _sphere_bins(lo=lo)
    pdf = pdf_of_dirs(dirs.reshape(-1, 3).astype(np.float32)).reshape(dirs.shape[:2])
    bin_prob = pdf.astype(np.float64).sum(axis=1) * dw
    observed = _histogram(samples.astype(np.float64), z_edges, phi_edges)
    p, stat = _chi2_pvalue(observed, bin_prob * len(samples))
    return p, bin_prob.sum()


@pytest.mark.parametrize("name,pdf", [
    ("sample_uniform_hemisphere", lambda d: np.where(d[:, 2] >= 0, 1 / (2 * math.pi), 0.0)),
    ("sample_cosine_hemisphere", None),
])
def test_hemisphere_samplers_fit_their_pdf(programs, name, pdf):
    d = evaluate(programs, name, _uniform(N, 1))
    if pdf is None:
        pdf = lambda dirs: evaluate(programs, "pdf_cosine_hemisphere", dirs[:, 2].copy())
    p, total = _goodness_of_fit(d, pdf, lo=0.0)
    assert p > ALPHA, p
    assert abs(total - 1.0) < 2e-3  # the stated pdf integrates to one over the hemisphere


def _reflect_vndf(programs, u, v, a):
    n = len(u)
    h = evaluate(programs, "sample_ggx_vndf", u, np.tile(v, (n, 1)).astype(np.float32),
                 np.full(n, a, np.float32))
    return 2 * (h @ v)[:, None] * h - v  # l = reflect(-v, h), tangent space


def _vndf_pdf(programs, v, a):
    def pdf(dirs):
        h = dirs + v
        h /= np.linalg.norm(h, axis=1, keepdims=True)
        n = len(dirs)
        return evaluate(programs, "pdf_ggx_vndf", np.full(n, v[2], np.float32),
                        h[:, 2].astype(np.float32), np.full(n, a, np.float32))
    return pdf


@pytest.mark.parametrize("theta_v,a", [(0.0, 0.5), (1.0, 0.3), (1.45, 0.6), (0.7, 1.0)])
def test_ggx_vndf_fits_its_pdf(programs, theta_v, a):
    """The reflected directions of VNDF half vectors follow pdf_ggx_vndf (= G1 D / (4 n.v)) over
    the whole sphere (directions below the horizon included: the estimator counts them as 0)."""
    v = np.array([math.sin(theta_v), 0.0, math.cos(theta_v)], np.float64)
    l = _reflect_vndf(programs, _uniform(N, 2), v.astype(np.float32), a)
    p, total = _goodness_of_fit(l, _vndf_pdf(programs, v.astype(np.float32), a))
    assert p > ALPHA, p
    assert abs(total - 1.0) < 5e-3, total


def test_vndf_is_finite_at_the_extremes(programs):
    u = np.array([[0.0, 0.0], [0.9999999, 0.9999999], [0.5, 0.0], [0.25, 0.9999999]], np.float32)
    vs = np.array([[0, 0, 1], [1, 0, 0], [0.6, 0.8, 0], [0.99999, 0, 0.0044]], np.float32)
    us, vv, aa = [], [], []
    for a in (0.0, 1e-8, 0.002025, 1.0):
        for v in vs:
            for uu in u:
                us.append(uu), vv.append(v), aa.append(a)
    h = evaluate(programs, "sample_ggx_vndf", np.array(us), np.array(vv), np.array(aa, np.float32))
    assert np.isfinite(h).all()
    np.testing.assert_allclose(np.linalg.norm(h, axis=1), 1.0, atol=1e-5)
    assert (h[:, 2] >= 0).all()
    pdf = evaluate(programs, "pdf_ggx_vndf", np.array(vv)[:, 2].copy(), h[:, 2].copy(),
                   np.array(aa, np.float32))
    assert np.isfinite(pdf).all() and (pdf >= 0).all()


@pytest.fixture(scope="module")
def sky_sampling(programs):
    from viewer.environment.ibl import IBLOptions, build_ibl
    from viewer.environment.maps import sky_environment
    from viewer.environment.sampling import build_env_sampling

    ibl = build_ibl(programs, sky_environment(64), IBLOptions(prefilter_levels=1,
                                                              prefilter_samples=1, dfg_size=4,
                                                              dfg_samples=4))
    es = build_env_sampling(programs, ibl.radiance)
    yield es
    es.release()
    ibl.release()


def test_environment_sampler_fits_its_pdf(programs, sky_sampling):
    """Texel frequencies of sampled directions follow p_uv / (W H) (chi-square over the 64 x 32
    texels, the distribution's own bins), and env_pdf integrates to one over the sphere."""
    from learned.parity.checks.env_sampling import eval_env_sampling

    u = _uniform(N, 3)
    out = eval_env_sampling(programs, sky_sampling, u, np.tile([0, 1, 0], (N, 1)).astype(np.float32))
    assert (out[:, 3] > 0).all() and np.isfinite(out).all()
    d = out[:, :3].astype(np.float64)
    pdf_uv = sky_sampling.read()["pdf"].astype(np.float64)  # [H, W]
    h, w = pdf_uv.shape
    uu = np.arctan2(d[:, 0], -d[:, 2]) / (2 * math.pi) + 0.5
    vv = np.arctan2(np.hypot(d[:, 0], d[:, 2]), d[:, 1]) / math.pi
    texel = (np.clip(np.floor(vv * h), 0, h - 1) * w + np.clip(np.floor(uu * w), 0, w - 1))
    observed = np.bincount(texel.astype(int), minlength=h * w).astype(np.float64)
    expected = pdf_uv.ravel() / (w * h) * N
    p, _ = _chi2_pvalue(observed, expected)
    assert p > ALPHA, p
    # the solid-angle pdf integrates to one (midpoint rule, 4 x 4 points per texel)
    th = (np.arange(4 * h) + 0.5) / (4 * h) * math.pi
    ph = (np.arange(4 * w) + 0.5) / (4 * w) * 2 * math.pi - math.pi
    T, P = np.meshgrid(th, ph, indexing="ij")
    dirs = np.stack([np.sin(T) * np.sin(P), np.cos(T), -np.sin(T) * np.cos(P)], -1).reshape(-1, 3)
    pdf = eval_env_sampling(programs, sky_sampling, np.zeros((len(dirs), 2), np.float32),
                            dirs.astype(np.float32))[:, 4].reshape(T.shape)
    integral = (pdf * np.sin(T)).sum() * (math.pi / (4 * h)) * (2 * math.pi / (4 * w))
    assert abs(integral - 1.0) < 1e-3, integral


def test_environment_pdf_matches_sampled_pdf(programs, sky_sampling):
    from learned.parity.checks.env_sampling import eval_env_sampling

    u = _uniform(4096, 4)
    out = eval_env_sampling(programs, sky_sampling, u, np.zeros((4096, 3), np.float32))
    again = eval_env_sampling(programs, sky_sampling, u, out[:, :3].copy())
    inner = np.abs(u[:, 0] * 64 - np.round(u[:, 0] * 64)) > 1e-3  # away from texel edges
    np.testing.assert_allclose(again[inner, 4], out[inner, 3], rtol=1e-3)


def test_pixel_sequences_are_stratified_deterministic_and_decorrelated(programs):
    n = 16
    idx = np.arange(n, dtype=np.float32)
    args = lambda px, seed, dim: (np.full(n, px, np.float32), np.full(n, 5, np.float32), idx,
                                  np.full(n, seed, np.float32), np.full(n, dim, np.float32))
    a = evaluate(programs, "mc_sample_2d", *args(3, 0, 0))
    assert np.array_equal(a, evaluate(programs, "mc_sample_2d", *args(3, 0, 0)))  # deterministic
    # (0, 2)-sequence with a digital shift: each 1/16 stratum in x and in y holds one point
    assert sorted(np.floor(a[:, 0] * n).astype(int)) == list(range(n))
    assert sorted(np.floor(a[:, 1] * n).astype(int)) == list(range(n))
    # and every 4x4 elementary interval one point
    cells = np.floor(a[:, 0] * 4).astype(int) * 4 + np.floor(a[:, 1] * 4).astype(int)
    assert sorted(cells) == list(range(16))
    for other in (args(4, 0, 0), args(3, 1, 0), args(3, 0, 1)):
        b = evaluate(programs, "mc_sample_2d", *other)
        assert not np.allclose(a, b)  # other pixel, seed or dimension: other scramble

