"""The GGX prefilter by convolution (viewer/environment/prefilter.py, passes/ibl_compose.comp): against a brute-
force float64 sum over every texel, through the GLSL lookups for a narrow (128-wide) map, and the
compose pass's GPU envelope."""
import math

import numpy as np
import pytest

from viewer.environment.ibl import IBLOptions, build_ibl, prefilter_roughness
from viewer.environment.maps import (
    EnvironmentSpec,
    load_environment,
    resample,
    studio_environment,
)
from viewer.environment.prefilter import (
    box_down,
    box_down_sparse,
    ggx_normalisation,
    level_widths,
    prefilter_levels,
    sun_points,
    sun_texels,
    working_map,
)
from viewer.environment.sun import extract_sun, texel_solid_angles

LUMA = np.array([0.2126, 0.7152, 0.0722])


def _points(h, w, sub=1):
    """Directions ``[h sub * w sub, 3]`` and solid angles of a ``w``-wide map's texels, each split
    into ``sub`` x ``sub`` parts."""
    hs, ws = h * sub, w * sub
    u = (np.arange(ws) + 0.5) / ws
    v = (np.arange(hs) + 0.5) / hs
    phi = 2 * np.pi * (u[None, :] - 0.5)
    th = np.pi * v[:, None]
    st = np.sin(th)
    d = np.stack(np.broadcast_arrays(st * np.sin(phi), np.cos(th), -st * np.cos(phi)), -1)
    return d.reshape(-1, 3), np.repeat(texel_solid_angles(hs, ws), ws)


def brute_force(env, dirs, alpha, sub=1):
    """The GGX (n = v = r) prefilter of ``env`` at unit ``dirs`` in float64, by summing the kernel
    D(h) max(n.l, 0) over every texel (each constant over its solid angle, integrated on ``sub`` x
    ``sub`` points), normalised by the kernel's sum."""
    h, w = env.shape[:2]
    pts, dw = _points(h, w, sub)
    rad = np.repeat(np.repeat(env[..., :3].astype(np.float64), sub, 0), sub, 1).reshape(-1, 3)
    a2 = alpha * alpha
    out = np.empty((len(dirs), 3))
    for i in range(0, len(dirs), 256):
        c = np.asarray(dirs[i:i + 256], np.float64) @ pts.T
        k = np.where(c > 0, a2 / (np.pi * (a2 + (1 - c) * (1 - a2) / 2) ** 2) * c, 0.0) * dw
        out[i:i + 256] = (k @ rad) / k.sum(1, keepdims=True)
    return out


def _spotty(width, seed=0):
    rng = np.random.default_rng(seed)
    env = rng.uniform(0.05, 1.0, size=(width // 2, width, 3)).astype(np.float32)
    env[width // 6, width // 5] = (80.0, 60.0, 40.0)
    env[width // 3: width // 3 + 2, width // 2: width // 2 + 3] = 20.0
    return env


def test_convolution_is_the_brute_force_sum():
    """Every level of a 64-wide map (worked at 64: each level's source is the map itself) equals
    the float64 sum over every texel to float32 rounding (measured max rel 1.1e-6): the FFT along
    the rows is that sum, reordered."""
    env = _spotty(64)
    rough = [prefilter_roughness(k, 5) for k in range(5)]
    levels = prefilter_levels(working_map(env, 64), rough)
    for k, level in enumerate(levels, start=1):
        h, w = level.shape[:2]
        d, _ = _points(h, w)
        ref = brute_force(env, d, rough[k] ** 2).reshape(h, w, 3)
        np.testing.assert_allclose(level, ref, rtol=2e-5, atol=0)


def test_normalisation_and_helpers():
    for alpha in (1 / 32, 1 / 16, 0.25, 0.5, 0.995, 1.0):
        u = (np.arange(400_000) + 0.5) / 400_000  # u = 1 - n.l
        a2 = alpha * alpha
        k = a2 / (np.pi * (a2 + u * (1 - a2) / 2) ** 2) * (1 - u)
        assert ggx_normalisation(alpha) == pytest.approx(2 * np.pi * k.mean(), rel=1e-5)
    # box_down keeps the solid-angle weighted mean; the sparse version matches the dense one
    env = _spotty(32)
    dw = texel_solid_angles(16, 32)[:, None, None]
    half = box_down(env)
    dw2 = texel_solid_angles(8, 16)[:, None, None]
    assert (half * dw2).sum() == pytest.approx((env * dw).sum(), rel=1e-6)
    sparse = np.zeros_like(env)
    ys, xs = np.array([3, 3, 10]), np.array([5, 6, 31])
    sparse[ys, xs] = [(1.0, 2.0, 3.0), (4.0, 5.0, 6.0), (7.0, 8.0, 9.0)]
    by, bx, bv = box_down_sparse((ys, xs, sparse[ys, xs]), 16, 32, 2)
    dense = box_down(box_down(sparse))
    got = np.zeros_like(dense)
    got[by, bx] = bv
    np.testing.assert_allclose(got, dense, rtol=1e-6, atol=1e-7)
    assert level_widths(2048, 512, 6) == [256, 128, 128, 128, 64]
    assert level_widths(128, 512, 6) == [64, 32, 16, 8, 4]


def test_sun_points_carry_the_sun():
    """The points' energy is the sun's irradiance (to float32), at most 256 of them, and the
    finest level's points are within the sun's disc."""
    env = load_environment(EnvironmentSpec(procedural="sky", width=256))
    residual, sun = extract_sun(env)
    texels = sun_texels(env, residual)
    for k in range(1, 6):
        alpha = prefilter_roughness(k, 6) ** 2
        pts = sun_points(texels, 128, 256, alpha)
        assert 1 <= len(pts) <= 256
        np.testing.assert_allclose(pts[:, 3:].sum(0) * ggx_normalisation(alpha), sun.irradiance,
                                   rtol=1e-5)
        cos = pts[:, :3] @ np.array(sun.direction)
        assert cos.min() > math.cos(2 * sun.angular_radius + 0.05)


# ---- a narrow map, through the GLSL lookups -------------------------------------------------

ROUGHNESS = (0.3, 0.5, 0.7, 0.9)
# The envelope a 128-wide map's split-sum lookups (ibl_specular_radiance at random directions)
# stay in against the brute-force GGX filter of the same map: energy bias (mean lookup / mean
# filter - 1) within 1 % at each roughness, and the median per-lookup relative error within
# MEDIAN. Measured (park.exr and the procedural studio, both resampled to 128x64, 1000
# directions): bias within 0.4 %, medians 1.0-4.4 / 0.2-0.8 / 0.4-0.9 / 0.9-3.0 %: what is left is
# the lookup's linear blend between two levels (alpha halves per level), not the map's size. With
# the chain at the map's own size (the "fis" method before, levels down to 4x2 texels) the
# bias was -0.7 / -0.5 / -2.5 / -6.7 % and the medians 1.7-7.4 / 2.7-10 / 5-10 / 9-15 %.
MEDIAN = {0.3: 0.06, 0.5: 0.015, 0.7: 0.015, 0.9: 0.045}
BIAS = 0.01


def _narrow_maps():
    park = load_environment(EnvironmentSpec(path=str(_asset("park.exr"))))
    return {"park": resample(park, 128, 64), "studio": studio_environment(128)}


def _asset(name):
    from assets import ASSET_ROOT

    return ASSET_ROOT / "environments" / name


def _lookup_errors(programs, ibl, env, n=1000):
    from learned.parity.checks.ibl import _eval_lookups

    rng = np.random.default_rng(0)
    dirs = rng.normal(size=(n, 3))
    dirs = (dirs / np.linalg.norm(dirs, axis=1, keepdims=True)).astype(np.float32)
    out = {}
    for r in ROUGHNESS:
        rough = np.full(n, r, np.float32)
        spec = _eval_lookups(programs, ibl, dirs, rough, np.full(n, 0.5, np.float32),
                             np.ones(n, np.float32))[0]
        ref = brute_force(env, dirs, r * r, sub=2)
        g, f = spec @ LUMA, ref @ LUMA
        out[r] = (float(g.mean() / f.mean() - 1.0), float(np.median(np.abs(g - f) / f)),
                  spec, dirs, rough)
    return out


@pytest.mark.filterwarnings("ignore:.*negative, NaN or Inf")
def test_narrow_map_lookups_stay_in_the_envelope(programs):
    """A 128-wide map's chain is built 512 wide (its source upsampled): every roughness lands on
    a level with enough texels. The old chain (at the map's own size) leaves the envelope, so the
    test can fail. Why it holds on other GPUs: the convolution is the same CPU sum everywhere, and
    a GPU's texture unit (8-bit filter weights) moves a lookup by at most what
    sample_trilinear_envelope bounds (median 0.08-0.5 % of the value here), which the test adds to
    the measured bias and median before comparing them with the envelope."""
    torch = pytest.importorskip("torch")
    from learned.twins.equirect import equirect_uv
    from learned.twins.ibl import (
        equirect_uv_error,
        prefilter_lod,
        sample_trilinear_envelope,
    )

    for name, env in _narrow_maps().items():
        ibl = build_ibl(programs, env, IBLOptions(dfg_size=16, dfg_samples=64))
        old = build_ibl(programs, env, IBLOptions.legacy(dfg_size=16, dfg_samples=64))
        try:
            assert ibl.prefiltered.size == (512, 256) and old.prefiltered.size == (128, 64)
            new_err = _lookup_errors(programs, ibl, env)
            old_err = _lookup_errors(programs, old, env)
            chain = [torch.from_numpy(ibl.read_level("prefiltered", k)) for k in range(ibl.levels)]
            for r in ROUGHNESS:
                bias, median, spec, dirs, rough = new_err[r]
                d = torch.from_numpy(dirs)
                lod = prefilter_lod(torch.from_numpy(rough), torch.tensor(float(ibl.levels)))
                bound = sample_trilinear_envelope(chain, equirect_uv(d), lod,
                                                  equirect_uv_error(d, 0.0), weight_bits=8)
                gpu = np.median(bound[..., :3].numpy() @ LUMA / (spec @ LUMA))
                # with a GPU's filter deviation (its bound's median) added, still inside
                assert abs(bias) + gpu <= BIAS and median + gpu <= MEDIAN[r], (name, r, gpu)
            assert any(abs(old_err[r][0]) > BIAS or old_err[r][1] > MEDIAN[r]
                       for r in ROUGHNESS), (name, old_err)
        finally:
            ibl.release()
            old.release()


def test_compose_envelope_covers_a_gpu(programs):
    """compose_level_envelope's sun part holds for the twin run with texel directions off by the
    assumed sin/cos error and is not vacuous: directions off by 100x that error leave it. (Its
    resampling part is sample_trilinear_envelope's, tested in test_ibl.py; 4x upsampling's weights
    are multiples of 1/8, exact in a GPU's 8 bits.)"""
    torch = pytest.importorskip("torch")
    from learned.twins import ibl_precompute as pre

    rng = np.random.default_rng(4)
    # a constant level: the resampling's share of the bound is then 0, and the sun's alone is tested
    work = torch.full((8, 16, 3), 0.5)
    centre = np.array([0.3, 0.6, -0.74])
    dirs = centre + rng.normal(0.0, 0.02, size=(24, 3))
    dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
    pts = torch.from_numpy(np.concatenate([dirs, rng.uniform(0.0, 0.05, size=(24, 3))], 1)
                           .astype(np.float32))
    a2 = (1.0 / 16.0) ** 2
    size = (32, 64)
    exact = pre.compose_level(work, size, pts, a2)
    bound = pre.compose_level_envelope(work, size, pts, a2)
    real = pre._texel_dirs

    def moved(scale):
        def dirs_off(h, w):
            uv, n = real(h, w)
            g = torch.Generator().manual_seed(1)
            return uv, n + (2 * torch.rand(n.shape, generator=g) - 1) * scale * 4e-6 / math.sqrt(3)
        return dirs_off

    for scale, inside in ((1.0, True), (100.0, False)):
        pre._texel_dirs = moved(scale)
        try:
            got = pre.compose_level(work, size, pts, a2)
        finally:
            pre._texel_dirs = real
        assert bool(((got - exact).abs() <= bound).all()) == inside, scale
