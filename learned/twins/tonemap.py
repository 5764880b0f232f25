"""Twins of ``shaders/lib/tonemap.glsl``."""
from __future__ import annotations

import torch

_ACES_IN = torch.tensor([[0.59719, 0.35458, 0.04823],
                         [0.07600, 0.90834, 0.01566],
                         [0.02840, 0.13383, 0.83777]], dtype=torch.float32)
_ACES_OUT = torch.tensor([[1.60475, -0.53108, -0.07367],
                          [-0.10208, 1.10813, -0.00605],
                          [-0.00327, -0.07276, 1.07602]], dtype=torch.float32)
# AgX (three.js r162+): Rec. 709 -> Rec. 2020 composed with the inset matrix, the outset matrix
# (inverse of three.js's AgXOutsetMatrixInv) and Rec. 2020 -> Rec. 709, as row-major matrices
_AGX_INSET = torch.tensor([[0.5448236568, 0.3737703275, 0.0813596693],
                           [0.1404419197, 0.7541441857, 0.1054103915],
                           [0.0888390519, 0.1788978601, 0.7323274369]], dtype=torch.float32)
_AGX_OUTSET = torch.tensor([[1.1271005818, -0.1106066431, -0.0164939387],
                            [-0.1413297635, 1.1578237022, -0.0164939387],
                            [-0.1413297635, -0.1106066431, 1.2519364066]], dtype=torch.float32)
_REC2020_TO_SRGB = torch.tensor([[1.6605, -0.5876, -0.0728],
                                 [-0.1246, 1.1329, -0.0083],
                                 [-0.0182, -0.1006, 1.1187]], dtype=torch.float32)


def apply_exposure(c: torch.Tensor, ev: torch.Tensor) -> torch.Tensor:
    """GLSL ``vec3 apply_exposure(vec3 c, float ev)``. c: [..., 3], ev: [...]."""
    return c * torch.exp2(ev)[..., None]


def rrt_odt_fit(v: torch.Tensor) -> torch.Tensor:
    """GLSL ``vec3 rrt_odt_fit(vec3 v)`` (Hill's ACES RRT+ODT fit)."""
    a = v * (v + 0.0245786) - 0.000090537
    b = v * (0.983729 * v + 0.4329510) + 0.238081
    return a / b


def tonemap_aces_fitted(c: torch.Tensor) -> torch.Tensor:
    """GLSL ``vec3 tonemap_aces_fitted(vec3 c)``. c: [..., 3] linear -> [..., 3] in [0, 1]."""
    v = c.clamp(0.0, 1e4) @ _ACES_IN.to(c).T
    return (rrt_odt_fit(v) @ _ACES_OUT.to(c).T).clamp(0.0, 1.0)


def tonemap_reinhard(c: torch.Tensor) -> torch.Tensor:
    """GLSL ``vec3 tonemap_reinhard(vec3 c)``."""
    x = c.clamp_min(0.0)
    return x / (1.0 + x)


def tonemap_pbr_neutral(c: torch.Tensor) -> torch.Tensor:
    """GLSL ``vec3 tonemap_pbr_neutral(vec3 c)`` (Khronos PBR Neutral). c: [..., 3] linear Rec. 709
    -> [..., 3] linear in [0, 1]."""
    f90, k_d = 0.04, 0.15
    k_s = 0.8 - f90
    x = c.clamp(0.0, 1e6)
    m = x.amin(-1, keepdim=True)
    f = torch.where(m <= 2.0 * f90, m - m * m / (4.0 * f90), torch.full_like(m, f90))
    x = x - f
    p = x.amax(-1, keepdim=True)
    d = 1.0 - k_s
    p_n = 1.0 - d * d / (p + d - k_s)
    g = 1.0 / (k_d * (p - p_n) + 1.0)
    compressed = x * (p_n / p) * g + p_n * (1.0 - g)
    return torch.where(p <= k_s, x, compressed)


def agx_contrast(x: torch.Tensor) -> torch.Tensor:
    """GLSL ``vec3 agx_contrast(vec3 x)`` (Wrensch's polynomial of AgX's default sigmoid)."""
    x2 = x * x
    x4 = x2 * x2
    return (15.5 * x4 * x2 - 40.14 * x4 * x + 31.96 * x4 - 6.868 * x2 * x + 0.4298 * x2
            + 0.1191 * x - 0.00232)


def tonemap_agx(c: torch.Tensor) -> torch.Tensor:
    """GLSL ``vec3 tonemap_agx(vec3 c)`` (three.js r162+ AgX). c: [..., 3] linear Rec. 709 ->
    [..., 3] linear in [0, 1]."""
    min_ev, max_ev = -12.47393, 4.026069
    v = c.clamp(0.0, 1e6) @ _AGX_INSET.to(c).T
    v = (torch.log2(v.clamp_min(1e-10)) - min_ev) / (max_ev - min_ev)
    v = agx_contrast(v.clamp(0.0, 1.0))
    v = torch.pow((v @ _AGX_OUTSET.to(c).T).clamp_min(0.0), 2.2)
    return (v @ _REC2020_TO_SRGB.to(c).T).clamp(0.0, 1.0)


def linear_to_srgb(c: torch.Tensor) -> torch.Tensor:
    """GLSL ``vec3 linear_to_srgb(vec3 c)`` (IEC 61966-2-1)."""
    x = c.clamp(0.0, 1.0)
    return torch.where(x <= 0.0031308, 12.92 * x, 1.055 * torch.pow(x, 1.0 / 2.4) - 0.055)


def srgb_to_linear(c: torch.Tensor) -> torch.Tensor:
    """GLSL ``vec3 srgb_to_linear(vec3 c)``."""
    x = c.clamp(0.0, 1.0)
    return torch.where(x <= 0.04045, x / 12.92, torch.pow((x + 0.055) / 1.055, 2.4))


