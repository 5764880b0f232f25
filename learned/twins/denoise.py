"""Twins of ``shaders/lib/denoise.glsl``: the a-trous filter's kernel and edge-stopping weights."""
from __future__ import annotations

import torch


def atrous_kernel(k: torch.Tensor) -> torch.Tensor:
    """GLSL ``float atrous_kernel(float k)``: the B3 spline's 1D weight of offset k."""
    a = k.abs()
    return torch.where(a < 0.5, torch.full_like(a, 0.375),
                       torch.where(a < 1.5, torch.full_like(a, 0.25), torch.full_like(a, 0.0625)))


def atrous_edge_weight(depth_p: torch.Tensor, depth_q: torch.Tensor, n_p: torch.Tensor,
                       n_q: torch.Tensor, step_px: torch.Tensor, sigma_z: torch.Tensor,
                       sigma_n: torch.Tensor) -> torch.Tensor:
    """GLSL ``float atrous_edge_weight(float depth_p, float depth_q, vec3 n_p, vec3 n_q,
    float step_px, float sigma_z, float sigma_n)``."""
    valid = (depth_q > 0.0) & (depth_p > 0.0)
    dz = (depth_p - depth_q).abs() / (sigma_z * depth_p * torch.clamp(step_px, min=1.0) + 1e-6)
    w_n = torch.pow(torch.clamp((n_p * n_q).sum(-1), min=0.0), sigma_n)
    return torch.where(valid, torch.exp(-dz) * w_n, torch.zeros_like(dz))
