"""Twins of ``shaders/lib/ibl.glsl`` and of the IBL precompute passes (``shaders/passes/ibl_*.comp``).

Textures are lists of mip levels, each ``[h_k, w_k, C]`` float32 with row 0 first (as uploaded to
GL). :func:`sample_bilinear` / :func:`sample_trilinear` reproduce GL filtering: texel centres at
(i + 0.5) / size, GL_REPEAT in u, CLAMP_TO_EDGE in v (``repeat_u=False`` clamps u too, as the DFG
LUT does), LINEAR_MIPMAP_LINEAR between levels ``floor(lod)`` and ``floor(lod) + 1``.

The precompute twins (:func:`downsample_box`, :func:`prefilter_environment`, :func:`sh_project`,
:func:`dfg_lut`) use the same Hammersley sequences and the same operation order as the passes.
This module also registers the pass-level parity checks (``learned.parity.PASS_CHECKS``) at import.
"""
from __future__ import annotations

import math

import torch

from .brdf import f_schlick, v_smith_ggx_correlated
from .equirect import equirect_dir, equirect_uv
from .sampling import (
    ggx_sample_d,
    hammersley_sequence,
    importance_sample_ggx,
    tangent_to_world,
)
from .sh import sh_basis_all

# ---------------------------------------------------------------------------------------------
# GL texture filtering
# ---------------------------------------------------------------------------------------------

def _quantise(f: torch.Tensor, bits: int | None) -> torch.Tensor:
    """A filter weight in [0, 1) truncated to ``bits`` fraction bits, as a GPU texture unit may
    (``None``: float32, as llvmpipe and the GLSL spec's ideal filter)."""
    if bits is None:
        return f
    return torch.floor(f * float(2 ** bits)) / float(2 ** bits)


def sample_bilinear(level: torch.Tensor, uv: torch.Tensor, repeat_u: bool = True,
                    weight_bits: int | None = None) -> torch.Tensor:
    """GL_LINEAR lookup of one level ``[h, w, C]`` at ``uv [..., 2]`` -> ``[..., C]``.
    ``weight_bits`` models a GPU's fixed-point filter weights (see FILTER_WEIGHT_BITS)."""
    h, w = level.shape[:2]
    x = uv[..., 0] * w - 0.5
    y = uv[..., 1] * h - 0.5
    x0 = torch.floor(x)
    y0 = torch.floor(y)
    fx = _quantise(x - x0, weight_bits)[..., None]
    fy = _quantise(y - y0, weight_bits)[..., None]
    x0 = x0.to(torch.int64)
    y0 = y0.to(torch.int64)
    if repeat_u:
        xa, xb = torch.remainder(x0, w), torch.remainder(x0 + 1, w)
    else:
        xa, xb = x0.clamp(0, w - 1), (x0 + 1).clamp(0, w - 1)
    ya, yb = y0.clamp(0, h - 1), (y0 + 1).clamp(0, h - 1)
    t00, t10 = level[ya, xa], level[ya, xb]
    t01, t11 = level[yb, xa], level[yb, xb]
    top = t00 + (t10 - t00) * fx
    bottom = t01 + (t11 - t01) * fx
    return top + (bottom - top) * fy


def sample_trilinear(levels: list[torch.Tensor], uv: torch.Tensor, lod: torch.Tensor,
                     repeat_u: bool = True, weight_bits: int | None = None) -> torch.Tensor:
    """GL_LINEAR_MIPMAP_LINEAR ``textureLod`` on a mip chain; lod ``[...]`` clamped to the chain.
    ``weight_bits``: fixed-point bilinear weights and lod fraction, as a GPU (default float32)."""
    lod = lod.clamp(0.0, float(len(levels) - 1))
    base = torch.floor(lod)
    frac = _quantise(lod - base, weight_bits)[..., None]
    base = base.to(torch.int64)
    out = torch.zeros(*uv.shape[:-1], levels[0].shape[-1], dtype=levels[0].dtype)
    for k in range(len(levels)):
        lo = base == k
        hi = (base == k - 1) & (frac[..., 0] > 0)
        if not (lo.any() or hi.any()):
            continue
        s = sample_bilinear(levels[k], uv, repeat_u, weight_bits)
        out = out + torch.where(lo[..., None], s * (1.0 - frac), 0.0) \
                  + torch.where(hi[..., None], s * frac, 0.0)
    return out


# ---------------------------------------------------------------------------------------------
# What a GPU's texture unit may do differently: the error envelope of a filtered lookup
# ---------------------------------------------------------------------------------------------
#
# The twins above filter in float32, as llvmpipe does. GPU texture units do not: they quantise the
# bilinear weights and the lod fraction to a few bits (Vulkan reports 8 subTexelPrecisionBits and
# 8 mipmapPrecisionBits on NVIDIA, AMD, Intel and Apple GPUs, and allows as few as 4; OpenGL does
# not expose the numbers), so one lookup may differ from the float twin by 2^-8 of the difference
# between neighbouring texels - near a 40:1 sun, by ~0.2 where float32 rounding is 1e-6. The
# coordinates differ too: uv comes from atan(), whose precision GLSL leaves undefined, and a
# direction error of delta moves the lookup by delta * size texels. The parity checks of passes
# that filter textures therefore compare against a per-output bound computed here from the very
# taps each lookup reads, instead of a fixed tolerance tuned on one machine.

FILTER_WEIGHT_BITS = 8      # bilinear weight and lod fraction precision assumed for a GPU
DIRECTION_ABS_ERROR = 4e-6  # |error| of a direction built with sin/cos (3 evaluations, ~1e-6 each)
ATAN_ABS_ERROR = 8e-6       # |error| of atan() in radians: no GLSL requirement; llvmpipe's
                            # polynomial measured 3.4e-6 (equirect_uv, 200k directions), GPUs a
                            # few ulp


def equirect_uv_error(d: torch.Tensor, direction_error: float = DIRECTION_ABS_ERROR
                      ) -> torch.Tensor:
    """Bound ``[..., 2]`` on |uv error| of ``equirect_uv(d)`` for a unit direction known to within
    ``direction_error``: u = atan(x, -z) / 2 pi is ill conditioned near the poles (1 / rho)."""
    rho = torch.sqrt(d[..., 0] * d[..., 0] + d[..., 2] * d[..., 2])
    du = (direction_error / rho.clamp_min(direction_error) + ATAN_ABS_ERROR) / (2.0 * math.pi)
    dv = torch.full_like(du, (direction_error + ATAN_ABS_ERROR) / math.pi)
    return torch.stack([du, dv], dim=-1)


def _slopes(level: torch.Tensor, uv: torch.Tensor, repeat_u: bool
            ) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
    """Bilinear value and the largest |texel difference| ``[..., C]`` along x and along y among
    the 4x4 texels around the lookup (the slope on either side of the footprint, so a lookup
    moved across a texel centre is covered too)."""
    h, w = level.shape[:2]
    x0 = torch.floor(uv[..., 0] * w - 0.5).to(torch.int64)
    y0 = torch.floor(uv[..., 1] * h - 0.5).to(torch.int64)

    def col(i):
        return torch.remainder(i, w) if repeat_u else i.clamp(0, w - 1)

    xs = [col(x0 + k) for k in (-1, 0, 1, 2)]
    ys = [(y0 + k).clamp(0, h - 1) for k in (-1, 0, 1, 2)]
    t = [[level[y, x] for x in xs] for y in ys]
    dx = torch.zeros_like(t[0][0])
    dy = torch.zeros_like(t[0][0])
    for j in range(4):
        for i in range(3):
            dx = torch.maximum(dx, (t[j][i + 1] - t[j][i]).abs())
            dy = torch.maximum(dy, (t[i + 1][j] - t[i][j]).abs())
    return sample_bilinear(level, uv, repeat_u), dx, dy


def sample_trilinear_envelope(levels: list[torch.Tensor], uv: torch.Tensor, lod: torch.Tensor,
                              uv_error: torch.Tensor, repeat_u: bool = True,
                              weight_bits: int = FILTER_WEIGHT_BITS) -> torch.Tensor:
    """Bound ``[..., C]`` on |GPU textureLod - :func:`sample_trilinear`| for one lookup: per level
    used, (q + uv_error * size) times the steepest neighbouring texel difference in x and in y
    (weight quantisation q = 2^-bits, and the coordinate error in texels), plus q times the largest
    difference to the neighbouring levels (lod fraction quantisation; it also covers a lod within
    q of an integer, which a GPU may round to the other side)."""
    q = 2.0 ** -weight_bits
    n = len(levels)
    lod = lod.clamp(0.0, float(n - 1))
    base = torch.floor(lod).to(torch.int64)
    frac = (lod - torch.floor(lod))[..., None]
    bound = torch.zeros(*uv.shape[:-1], levels[0].shape[-1], dtype=torch.float32)
    value = {}
    for k in range(n):
        near = (base >= k - 1) & (base <= k + 1)
        if not near.any():
            continue
        h, w = levels[k].shape[:2]
        s, dx, dy = _slopes(levels[k], uv, repeat_u)
        value[k] = torch.where(near[..., None], s, 0.0)
        e = (q + uv_error[..., 0:1] * w) * dx + (q + uv_error[..., 1:2] * h) * dy
        wk = torch.where((base == k)[..., None], 1.0 - frac, 0.0) \
            + torch.where((base == k - 1)[..., None], frac, 0.0)
        # a quantised fraction may give a level weight up to q even where the float one is 0
        bound = bound + (wk + q) * torch.where(near[..., None], e, 0.0)
    zero = torch.zeros_like(bound)
    for k in range(n):
        up, down = value.get(k + 1, zero), value.get(k - 1, zero)
        here = value.get(k, zero)
        step = torch.maximum((up - here).abs() if k + 1 < n else zero,
                             (here - down).abs() if k > 0 else zero)
        bound = bound + torch.where((base == k)[..., None], q * step, 0.0)
    return bound


# ---------------------------------------------------------------------------------------------
# lib/ibl.glsl
# ---------------------------------------------------------------------------------------------

def ibl_specular_radiance(prefiltered: list[torch.Tensor], r_ws: torch.Tensor,
                          perceptual_roughness: torch.Tensor, levels: float) -> torch.Tensor:
    """GLSL ``vec3 ibl_specular_radiance(sampler2D, vec3 r_ws, float r, float levels)``:
    prefiltered chain (list of ``[h, w, C]``), r_ws ``[..., 3]`` -> ``[..., 3]``."""
    lod = prefilter_lod(perceptual_roughness, torch.full_like(perceptual_roughness, float(levels)))
    return sample_trilinear(prefiltered, equirect_uv(r_ws), lod)[..., :3]


def ibl_specular_radiance_sun(sunless: list[torch.Tensor], full: list[torch.Tensor],
                              r_ws: torch.Tensor, perceptual_roughness: torch.Tensor,
                              levels: float, w: torch.Tensor) -> torch.Tensor:
    """GLSL ``vec3 ibl_specular_radiance_sun(sampler2D sunless, sampler2D full, vec3 r_ws, float r,
    float levels, float w)``: mix(full, sunless, w) of the two chains' lookups where w < 1, the
    sun-less lookup where w = 1. w ``[...]`` -> ``[..., 3]``."""
    p = ibl_specular_radiance(sunless, r_ws, perceptual_roughness, levels)
    f = ibl_specular_radiance(full, r_ws, perceptual_roughness, levels)
    w3 = w[..., None]
    return torch.where(w3 < 1.0, f * (1.0 - w3) + p * w3, p)


def prefilter_lod(perceptual_roughness: torch.Tensor, levels: torch.Tensor) -> torch.Tensor:
    """GLSL ``float prefilter_lod(float r, float levels)``: with alpha = r^2 and alpha_1 =
    2^(1 - (levels - 1)), alpha / alpha_1 min(levels - 1, 1) below alpha_1, else
    (levels - 1) + log2(alpha)."""
    last = (levels - 1.0).clamp_min(0.0)
    r = perceptual_roughness.clamp(0.0, 1.0)
    a = r * r
    a1 = torch.exp2(1.0 - last)
    return torch.where(a < a1, a / a1 * last.clamp_max(1.0), last + torch.log2(a))


def ibl_dfg(dfg: torch.Tensor, NoV: torch.Tensor, perceptual_roughness: torch.Tensor
            ) -> torch.Tensor:
    """GLSL ``vec2 ibl_dfg(sampler2D dfg, float NoV, float r)``: LUT ``[n, n, 2]`` -> ``[..., 2]``."""
    n = torch.tensor([float(dfg.shape[1]), float(dfg.shape[0])], dtype=torch.float32)
    x = torch.stack([NoV.clamp(0.0, 1.0), perceptual_roughness.clamp(0.0, 1.0)], dim=-1)
    uv = (x * (n - 1.0) + 0.5) / n  # texel centres on the end points (see dfg_lut)
    return sample_bilinear(dfg, uv, repeat_u=False)[..., :2]


def ibl_dominant_factor(dominant: torch.Tensor, NoV: torch.Tensor,
                        perceptual_roughness: torch.Tensor) -> torch.Tensor:
    """GLSL ``float ibl_dominant_factor(sampler2D dominant, float NoV, float r)``: LUT
    ``[n, n, 1]`` -> ``[...]``."""
    n = torch.tensor([float(dominant.shape[1]), float(dominant.shape[0])], dtype=torch.float32)
    x = torch.stack([NoV.clamp(0.0, 1.0), perceptual_roughness.clamp(0.0, 1.0)], dim=-1)
    uv = (x * (n - 1.0) + 0.5) / n
    return sample_bilinear(dominant, uv, repeat_u=False)[..., 0]


def specular_dominant_direction(n: torch.Tensor, r: torch.Tensor, t: torch.Tensor
                                ) -> torch.Tensor:
    """GLSL ``vec3 specular_dominant_direction(vec3 n, vec3 r, float t)`` =
    normalize(mix(n, r, t)): n, r ``[..., 3]``, t ``[...]`` -> ``[..., 3]``."""
    d = n + (r - n) * t[..., None]
    return d * torch.rsqrt((d * d).sum(-1, keepdim=True))


def ibl_specular_dfg(dfg: torch.Tensor, f0: torch.Tensor, f90: torch.Tensor) -> torch.Tensor:
    """GLSL ``vec3 ibl_specular_dfg(vec2 dfg, vec3 f0, float f90)`` = f0 (y - x) + f90 x."""
    x = dfg[..., 0:1]
    y = dfg[..., 1:2]
    return f0 * (y - x) + f90[..., None] * x


def ibl_energy_compensation(dfg: torch.Tensor, f0: torch.Tensor) -> torch.Tensor:
    """GLSL ``vec3 ibl_energy_compensation(vec2 dfg, vec3 f0)`` = 1 + f0 (1 / dfg.y - 1)."""
    return 1.0 + f0 * (1.0 / dfg[..., 1:2].clamp_min(1e-4) - 1.0)


# ---------------------------------------------------------------------------------------------
# Precompute passes
# ---------------------------------------------------------------------------------------------

def downsample_box(src: torch.Tensor) -> torch.Tensor:
    """Twin of ``passes/ibl_downsample.comp``: ``[h, w, C]`` -> ``[max(h/2,1), max(w/2,1), C]``,
    the 2x2 mean with each source row weighted by its texel solid angle (sin of the row centre's
    polar angle)."""
    h, w = src.shape[:2]
    ho, wo = max(1, h // 2), max(1, w // 2)
    ys = torch.arange(ho)
    xs = torch.arange(wo)
    y0, y1 = (2 * ys).clamp(max=h - 1), (2 * ys + 1).clamp(max=h - 1)
    x0, x1 = (2 * xs).clamp(max=w - 1), (2 * xs + 1).clamp(max=w - 1)
    a = src[y0][:, x0]
    b = src[y0][:, x1]
    c = src[y1][:, x0]
    d = src[y1][:, x1]
    inv_h = torch.tensor(1.0, dtype=torch.float32) / float(h)
    w0 = torch.sin(math.pi * ((y0.to(torch.float32) + 0.5) * inv_h))[:, None, None]
    w1 = torch.sin(math.pi * ((y1.to(torch.float32) + 0.5) * inv_h))[:, None, None]
    return ((a + b) * w0 + (c + d) * w1) * (0.5 / (w0 + w1))


def radiance_chain(env: torch.Tensor) -> list[torch.Tensor]:
    """The full box mip chain of ``env [H, W, C]`` down to 1x1 (what ``build_ibl`` uploads)."""
    chain = [env]
    while chain[-1].shape[:2] != (1, 1):
        chain.append(downsample_box(chain[-1]))
    return chain


def _texel_dirs(h: int, w: int) -> tuple[torch.Tensor, torch.Tensor]:
    """Texel-centre uv ``[h, w, 2]`` and directions ``[h, w, 3]`` (float32, as the passes)."""
    ys, xs = torch.meshgrid(torch.arange(h, dtype=torch.float32),
                            torch.arange(w, dtype=torch.float32), indexing="ij")
    uv = torch.stack([(xs + 0.5) / w, (ys + 0.5) / h], dim=-1)
    return uv, equirect_dir(uv)


def _dot(a: torch.Tensor, b: torch.Tensor) -> torch.Tensor:
    return a[..., 0] * b[..., 0] + a[..., 1] * b[..., 1] + a[..., 2] * b[..., 2]


def prefilter_level(chain: list[torch.Tensor], size: tuple[int, int], perceptual_roughness: float,
                    samples: int, weight_bits: int | None = None,
                    uv_offset: torch.Tensor | None = None) -> torch.Tensor:
    """Twin of one dispatch of ``passes/ibl_prefilter.comp``: a ``[h, w, C]`` prefiltered level.
    ``weight_bits`` and ``uv_offset`` (added to every lookup's uv) emulate a GPU's texture unit
    and trigonometry, to test :func:`prefilter_level_envelope` against them."""
    h, w = size
    h0, w0 = chain[0].shape[:2]
    omega_p = torch.tensor(4.0 * math.pi / (w0 * h0), dtype=torch.float32)
    max_lod = float(len(chain) - 1)
    _, n = _texel_dirs(h, w)
    n = n[:, :, None, :]  # [h, w, 1, 3]
    r = torch.tensor(perceptual_roughness, dtype=torch.float32)
    a = r * r
    xi = hammersley_sequence(samples)  # [S, 2]
    inv_samples = torch.tensor(1.0, dtype=torch.float32) / float(samples)
    hv = tangent_to_world(importance_sample_ggx(xi, a).expand(h, w, samples, 3),
                          n.expand(h, w, samples, 3))
    NoH = _dot(n, hv)
    l = 2.0 * NoH[..., None] * hv - n
    NoL = _dot(n, l)
    keep = NoL > 0.0
    pdf = ggx_sample_d(xi, a) * 0.25  # [S], from xi as the pass (not from NoH)
    omega_s = inv_samples / pdf.clamp_min(1e-30)
    lod = (0.5 * torch.log2(omega_s / omega_p)).clamp(0.0, max_lod)  # no +1 bias (the pass)
    uv = equirect_uv(l) if uv_offset is None else equirect_uv(l) + uv_offset
    rad = sample_trilinear(chain, uv, lod, weight_bits=weight_bits)  # [h, w, S, C]
    wgt = torch.where(keep, NoL, 0.0)
    total = (rad * wgt[..., None]).sum(dim=2)
    return total / wgt.sum(dim=2).clamp_min(1e-30)[..., None]


def prefilter_level_envelope(chain: list[torch.Tensor], size: tuple[int, int],
                             perceptual_roughness: float, samples: int,
                             weight_bits: int = FILTER_WEIGHT_BITS) -> torch.Tensor:
    """Bound ``[h, w, C]`` on |GPU - :func:`prefilter_level`|: the n.l-weighted mean of each
    sample's :func:`sample_trilinear_envelope` (the weights themselves are well conditioned: an
    ulp each), plus float32 summation of ``samples`` terms (2 S ulp of the result)."""
    h, w = size
    h0, w0 = chain[0].shape[:2]
    omega_p = torch.tensor(4.0 * math.pi / (w0 * h0), dtype=torch.float32)
    _, n = _texel_dirs(h, w)
    n = n[:, :, None, :]
    a = torch.tensor(perceptual_roughness, dtype=torch.float32) ** 2
    xi = hammersley_sequence(samples)
    hv = tangent_to_world(importance_sample_ggx(xi, a).expand(h, w, samples, 3),
                          n.expand(h, w, samples, 3))
    NoH = _dot(n, hv)
    l = 2.0 * NoH[..., None] * hv - n
    NoL = _dot(n, l)
    pdf = ggx_sample_d(xi, a) * 0.25
    omega_s = (1.0 / float(samples)) / pdf.clamp_min(1e-30)
    lod = (0.5 * torch.log2(omega_s / omega_p)).clamp(0.0, float(len(chain) - 1))
    # l = 2 (n.h) h - n: direction errors of n and h (sin/cos) add up to ~3x theirs
    err = sample_trilinear_envelope(chain, equirect_uv(l), lod,
                                    equirect_uv_error(l, 3.0 * DIRECTION_ABS_ERROR),
                                    weight_bits=weight_bits)
    wgt = torch.where(NoL > 0.0, NoL, 0.0)
    total = wgt.sum(dim=2).clamp_min(1e-30)[..., None]
    rad = sample_trilinear(chain, equirect_uv(l), lod)
    mean = (rad * wgt[..., None]).sum(dim=2) / total
    return (err * wgt[..., None]).sum(dim=2) / total + 2.0 * samples * 2.0 ** -24 * mean.abs()


def prefilter_environment(chain: list[torch.Tensor], roughness: list[float],
                          samples: list[int]) -> list[torch.Tensor]:
    """Twin of the prefiltered chain of ``build_ibl``: level 0 = ``chain[0]``, level k >= 1 = GGX
    prefiltered at perceptual roughness ``roughness[k]`` with ``samples[k]`` Hammersley points
    (the pass's uniforms: the renderer uses ``viewer.ibl.prefilter_roughness(k, levels)`` and
    ``viewer.ibl.prefilter_samples(k, options.prefilter_samples)``)."""
    out = [chain[0]]
    for k in range(1, len(roughness)):
        out.append(prefilter_level(chain, tuple(chain[k].shape[:2]), roughness[k], samples[k]))
    return out


def texel_solid_angle(h: int, w: int) -> torch.Tensor:
    """Exact solid angle ``[h]`` of one texel in each equirect row (float32, as ``ibl_sh.comp``)."""
    v = (torch.arange(h, dtype=torch.float32) + 0.5) / h
    return (2.0 * math.pi / w) * 2.0 * torch.sin(math.pi * v) * math.sin(0.5 * math.pi / h)


def sh_project(env: torch.Tensor) -> torch.Tensor:
    """Twin of ``passes/ibl_sh.comp`` + the float64 reduction: ``[H, W, 3]`` -> ``[9, 3]``
    radiance SH coefficients (float64)."""
    h, w = env.shape[:2]
    _, n = _texel_dirs(h, w)
    weighted = env[..., :3].to(torch.float32) * texel_solid_angle(h, w)[:, None, None]
    basis = sh_basis_all(n)  # [h, w, 9]
    return (weighted[:, :, None, :] * basis[..., None]).to(torch.float64).sum(dim=(0, 1))


def _lut_lobe_samples(size: int, samples: int, max_NoV: float = 1.0):
    """The GGX samples both outputs of ``passes/ibl_dfg.comp`` integrate over, per texel of a
    ``[size (roughness), size (n.v)]`` grid (n.v clamped to [1e-4, ``max_NoV``]): NoV and
    sin(theta_v) ``[size, size]``, the reflected directions l ``[size, size, S, 3]``, their
    weights G = V 4 (v.h) (n.l) / (n.h) and v.h ``[size, size, S]``, and where n.l > 0."""
    c = torch.arange(size, dtype=torch.float32) / float(size - 1)
    r, NoV = torch.meshgrid(c, c.clamp_min(1e-4).clamp_max(max_NoV), indexing="ij")
    a = (r * r)[..., None]
    NoV = NoV[..., None]
    sin_t = torch.sqrt((1.0 - NoV * NoV).clamp_min(0.0))
    v = torch.stack([sin_t, torch.zeros_like(NoV), NoV], dim=-1)  # [size, size, 1, 3]
    xi = hammersley_sequence(samples)
    hv = importance_sample_ggx(xi, a)  # [size, size, S, 3]
    VoH = _dot(v, hv)
    l = 2.0 * VoH[..., None] * hv - v
    NoL = l[..., 2]
    g = v_smith_ggx_correlated(NoV, NoL, a) * 4.0 * VoH.clamp_min(0.0) * NoL \
        / hv[..., 2].clamp_min(1e-30)
    return NoV[..., 0], sin_t[..., 0], l, g, VoH, NoL > 0.0


def dfg_lut(size: int, samples: int) -> torch.Tensor:
    """Twin of ``passes/ibl_dfg.comp``: ``[size (roughness), size (n.v), 2]`` float32."""
    _, _, _, g, VoH, keep = _lut_lobe_samples(size, samples)
    fc = f_schlick(torch.zeros(1, dtype=torch.float32), torch.ones_like(VoH), VoH)[..., 0]
    gx = torch.where(keep, g * fc, 0.0).sum(dim=-1)
    gy = torch.where(keep, g, 0.0).sum(dim=-1)
    gx = gx / float(max(samples, 1))
    gy = (gy / float(max(samples, 1))).clamp_max(1.0)
    return torch.stack([torch.minimum(gx, gy), gy], dim=-1)


def dominant_lut(size: int, samples: int) -> torch.Tensor:
    """Twin of ``passes/ibl_dfg.comp``'s second output: ``[size (roughness), size (n.v), 1]``
    float32, the lerp factor t of the f (n.l) lobe's mean direction m = sum G l (see the pass):
    t = m.x / (m.x (1 - n.v) - sin(theta_v) m.z) at n.v <= 0.999, clamped to [0, 1]."""
    NoV, sin_t, l, g, _, keep = _lut_lobe_samples(size, samples, max_NoV=0.999)
    mx = torch.where(keep, g * l[..., 0], 0.0).sum(dim=-1)
    mz = torch.where(keep, g * l[..., 2], 0.0).sum(dim=-1)
    t = mx / torch.clamp_max(mx * (1.0 - NoV) - sin_t * mz, -1e-30)
    return t.clamp(0.0, 1.0)[..., None]


# ---------------------------------------------------------------------------------------------
# Parity cases and pass checks
# ---------------------------------------------------------------------------------------------
