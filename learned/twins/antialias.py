"""Twins of ``shaders/lib/antialias.glsl``: FXAA 3.11 (quality preset 12) and the supersampling box
resolve. Textures are ``[H, W, C]`` float tensors in GL row order (row 0 at the bottom, as
``texelFetch`` indexes them); positions are ``[..., 2]`` pixels (x, y), pixel centres at i + 0.5."""
from __future__ import annotations

import torch

from .tonemap import linear_to_srgb, srgb_to_linear

_STEPS = (1.0, 1.5, 2.0, 4.0, 12.0)  # FXAA_QUALITY__P0..P4 of preset 12
_SUBPIX, _EDGE_THRESHOLD, _EDGE_THRESHOLD_MIN = 0.75, 0.166, 0.0833


def fxaa_luma(rgb: torch.Tensor) -> torch.Tensor:
    """GLSL ``float fxaa_luma(vec3 rgb)`` (Rec. 601 weights). rgb: [..., 3] -> [...]."""
    return rgb[..., 0] * 0.299 + rgb[..., 1] * 0.587 + rgb[..., 2] * 0.114


def fxaa_texel(srgb: torch.Tensor) -> torch.Tensor:
    """GLSL ``vec4 fxaa_texel(vec4 srgb)``: linear RGB and perceptual luma. [..., 4] -> [..., 4]."""
    return torch.cat([srgb_to_linear(srgb[..., :3]), fxaa_luma(srgb[..., :3])[..., None]], -1)


def fxaa_fetch(tex: torch.Tensor, pos: torch.Tensor, display: bool) -> torch.Tensor:
    """GLSL ``vec4 fxaa_fetch(sampler2D tex, vec2 pos, bool display)``: bilinear, clamped to the
    edge; ``display``: texels through :func:`fxaa_texel` first. tex: [H, W, 4], pos: [..., 2]
    -> [..., 4]."""
    h, w = tex.shape[0], tex.shape[1]
    p = pos - 0.5
    i0 = torch.floor(p)
    f = p - i0
    i0 = i0.long()
    ax, bx = i0[..., 0].clamp(0, w - 1), (i0[..., 0] + 1).clamp(0, w - 1)
    ay, by = i0[..., 1].clamp(0, h - 1), (i0[..., 1] + 1).clamp(0, h - 1)
    fx, fy = f[..., :1], f[..., 1:]
    texel = fxaa_texel if display else (lambda c: c)

    def mix(a, b, t):
        return a * (1.0 - t) + b * t
    return mix(mix(texel(tex[ay, ax]), texel(tex[ay, bx]), fx),
               mix(texel(tex[by, ax]), texel(tex[by, bx]), fx), fy)


def fxaa_luma_at(tex: torch.Tensor, pos: torch.Tensor) -> torch.Tensor:
    """GLSL ``float fxaa_luma_at(sampler2D tex, vec2 pos)``."""
    return fxaa_fetch(tex, pos, True)[..., 3]


def fxaa(tex: torch.Tensor, pos: torch.Tensor) -> torch.Tensor:
    """GLSL ``vec4 fxaa(sampler2D tex, vec2 pos)`` (FXAA 3.11 quality, preset 12), every position
    at once: the GLSL branches become masks. tex: [H, W, 4], pos: [..., 2] -> [..., 4]."""
    def at(dx, dy):
        return fxaa_luma_at(tex, pos + torch.tensor([dx, dy], dtype=pos.dtype))

    ix = pos.floor().long()
    rgba_m = tex[ix[..., 1], ix[..., 0]]
    luma_m = fxaa_luma(rgba_m[..., :3])
    luma_s, luma_e, luma_n, luma_w = at(0.0, 1.0), at(1.0, 0.0), at(0.0, -1.0), at(-1.0, 0.0)
    range_max = torch.maximum(torch.maximum(luma_n, luma_w),
                              torch.maximum(luma_e, torch.maximum(luma_s, luma_m)))
    range_min = torch.minimum(torch.minimum(luma_n, luma_w),
                              torch.minimum(luma_e, torch.minimum(luma_s, luma_m)))
    rng = range_max - range_min
    early = rng < torch.clamp_min(range_max * _EDGE_THRESHOLD, _EDGE_THRESHOLD_MIN)

    luma_nw, luma_se, luma_ne, luma_sw = at(-1.0, -1.0), at(1.0, 1.0), at(1.0, -1.0), at(-1.0, 1.0)
    luma_ns, luma_we = luma_n + luma_s, luma_w + luma_e
    luma_nese, luma_nwsw = luma_ne + luma_se, luma_nw + luma_sw
    edge_horz = ((-2.0 * luma_w + luma_nwsw).abs() + 2.0 * (-2.0 * luma_m + luma_ns).abs()
                 + (-2.0 * luma_e + luma_nese).abs())
    edge_vert = ((-2.0 * luma_s + luma_sw + luma_se).abs() + 2.0 * (-2.0 * luma_m + luma_we).abs()
                 + (-2.0 * luma_n + luma_nw + luma_ne).abs())
    horz = edge_horz >= edge_vert
    subpix_a = 2.0 * (luma_ns + luma_we) + luma_nwsw + luma_nese
    safe_range = torch.where(early, torch.ones_like(rng), rng)
    subpix_c = ((subpix_a / 12.0 - luma_m).abs() / safe_range).clamp(0.0, 1.0)
    subpix_f = (-2.0 * subpix_c + 3.0) * subpix_c * subpix_c

    luma_n = torch.where(horz, luma_n, luma_w)
    luma_s = torch.where(horz, luma_s, luma_e)
    gradient_n, gradient_s = luma_n - luma_m, luma_s - luma_m
    pair_n = gradient_n.abs() >= gradient_s.abs()
    gradient = torch.maximum(gradient_n.abs(), gradient_s.abs())
    length_sign = torch.where(pair_n, -1.0, 1.0).to(pos.dtype)
    luma_nn = torch.where(pair_n, luma_n, luma_s) + luma_m

    one, zero = torch.ones_like(luma_m), torch.zeros_like(luma_m)
    across = torch.stack([torch.where(horz, zero, one), torch.where(horz, one, zero)], -1)
    along = torch.stack([torch.where(horz, one, zero), torch.where(horz, zero, one)], -1)
    pos_b = pos + across * (0.5 * length_sign)[..., None]
    pos_n = pos_b - along * _STEPS[0]
    pos_p = pos_b + along * _STEPS[0]
    gradient_scaled = gradient * 0.25
    luma_m_lt_zero = luma_m - luma_nn * 0.5 < 0.0
    end_n = fxaa_luma_at(tex, pos_n) - luma_nn * 0.5
    end_p = fxaa_luma_at(tex, pos_p) - luma_nn * 0.5
    done_n = end_n.abs() >= gradient_scaled
    done_p = end_p.abs() >= gradient_scaled
    for i in range(1, len(_STEPS)):
        pos_n = torch.where(done_n[..., None], pos_n, pos_n - along * _STEPS[i])
        pos_p = torch.where(done_p[..., None], pos_p, pos_p + along * _STEPS[i])
        if i == len(_STEPS) - 1:
            break
        end_n = torch.where(done_n, end_n, fxaa_luma_at(tex, pos_n) - luma_nn * 0.5)
        end_p = torch.where(done_p, end_p, fxaa_luma_at(tex, pos_p) - luma_nn * 0.5)
        done_n = end_n.abs() >= gradient_scaled
        done_p = end_p.abs() >= gradient_scaled
    dst_n = ((pos - pos_n) * along).sum(-1)
    dst_p = ((pos_p - pos) * along).sum(-1)
    good_n = (end_n < 0.0) != luma_m_lt_zero
    good_p = (end_p < 0.0) != luma_m_lt_zero
    good = torch.where(dst_n < dst_p, good_n, good_p)
    pixel_offset = 0.5 - torch.minimum(dst_n, dst_p) / (dst_n + dst_p)
    offset = torch.maximum(torch.where(good, pixel_offset, zero), subpix_f * subpix_f * _SUBPIX)
    at = pos + across * (offset * length_sign)[..., None]
    out = torch.cat([linear_to_srgb(fxaa_fetch(tex, at, True)[..., :3]),
                     fxaa_fetch(tex, at, False)[..., 3:]], -1)
    return torch.where(early[..., None], rgba_m, out)


def ssaa_resolve(tex: torch.Tensor, n: int) -> torch.Tensor:
    """GLSL ``vec4 ssaa_resolve(sampler2D tex, ivec2 pixel, int n)`` for every output pixel: the
    mean of each n x n block. tex: [n H, n W, C] -> [H, W, C]."""
    hh, ww, c = tex.shape[0] // n, tex.shape[1] // n, tex.shape[2]
    return tex[: hh * n, : ww * n].reshape(hh, n, ww, n, c).mean(dim=(1, 3))
