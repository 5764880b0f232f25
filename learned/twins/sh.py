"""Twins of ``shaders/lib/sh.glsl``: real SH basis (3 bands) and Ramamoorthi-Hanrahan irradiance."""
from __future__ import annotations

import math

import torch

SH_C = (0.282094791773878, 0.488602511902920, 1.092548430592079, 0.315391565252520,
        0.546274215296040)
SH_COSINE_LOBE = (math.pi,) + (2.0 * math.pi / 3.0,) * 3 + (0.25 * math.pi,) * 5  # A_l per index


def sh_basis_all(n: torch.Tensor) -> torch.Tensor:
    """All 9 basis functions at unit vectors ``n [..., 3]`` -> ``[..., 9]`` (GLSL index order)."""
    x, y, z = n[..., 0], n[..., 1], n[..., 2]
    c0, c1, c2, c3, c4 = SH_C
    return torch.stack([
        torch.full_like(x, c0),
        c1 * y, c1 * z, c1 * x,
        c2 * x * y, c2 * y * z, c3 * (3.0 * z * z - 1.0), c2 * x * z, c4 * (x * x - y * y),
    ], dim=-1)


def sh_basis(index: torch.Tensor, n: torch.Tensor) -> torch.Tensor:
    """GLSL ``float sh_basis(int index, vec3 n)``: index ``[...]`` (0..8, else 0),
    n ``[..., 3]``."""
    idx = index.round().to(torch.int64) if index.is_floating_point() else index.to(torch.int64)
    all9 = sh_basis_all(n)
    valid = (idx >= 0) & (idx <= 8)
    picked = torch.gather(all9, -1, idx.clamp(0, 8)[..., None].expand(*all9.shape[:-1], 1))[..., 0]
    return torch.where(valid, picked, torch.zeros_like(picked))


def sh_cosine_lobe(index: torch.Tensor) -> torch.Tensor:
    """GLSL ``float sh_cosine_lobe(int index)``: A_l for the band of ``index``."""
    idx = index.round().to(torch.int64) if index.is_floating_point() else index.to(torch.int64)
    return torch.where(idx == 0, torch.tensor(math.pi, dtype=torch.float32),
                       torch.where(idx < 4, torch.tensor(2.0 * math.pi / 3.0, dtype=torch.float32),
                                   torch.tensor(0.25 * math.pi, dtype=torch.float32)))


def sh_irradiance(n: torch.Tensor, sh: torch.Tensor) -> torch.Tensor:
    """GLSL ``vec3 sh_irradiance(vec3 n, vec3[9] sh)``: n ``[..., 3]``, sh ``[9, 3]`` (or
    ``[..., 9, 3]``) -> irradiance ``[..., 3]``, clamped at 0."""
    lobe = torch.tensor(SH_COSINE_LOBE, dtype=n.dtype)
    w = sh_basis_all(n) * lobe  # [..., 9]
    return (w[..., None] * sh.to(n.dtype)).sum(dim=-2).clamp_min(0.0)


