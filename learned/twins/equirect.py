"""Twins of ``shaders/lib/equirect.glsl``: equirect mapping (row 0 = zenith, +Y up) and Y rotation."""
from __future__ import annotations

import math

import torch

from ._cases import Arg, ParityCase

INV_PI = 1.0 / math.pi


def equirect_uv(dir: torch.Tensor) -> torch.Tensor:
    """GLSL ``vec2 equirect_uv(vec3 dir)``: ``[..., 3]`` -> ``[..., 2]`` (u, v) in [0, 1]."""
    x, y, z = dir[..., 0], dir[..., 1], dir[..., 2]
    rho = torch.sqrt(x * x + z * z)
    phi = torch.where(rho > 0.0, torch.atan2(x, -z), torch.zeros_like(x))
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


PARITY_CASES = [
    ParityCase("equirect_uv",
               (Arg(kind="unit", components=3,
                    adversarial=((0.0, 1.0, 0.0), (0.0, -1.0, 0.0), (0.0, 0.0, -1.0), (1.0, 0.0, 0.0),
                                 (-1.0, 0.0, 0.0), (1e-20, 1.0, 0.0), (0.0, 2.0, 0.0),
                                 (3.0, 0.0, -4.0))),),
               atol=3e-6, rtol=1e-5,
               measured="max abs 1.07e-6 (seeds 0-3; llvmpipe atan approximation)"),
    ParityCase("equirect_dir",
               (Arg(components=2, adversarial=((0.0, 0.0), (0.5, 0.5), (1.0, 1.0), (0.75, 0.5))),),
               atol=1e-6, rtol=1e-5, measured="max abs 1.2e-7 (seeds 0-3)"),
    ParityCase("rotate_y",
               (Arg(lo=-2.0, hi=2.0, components=3, adversarial=((1.0, 0.0, 0.0),)),
                Arg(lo=-7.0, hi=7.0, adversarial=(0.0, math.pi / 2, -math.pi))),
               atol=1e-6, rtol=1e-5, measured="max abs 2.4e-7 (seeds 0-3; |angle| <= 7)"),
]
