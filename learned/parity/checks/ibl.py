"""IBL precomputation passes and lookups (``passes/ibl_*.comp``, ``lib/ibl.glsl``, ``lib/sh.glsl``)
against :mod:`learned.twins.ibl` and :mod:`learned.twins.ibl_precompute`: downsampling, GGX
prefiltering by importance sampling, the composition of a convolved level with the sun
(``ibl_compose``), SH projection, the DFG LUT and the filtered lookups, the filtered ones against
per-output error envelopes."""
from __future__ import annotations

import numpy as np
import torch

from learned.twins.equirect import equirect_uv
from learned.twins.ibl import (
    dfg_lut,
    dominant_lut,
    equirect_uv_error,
    ibl_dfg,
    ibl_dominant_factor,
    ibl_specular_radiance,
    ibl_specular_radiance_sun,
    irradiance_lookup,
    prefilter_environment,
    prefilter_level_envelope,
    prefilter_lod,
    radiance_chain,
    sample_trilinear_envelope,
    sh_project,
)
from learned.twins.ibl_precompute import compose_level as compose_level_twin
from learned.twins.ibl_precompute import compose_level_envelope
from learned.twins.sh import sh_irradiance
from viewer.environment.ibl import (
    IBLOptions,
    build_ibl,
    prefilter_roughness,
    prefilter_samples,
)
from viewer.environment.ibl_build import compose_level, mip_texture
from viewer.gl.kernels import run_kernel

from ..results import compare, compare_envelope, device_filter_bits
from . import collector


def parity_environment(width: int = 64, seed: int = 0) -> np.ndarray:
    """A small ``[width/2, width, 3]`` environment for pass checks: random positive radiance plus
    a bright 3x3 spot (so the prefilter and SH see a high-frequency feature)."""
    rng = np.random.default_rng(seed)
    h = width // 2
    env = rng.uniform(0.05, 1.0, size=(h, width, 3)).astype(np.float32)
    env[h // 3: h // 3 + 3, width // 5: width // 5 + 3] = (40.0, 30.0, 20.0)
    return env


def checks() -> dict:
    """This module's pass checks: name -> (model or None, check(programs) -> results)."""
    found, register_pass_check = collector()


    cache: dict = {}

    def built(programs):
        """One small IBL per programs object, shared by the checks (and torch chains)."""
        key = id(programs)
        if key not in cache:

            env = parity_environment()
            # the importance-sampled chain, whose pass ibl_prefilter is checked here (the
            # convolution method's GPU part is ibl_compose, checked below)
            opts = IBLOptions(prefilter_levels=5, prefilter_method="fis", prefilter_samples=32,
                              dfg_size=32, dfg_samples=128)
            ibl = build_ibl(programs, env, opts)
            cache.clear()
            cache[key] = (env, opts, ibl, device_filter_bits(programs))
        return cache[key]

    @register_pass_check("ibl_downsample")
    def check_downsample(programs):
        env, opts, ibl, bits = built(programs)
        chain = radiance_chain(torch.from_numpy(env))
        gl = np.concatenate([ibl.read_level("radiance", k)[..., :3].ravel()
                             for k in range(len(chain))])
        ref = np.concatenate([c.numpy().ravel() for c in chain])
        bound = np.concatenate([b.ravel() for b in _downsample_envelope(chain)])
        return [compare_envelope(
            "ibl_downsample", gl, ref, bound,
            measured="max rel 3e-7 (sin of the row weights), all 7 levels of a 64x32 env",
            envelope="per texel: the row weights' sin (1e-6 abs each, no GLSL requirement) "
                     "moves (top w0 + bottom w1) / (w0 + w1) by |top - bottom| 1e-6 / "
                     "(w0 + w1); 8 ulp of the result for the arithmetic; plus the largest "
                     "bound of the four source texels (level k reads the GPU's level k - 1)")]

    @register_pass_check("ibl_prefilter")
    def check_prefilter(programs):
        env, opts, ibl, bits = built(programs)
        chain = radiance_chain(torch.from_numpy(env))
        with torch.no_grad():
            samples = [prefilter_samples(k, opts.prefilter_samples) for k in range(ibl.levels)]
            ref = prefilter_environment(
                chain, [prefilter_roughness(k, ibl.levels) for k in range(ibl.levels)], samples)
            bound = [torch.zeros_like(chain[0])] + [
                prefilter_level_envelope(chain, tuple(chain[k].shape[:2]),
                                         prefilter_roughness(k, ibl.levels),
                                         samples[k], weight_bits=bits)
                for k in range(1, ibl.levels)]
        gl = np.concatenate([ibl.read_level("prefiltered", k)[..., :3].ravel()
                             for k in range(ibl.levels)])
        ref = np.concatenate([r[..., :3].numpy().ravel() for r in ref])
        bound = np.concatenate([b[..., :3].numpy().ravel() for b in bound])
        return [compare_envelope(
            "ibl_prefilter", gl, ref, bound,
            measured="max abs 5.2e-4 (values to 40), 3% of the envelope; 4.1e-4 / 2.7e-4 rel "
                     "before D came from xi (ggx_sample_d) instead of 1 - n.h",
            envelope="per texel: n.l-weighted mean over the 32 samples of each lookup's "
                     "sample_trilinear_envelope (the device's measured filter-weight and lod "
                     "fraction bits: 16 on llvmpipe, 8 on GPUs; uv error from sin/cos/atan) + "
                     "2 S ulp summation; level 0 is a copy (exact)")]

    @register_pass_check("ibl_compose")
    def check_compose(programs):
        """A 16x8 convolved level composed into 64x32 (4x upsampling, both poles) and into 16x8
        (a copy), with 24 sun points clustered round one direction and two far from it."""
        rng = np.random.default_rng(3)
        work = rng.uniform(0.05, 2.0, size=(8, 16, 3)).astype(np.float32)
        work[2, 5] = (30.0, 20.0, 10.0)
        centre = np.array([0.3, 0.6, -0.74])
        dirs = centre + rng.normal(0.0, 0.02, size=(26, 3))
        dirs[-2:] = ((0.0, -1.0, 0.0), (0.9, 0.1, 0.4))
        dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
        pts = np.concatenate([dirs, rng.uniform(0.0, 0.05, size=(26, 3))], 1).astype(np.float32)
        a2 = (1.0 / 16.0) ** 2
        gl, ref, bound = [], [], []
        for w_dst in (64, 16):
            dst = mip_texture(programs.ctx, w_dst, w_dst // 2, 1)
            try:
                compose_level(programs, dst, 0, work, pts, a2)
                gl.append(np.frombuffer(dst.read(), np.float32).reshape(
                    w_dst // 2, w_dst, 4)[..., :3].ravel())
            finally:
                dst.release()
            with torch.no_grad():
                t_work, t_pts = torch.from_numpy(work), torch.from_numpy(pts)
                size = (w_dst // 2, w_dst)
                ref.append(compose_level_twin(t_work, size, t_pts, a2).numpy().ravel())
                bound.append(compose_level_envelope(t_work, size, t_pts, a2,
                                                    weight_bits=device_filter_bits(programs)
                                                    ).numpy().ravel())
        return [compare_envelope(
            "ibl_compose", np.concatenate(gl), np.concatenate(ref), np.concatenate(bound),
            measured="max abs 1.1e-5, max rel 6.1e-7 (values to 30 + the sun's lobe)",
            envelope="per texel: the resampling's lookups (sample_trilinear_envelope at lod 0 "
                     "with the device's filter bits, both taps of a pole row) + 4 ulp, plus per "
                     "sun point the kernel's response to the direction's sin/cos error (|d ln k "
                     "/ du| 2 |n - l| 4e-6) and 16 ulp, + P ulp of the sum")]

    @register_pass_check("ibl_sh")
    def check_sh(programs):
        env, opts, ibl, bits = built(programs)
        ref = sh_project(torch.from_numpy(env)).numpy()
        scale = float(np.abs(ref).max())
        return [compare("ibl_sh", ibl.sh, ref, atol=1e-6 * scale, rtol=1e-5, kind="pass",
                        measured="max abs 1.9e-7, max rel 2.4e-7 (runs of 64 texels summed in "
                                 "float32, then float64)",
                        envelope="per texel term ~12 ops incl. sin (1e-6 abs assumed) -> "
                                 "~1e-6 x |term|; float64 reduction: atol 1e-6 x the largest "
                                 "coefficient covers cancellation in the summed terms")]

    @register_pass_check("ibl_dfg_lut")
    def check_dfg(programs):
        env, opts, ibl, bits = built(programs)
        with torch.no_grad():
            ref = dfg_lut(opts.dfg_size, opts.dfg_samples).numpy()
        return [compare("ibl_dfg_lut", ibl.read_level("dfg"), ref, atol=5e-6, rtol=1e-5,
                        kind="pass", measured="max abs 1.9e-6, max rel 2.8e-6 (n.v = 1e-4 row)",
                        envelope="128 terms <= 1 of ~30 ops (sqrt, 2.5-ulp divisions): 30 ulp "
                                 "each = 3.6e-6 rel, sequential float32 sum <= 128 x 2^-24 = "
                                 "7.6e-6 rel: 1.1e-5 at values ~1")]

    @register_pass_check("ibl_dominant_lut")
    def check_dominant(programs):
        env, opts, ibl, bits = built(programs)
        with torch.no_grad():
            ref = dominant_lut(opts.dfg_size, opts.dfg_samples).numpy()
        return [compare("ibl_dominant_lut", ibl.read_level("dominant"), ref, atol=2e-5, rtol=0.0,
                        kind="pass", measured="max abs 2.1e-6 (roughness 0 row)",
                        envelope="t (<= 1) is the ratio of two float32 sums of 128 terms of ~30 "
                                 "ops each (30 ulp) with cancellation between terms of either "
                                 "sign in m.x: 2 x (30 + 128) ulp = 1.9e-5")]

    @register_pass_check("ibl_lookups")
    def check_lookups(programs):
        env, opts, ibl, bits = built(programs)
        n = 4096
        rng = np.random.default_rng(1)
        dirs = rng.normal(size=(n, 3)).astype(np.float32)
        dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
        rough = rng.uniform(0.0, 1.0, size=n).astype(np.float32)
        rough[:8] = (0.0, 1.0, 0.25, 0.5, 0.75, 0.045, 1e-3, 0.999)
        nov = rng.uniform(0.0, 1.0, size=n).astype(np.float32)
        nov[:4] = (0.0, 1.0, 1e-4, 0.5)
        w = rng.uniform(0.0, 1.0, size=n).astype(np.float32)
        w[:4] = (0.0, 1.0, 0.5, 0.999)
        w[4:n // 4] = 1.0  # the one-lookup branch
        spec_gl, dfg_gl, dom_gl, sun_gl = _eval_lookups(programs, ibl, dirs, rough, nov, w)
        pre = [torch.from_numpy(ibl.read_level("prefiltered", k)) for k in range(ibl.levels)]
        rad = [torch.from_numpy(ibl.read_level("radiance", k)) for k in range(ibl.levels)]
        lut = torch.from_numpy(ibl.read_level("dfg"))
        dom_lut = torch.from_numpy(ibl.read_level("dominant"))
        with torch.no_grad():
            dom = ibl_dominant_factor(dom_lut, torch.from_numpy(nov), torch.from_numpy(rough))
            dom = dom.numpy()
            spec = ibl_specular_radiance(pre, torch.from_numpy(dirs), torch.from_numpy(rough),
                                         float(ibl.levels)).numpy()
            dfg = ibl_dfg(lut, torch.from_numpy(nov), torch.from_numpy(rough)).numpy()
            lod = prefilter_lod(torch.from_numpy(rough), torch.tensor(float(ibl.levels)))
            d = torch.from_numpy(dirs)
            # the input directions are exact: only atan's error moves uv
            bound = sample_trilinear_envelope(pre, equirect_uv(d), lod,
                                              equirect_uv_error(d, 0.0), weight_bits=bits)[..., :3]
            bound = (bound + 4.0 * 2.0 ** -24 * torch.from_numpy(spec).abs()).numpy()
            wt = torch.from_numpy(w)
            sun = ibl_specular_radiance_sun(pre, rad, d, torch.from_numpy(rough),
                                            float(ibl.levels), wt).numpy()
            # the mix of the two lookups' envelopes (it is linear in both) + 4 ulp of the mix
            rad_bound = sample_trilinear_envelope(rad, equirect_uv(d), lod,
                                                  equirect_uv_error(d, 0.0),
                                                  weight_bits=bits)[..., :3].numpy()
            w3 = w[:, None]
            sun_bound = np.where(w3 < 1.0, w3 * bound + (1.0 - w3) * rad_bound, bound) \
                + 4.0 * 2.0 ** -24 * np.abs(sun)
            size = torch.tensor([float(lut.shape[1]), float(lut.shape[0])])
            x = torch.stack([torch.from_numpy(nov).clamp(0.0, 1.0),
                             torch.from_numpy(rough).clamp(0.0, 1.0)], -1)
            uv_lut = (x * (size - 1.0) + 0.5) / size
            dfg_bound = (sample_trilinear_envelope(
                [lut], uv_lut, torch.zeros(n), torch.full_like(uv_lut, 1e-6), repeat_u=False,
                weight_bits=bits)[..., :2] + 1e-5 + 1e-4 * torch.from_numpy(dfg).abs()).numpy()
            dom_bound = (sample_trilinear_envelope(
                [dom_lut], uv_lut, torch.zeros(n), torch.full_like(uv_lut, 1e-6),
                repeat_u=False, weight_bits=bits)[..., 0] + 1e-5).numpy()
        return [compare_envelope(
                    "ibl_specular_radiance", spec_gl, spec, bound,
                    measured="max abs 4.7e-4 (values to 40), uv (atan) differences times "
                             "texel contrast",
                    envelope="per lookup: sample_trilinear_envelope (the device's measured "
                             "filter bits, atan error 8e-6 rad) + 4 ulp"),
                compare_envelope(
                    "ibl_specular_radiance_sun", sun_gl, sun, sun_bound,
                    measured="max abs 5.1e-4 (values to 40), as ibl_specular_radiance",
                    envelope="per lookup as ibl_specular_radiance, mixed with w as the values "
                             "are, + 4 ulp of the mix"),
                compare_envelope(
                    "ibl_dfg", dfg_gl, dfg, dfg_bound, measured="max abs 6e-8",
                    envelope="per lookup: sample_trilinear_envelope of the LUT (measured filter "
                             "bits, uv from clamps and one fma: 1e-6) + 1e-5 + 1e-4 rel"),
                compare_envelope(
                    "ibl_dominant_factor", dom_gl, dom, dom_bound, measured="max abs 6e-8",
                    envelope="per lookup: sample_trilinear_envelope of the LUT (as ibl_dfg) "
                             "+ 1e-5")]

    @register_pass_check("irradiance_lookup")
    def check_irradiance_lookup(programs):
        env, opts, ibl, bits = built(programs)
        irr = ibl.read_level("irradiance")
        rng = np.random.default_rng(3)
        n = 4096
        normals = rng.normal(size=(n, 3)).astype(np.float32)
        normals[:4] = ((0.0, 1.0, 0.0), (0.0, -1.0, 0.0), (1.0, 0.0, 0.0), (0.0, 0.0, -1.0))
        normals /= np.linalg.norm(normals, axis=1, keepdims=True)
        gl = eval_irradiance_lookup(programs, ibl.irradiance, normals)
        with torch.no_grad():
            t = torch.from_numpy(irr)
            d = torch.from_numpy(normals)
            ref = irradiance_lookup(t, d).numpy()
            uv = equirect_uv(d)
            h = float(irr.shape[0])
            uv = torch.stack([uv[..., 0], (uv[..., 1] * (h - 1.0) + 0.5) / h], -1)
            # at the poles u is undefined (the envelope is NaN) and every texel of the first
            # and last rows holds the pole's value: only the 4 ulp remain there
            bound = (torch.nan_to_num(sample_trilinear_envelope(
                [t], uv, torch.zeros(n), equirect_uv_error(d, 0.0) + 1e-7,
                weight_bits=bits)[..., :3], nan=0.0)
                + 4.0 * 2.0 ** -24 * torch.from_numpy(ref).abs()).numpy()
        return [compare_envelope(
            "irradiance_lookup", gl, ref, bound, measured="max abs 8.8e-6, max rel 3.3e-6 (llvmpipe)",
            envelope="per lookup: sample_trilinear_envelope of the map (measured filter bits, "
                     "atan error + 1e-7 for the row remap's fma) + 4 ulp")]

    @register_pass_check("sh_irradiance")
    def check_sh_irradiance(programs):
        rng = np.random.default_rng(2)
        sh = rng.normal(size=(9, 3)).astype(np.float32)
        sh[0] += 4.0  # mostly positive irradiance, some clamped
        n = 4096
        normals = rng.normal(size=(n, 3)).astype(np.float32)
        normals /= np.linalg.norm(normals, axis=1, keepdims=True)
        gl = eval_sh_irradiance(programs, normals, sh)
        with torch.no_grad():
            ref = sh_irradiance(torch.from_numpy(normals), torch.from_numpy(sh)).numpy()
        return [compare("sh_irradiance", gl, ref, atol=1e-5, rtol=1e-5, kind="pass",
                        measured="max abs 1.9e-6, max rel 5.9e-7",
                        envelope="9-term polynomial, ~25 ops: 25 ulp x sum |terms| (<= 4x the "
                                 "result for these coefficients) = 1.2e-5 x result; atol where "
                                 "the clamp at 0 meets cancellation")]
    return found


def _downsample_envelope(chain: list[torch.Tensor]) -> list[np.ndarray]:
    """Per-texel bound ``[h, w, 3]`` on |GPU - twin| for every level of the radiance chain (see
    check_downsample)."""
    out = [np.zeros(chain[0][..., :3].shape, np.float32)]
    for k in range(1, len(chain)):
        src, dst = chain[k - 1][..., :3].numpy(), chain[k][..., :3].numpy()
        h, w = src.shape[:2]
        ho, wo = dst.shape[:2]
        y0 = np.minimum(2 * np.arange(ho), h - 1)
        y1 = np.minimum(2 * np.arange(ho) + 1, h - 1)
        x0 = np.minimum(2 * np.arange(wo), w - 1)
        x1 = np.minimum(2 * np.arange(wo) + 1, w - 1)
        top = src[y0][:, x0] + src[y0][:, x1]
        bottom = src[y1][:, x0] + src[y1][:, x1]
        w0 = np.sin(np.pi * (y0 + 0.5) / h)[:, None, None]
        w1 = np.sin(np.pi * (y1 + 0.5) / h)[:, None, None]
        prev = out[-1]
        children = np.maximum(np.maximum(prev[y0][:, x0], prev[y0][:, x1]),
                              np.maximum(prev[y1][:, x0], prev[y1][:, x1]))
        out.append((0.5 * np.abs(top - bottom) * 1e-6 / (w0 + w1) + 8.0 * 2.0 ** -24
                    * np.abs(dst) + children).astype(np.float32))
    return out


def _eval_lookups(programs, ibl, dirs, rough, nov, w):
    """GL ``ibl_specular_radiance``, ``ibl_dfg``, ``ibl_dominant_factor`` and
    ``ibl_specular_radiance_sun`` (its second chain: the radiance chain, which differs from the
    prefiltered one wherever the mix matters) on the textures of ``ibl``."""
    def setup(prog):
        ibl.prefiltered.use(location=0)
        ibl.dfg.use(location=1)
        ibl.dominant.use(location=2)
        ibl.radiance.use(location=3)
        prog["u_pre"].value = 0
        prog["u_lut"].value = 1
        prog["u_dominant"].value = 2
        prog["u_pre_full"].value = 3
        prog["u_levels"].value = float(ibl.levels)

    inputs = np.concatenate([dirs, rough[:, None], nov[:, None], w[:, None]], axis=1)
    out = run_kernel(programs, "passes/parity_ibl_lookups.comp", inputs, 9, setup)
    return out[:, :3], out[:, 3:5], out[:, 5], out[:, 6:9]


def eval_irradiance_lookup(programs, texture, normals: np.ndarray) -> np.ndarray:
    """GL ``irradiance_lookup`` of the irradiance map ``texture`` at unit normals ``[n, 3]``."""
    def setup(prog):
        texture.use(location=0)
        prog["u_irradiance"].value = 0

    return run_kernel(programs, "passes/parity_irradiance_lookup.comp", normals, 3, setup)


def eval_sh_irradiance(programs, normals: np.ndarray, sh: np.ndarray) -> np.ndarray:
    """GL ``sh_irradiance`` for unit normals ``[n, 3]`` and coefficients ``[9, 3]`` -> ``[n, 3]``."""
    def setup(prog):
        prog["u_sh"].write(np.ascontiguousarray(sh, dtype=np.float32).tobytes())

    return run_kernel(programs, "passes/parity_sh_irradiance.comp", normals, 3, setup)
