"""Twins of ``shaders/lib/tonemap.glsl``."""
from __future__ import annotations

import torch

_ACES_IN = torch.tensor([[0.59719, 0.35458, 0.04823],
                         [0.07600, 0.90834, 0.01566],
                         [0.02840, 0.13383, 0.83777]], dtype=torch.float32)
_ACES_OUT = torch.tensor([[1.60475, -0.53108, -0.07367],
                          [-0.10208, 1.10813, -0.00605],
                          [-0.00327, -0.07276, 1.07602]], dtype=torch.float32)


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


def linear_to_srgb(c: torch.Tensor) -> torch.Tensor:
    """GLSL ``vec3 linear_to_srgb(vec3 c)`` (IEC 61966-2-1)."""
    x = c.clamp(0.0, 1.0)
    return torch.where(x <= 0.0031308, 12.92 * x, 1.055 * torch.pow(x, 1.0 / 2.4) - 0.055)


def srgb_to_linear(c: torch.Tensor) -> torch.Tensor:
    """GLSL ``vec3 srgb_to_linear(vec3 c)``."""
    x = c.clamp(0.0, 1.0)
    return torch.where(x <= 0.04045, x / 12.92, torch.pow((x + 0.055) / 1.055, 2.4))


