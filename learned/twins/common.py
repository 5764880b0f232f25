"""Twins of ``shaders/lib/common.glsl``."""
from __future__ import annotations

import math

import torch

PI = math.pi
INV_PI = 1.0 / math.pi  # lib/common.glsl INV_PI


def saturate(x: torch.Tensor) -> torch.Tensor:
    """GLSL ``float saturate(float x)``: clamp to [0, 1]."""
    return x.clamp(0.0, 1.0)


def sq(x: torch.Tensor) -> torch.Tensor:
    """GLSL ``float sq(float x)``."""
    return x * x


def half_vector(v: torch.Tensor, l: torch.Tensor) -> torch.Tensor:
    """GLSL ``vec3 half_vector(vec3 v, vec3 l)``: normalize(v + l), +Z where v = -l. [..., 3]."""
    h = v + l
    len2 = (h * h).sum(-1, keepdim=True)
    z = torch.zeros_like(h)
    z[..., 2] = 1.0
    return torch.where(len2 > 1e-30, h * torch.rsqrt(len2.clamp_min(1e-30)), z)


