"""Twins of ``shaders/lib/env_sampling.glsl`` and of the distribution build
(``shaders/passes/env_cdf_{rows,marginal,pdf}.comp``, driven by :mod:`viewer.environment.sampling`).

Textures are tensors with row 0 first, as uploaded: ``marginal [H + 1]``, ``conditional
[H, W + 1]``, ``pdf [H, W]``. Registers the pass checks ``env_distribution`` and ``env_sampling``.
"""
from __future__ import annotations

import math

import torch

from .equirect import equirect_dir, equirect_uv

_LUMA = (0.2126, 0.7152, 0.0722)


def luminance(c: torch.Tensor) -> torch.Tensor:
    """GLSL ``float luminance(vec3 c)`` (BT.709): ``[..., 3]`` -> ``[...]``."""
    return c[..., 0] * _LUMA[0] + c[..., 1] * _LUMA[1] + c[..., 2] * _LUMA[2]


def env_pdf_solid_angle(pdf_uv: torch.Tensor, sin_theta: torch.Tensor) -> torch.Tensor:
    """GLSL ``float env_pdf_solid_angle(float pdf_uv, float sin_theta)``."""
    ok = sin_theta > 0.0
    return torch.where(ok, pdf_uv / (2.0 * math.pi * math.pi
                                     * torch.where(ok, sin_theta, torch.ones_like(sin_theta))),
                       torch.zeros_like(pdf_uv))


def env_row_sin_theta(row: torch.Tensor, height: torch.Tensor) -> torch.Tensor:
    """GLSL ``float env_row_sin_theta(int row, int height)``."""
    row = torch.as_tensor(row).to(torch.float32)
    height = torch.as_tensor(height).to(torch.float32).clamp_min(1.0)
    return torch.sin(math.pi * (row + 0.5) / height)


def cdf_find(cdf: torch.Tensor, row: torch.Tensor, n: int, u: torch.Tensor) -> torch.Tensor:
    """GLSL ``int cdf_find(sampler2D cdf, int row, int n, float u)``: cdf ``[rows, n + 1]``, row and
    u ``[...]`` -> the largest i in [0, n - 1] with cdf[row, i] <= u (int64)."""
    table = cdf[row]  # [..., n + 1]
    i = (table <= u[..., None]).sum(-1) - 1
    return i.clamp(0, n - 1)


def sample_env(marginal: torch.Tensor, conditional: torch.Tensor, pdf_uv: torch.Tensor,
               u: torch.Tensor) -> torch.Tensor:
    """GLSL ``vec4 sample_env(sampler2D marginal, conditional, pdf_uv, vec2 u)``: u ``[..., 2]`` ->
    ``[..., 4]`` (direction in the environment frame, pdf in solid angle)."""
    h, w = pdf_uv.shape
    zeros = torch.zeros(u.shape[:-1], dtype=torch.int64)
    row = cdf_find(marginal[None, :], zeros, h, u[..., 1])
    m0, m1 = marginal[row], marginal[row + 1]
    dv = ((u[..., 1] - m0) / (m1 - m0).clamp_min(1e-30)).clamp(0.0, 1.0)
    col = cdf_find(conditional, row, w, u[..., 0])
    c0, c1 = conditional[row, col], conditional[row, col + 1]
    du = ((u[..., 0] - c0) / (c1 - c0).clamp_min(1e-30)).clamp(0.0, 1.0)
    uv = torch.stack([(col.to(torch.float32) + du) / float(w),
                      (row.to(torch.float32) + dv) / float(h)], dim=-1)
    d = equirect_dir(uv)
    p = env_pdf_solid_angle(pdf_uv[row, col], torch.sin(math.pi * uv[..., 1]))
    return torch.cat([d, p[..., None]], dim=-1)


def env_pdf(pdf_uv: torch.Tensor, d: torch.Tensor) -> torch.Tensor:
    """GLSL ``float env_pdf(sampler2D pdf_uv, vec3 d)``: d ``[..., 3]`` unit -> ``[...]``."""
    h, w = pdf_uv.shape
    uv = equirect_uv(d)
    x = torch.floor(uv[..., 0] * w).to(torch.int64).clamp(0, w - 1)
    y = torch.floor(uv[..., 1] * h).to(torch.int64).clamp(0, h - 1)
    sin_theta = torch.sqrt(d[..., 0] * d[..., 0] + d[..., 2] * d[..., 2])
    return env_pdf_solid_angle(pdf_uv[y, x], sin_theta)


def env_distribution(env: torch.Tensor) -> dict:
    """Twin of :func:`viewer.environment.sampling.build_env_sampling` (the three ``env_cdf_*.comp``
    passes): ``env [H, W, >=3]`` -> ``marginal [H + 1]``, ``conditional [H, W + 1]``,
    ``pdf [H, W]`` and ``fallback`` (bool). Sums run sequentially in float32, as on the GPU."""
    h, w = env.shape[:2]
    lum = luminance(env[..., :3].to(torch.float32))
    # 3x3 max: u wraps, v clamps
    padded = torch.cat([lum[:1], lum, lum[-1:]], dim=0)
    padded = torch.cat([padded[:, -1:], padded, padded[:, :1]], dim=1)
    m = torch.full_like(lum, 0.0)
    for dy in range(3):
        for dx in range(3):
            m = torch.maximum(m, padded[dy:dy + h, dx:dx + w])
    s = env_row_sin_theta(torch.arange(h), torch.tensor(h))
    func = m * s[:, None]
    # sequential float32 prefix sums (torch.cumsum on CPU accumulates in order)
    prefix = torch.cumsum(func, dim=1)
    total_row = prefix[:, -1]
    usable = (total_row > 0.0) & (total_row < 3.0e38)
    uniform = (torch.arange(1, w + 1, dtype=torch.float32) / float(w))[None, :].expand(h, w)
    cdf = torch.where(usable[:, None], (prefix / torch.where(usable, total_row, 1.0)[:, None])
                      .clamp_max(1.0), uniform).clone()
    cdf[:, -1] = 1.0
    conditional = torch.cat([torch.zeros(h, 1), cdf], dim=1)
    row_sum = torch.where(usable, total_row, torch.zeros_like(total_row))
    total = torch.cumsum(row_sum, 0)[-1]
    fallback = not bool((total > 0.0) & (total < 3.0e38))
    weights = s if fallback else row_sum
    acc = torch.cumsum(weights, 0)
    total = acc[-1]
    marg = (acc / total).clamp_max(1.0).clone()
    marg[-1] = 1.0
    marginal = torch.cat([torch.zeros(1), marg])
    if fallback:
        pdf = (s * float(h) / total)[:, None].expand(h, w).clone()
    else:
        pdf = func * (float(w) * float(h) / total)
    return {"marginal": marginal, "conditional": conditional, "pdf": pdf, "fallback": fallback}


# ---------------------------------------------------------------------------------------------
# pass checks
# ---------------------------------------------------------------------------------------------
