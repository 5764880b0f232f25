"""GL texture filtering in torch, and the error envelope of a filtered lookup on a GPU.

Textures are lists of mip levels, each ``[h_k, w_k, C]`` float32 with row 0 first (as uploaded to
GL). :func:`sample_bilinear` / :func:`sample_trilinear` reproduce GL filtering: texel centres at
(i + 0.5) / size, GL_REPEAT in u, CLAMP_TO_EDGE in v (``repeat_u=False`` clamps u too, as the DFG
LUT does), LINEAR_MIPMAP_LINEAR between levels ``floor(lod)`` and ``floor(lod) + 1``. Used by the
twins of ``lib/ibl.glsl`` (:mod:`learned.twins.ibl`), of the IBL precompute passes
(:mod:`learned.twins.ibl_precompute`) and of the lighting passes.
"""
from __future__ import annotations

import math

import torch

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
        s, = _on(lo | hi, uv, lambda uv_, lv=levels[k]: (sample_bilinear(lv, uv_, repeat_u,
                                                                          weight_bits),))
        out = out + torch.where(lo[..., None], s * (1.0 - frac), 0.0) \
                  + torch.where(hi[..., None], s * frac, 0.0)
    return out


def _on(mask: torch.Tensor, uv: torch.Tensor, lookup) -> tuple[torch.Tensor, ...]:
    """The tensors ``[..., C]`` of ``lookup(uv)``, evaluated only where ``mask [...]`` holds and 0
    elsewhere (where the callers weight them by 0). A level of a mip chain is near few of the
    lookups, and lookups are elementwise, so where ``mask`` holds the values are the full
    evaluation's, bit for bit; this only skips the work (half of a lighting pass's twin)."""
    if bool(mask.all()):
        return lookup(uv)
    shape = torch.broadcast_shapes(mask.shape, uv.shape[:-1])  # lod and uv may broadcast
    mask, uv = mask.expand(shape), uv.expand(*shape, uv.shape[-1])
    return tuple(torch.zeros(*mask.shape, t.shape[-1], dtype=t.dtype).index_put((mask,), t)
                 for t in lookup(uv[mask]))


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
        s, dx, dy = _on(near, uv, lambda uv_, lv=levels[k]: _slopes(lv, uv_, repeat_u))
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
