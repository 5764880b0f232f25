"""Twins of ``shaders/lib/path.glsl``: cone sampling and the Russian roulette of the path tracer."""
from __future__ import annotations

import math

import torch


def sample_uniform_cone(u: torch.Tensor, cos_max: torch.Tensor) -> torch.Tensor:
    """GLSL ``vec3 sample_uniform_cone(vec2 u, float cos_max)``: ``[..., 2]`` -> ``[..., 3]``."""
    cos_t = 1.0 - u[..., 0] * (1.0 - cos_max)
    sin_t = torch.sqrt(torch.clamp(1.0 - cos_t * cos_t, min=0.0))
    phi = 2.0 * math.pi * u[..., 1]
    return torch.stack([sin_t * torch.cos(phi), sin_t * torch.sin(phi), cos_t], dim=-1)


def pdf_uniform_cone(cos_max: torch.Tensor) -> torch.Tensor:
    """GLSL ``float pdf_uniform_cone(float cos_max)``."""
    omega = 2.0 * math.pi * (1.0 - cos_max)
    return torch.where(omega > 0.0, 1.0 / torch.where(omega > 0.0, omega, torch.ones_like(omega)),
                       torch.zeros_like(omega))


def path_continue_probability(beta: torch.Tensor, bounce: torch.Tensor) -> torch.Tensor:
    """GLSL ``float path_continue_probability(vec3 beta, float bounce)``."""
    p = torch.clamp(beta.amax(-1), 0.05, 0.95)
    return torch.where(bounce < 3.0, torch.ones_like(p), p)
