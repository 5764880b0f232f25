"""Twins of ``shaders/lib/equirect.glsl``: equirect mapping (row 0 = zenith, +Y up) and Y
rotation."""
from __future__ import annotations

import math

import torch

from .common import INV_PI


def equirect_uv(dir: torch.Tensor) -> torch.Tensor:
    """GLSL ``vec2 equirect_uv(vec3 dir)``: ``[..., 3]`` -> ``[..., 2]`` (u, v) in [0, 1]."""
    x, y, z = dir[..., 0], dir[..., 1], dir[..., 2]
    rho = torch.sqrt(x * x + z * z)
    phi = torch.where(rho > 1e-18, torch.atan2(x, -z), torch.zeros_like(x))
    theta = torch.atan2(rho, y)
    return torch.stack([phi * (0.5 * INV_PI) + 0.5, theta * INV_PI], dim=-1)


def equirect_dir(uv: torch.Tensor) -> torch.Tensor:
    """GLSL ``vec3 equirect_dir(vec2 uv)``: ``[..., 2]`` -> unit ``[..., 3]``."""
    phi = (2.0 * math.pi) * (uv[..., 0] - 0.5)
    theta = math.pi * uv[..., 1]
    sin_theta = torch.sin(theta)
    return torch.stack([sin_theta * torch.sin(phi), torch.cos(theta), -sin_theta * torch.cos(phi)],
                       dim=-1)


def rotate_y(v: torch.Tensor, angle: torch.Tensor) -> torch.Tensor:
    """GLSL ``vec3 rotate_y(vec3 v, float angle)``: counter-clockwise about +Y seen from above."""
    c = torch.cos(angle)
    s = torch.sin(angle)
    return torch.stack([c * v[..., 0] + s * v[..., 2], v[..., 1], -s * v[..., 0] + c * v[..., 2]],
                       dim=-1)


