"""Twins of ``shaders/lib/sampling.glsl``: Hammersley points and GGX importance sampling.

Bit operations run on int64 tensors masked to 32 bits, so ``radical_inverse_vdc`` is bit-exact.
"""
from __future__ import annotations

import math

import torch

from .brdf import BRDF_MIN_A2
from .common import sq

_MASK32 = 0xFFFFFFFF


def _as_uint(x: torch.Tensor) -> torch.Tensor:
    """Integer-valued float (or int) tensor -> int64 holding a uint32."""
    if x.is_floating_point():
        x = x.to(torch.float64).round()
    return x.to(torch.int64) & _MASK32


def radical_inverse_vdc(bits: torch.Tensor) -> torch.Tensor:
    """GLSL ``float radical_inverse_vdc(uint bits)``: base-2 radical inverse, top 24 bits,
    float32."""
    b = _as_uint(bits)
    b = ((b << 16) | (b >> 16)) & _MASK32
    b = ((b & 0x55555555) << 1) | ((b & 0xAAAAAAAA) >> 1)
    b = ((b & 0x33333333) << 2) | ((b & 0xCCCCCCCC) >> 2)
    b = ((b & 0x0F0F0F0F) << 4) | ((b & 0xF0F0F0F0) >> 4)
    b = ((b & 0x00FF00FF) << 8) | ((b & 0xFF00FF00) >> 8)
    return (b >> 8).to(torch.float32) * 5.9604644775390625e-08


def hammersley(i: torch.Tensor, n: torch.Tensor | int) -> torch.Tensor:
    """GLSL ``vec2 hammersley(uint i, uint n)`` -> ``[..., 2]`` = (i / n, radical_inverse(i))."""
    ii = _as_uint(i)
    nn = _as_uint(torch.as_tensor(n)).clamp_min(1)
    x = ii.to(torch.float32) / nn.to(torch.float32)
    return torch.stack(torch.broadcast_tensors(x, radical_inverse_vdc(ii)), dim=-1)


def hammersley_sequence(n: int) -> torch.Tensor:
    """All ``n`` Hammersley points ``[n, 2]`` float32, as the GLSL passes enumerate them."""
    return hammersley(torch.arange(n, dtype=torch.int64), n)


def importance_sample_ggx(xi: torch.Tensor, a: torch.Tensor) -> torch.Tensor:
    """GLSL ``vec3 importance_sample_ggx(vec2 xi, float a)``: xi ``[..., 2]`` -> ``[..., 3]``."""
    a2 = sq(a.clamp(0.0, 1.0))
    phi = (2.0 * math.pi) * xi[..., 0]
    t = xi[..., 1].clamp(0.0, 1.0)
    one_minus_t = 1.0 - t
    a2t = a2 * t
    denom = (one_minus_t + a2t).clamp_min(1e-30)
    cos2 = (one_minus_t / denom).clamp(0.0, 1.0)
    sin2 = (a2t / denom).clamp(0.0, 1.0)
    sin_theta = torch.sqrt(sin2)
    return torch.stack([sin_theta * torch.cos(phi), sin_theta * torch.sin(phi), torch.sqrt(cos2)],
                       dim=-1)


def ggx_sample_d(xi: torch.Tensor, a: torch.Tensor) -> torch.Tensor:
    """GLSL ``float ggx_sample_d(vec2 xi, float a)``: D of the half vector
    :func:`importance_sample_ggx` draws for xi, = q^2 / (pi a^2) with q = (1 - t) + a^2 t."""
    a2 = sq(a.clamp(0.0, 1.0)).clamp_min(BRDF_MIN_A2)
    t = xi[..., 1].clamp(0.0, 1.0)
    q = (1.0 - t) + a2 * t
    return q * q / (math.pi * a2)


def tangent_to_world(v: torch.Tensor, n: torch.Tensor) -> torch.Tensor:
    """GLSL ``vec3 tangent_to_world(vec3 v, vec3 n)`` (Duff et al. 2017): ``[..., 3]`` each."""
    nx, ny, nz = n[..., 0], n[..., 1], n[..., 2]
    s = torch.where(nz >= 0.0, torch.ones_like(nz), -torch.ones_like(nz))
    a = -1.0 / (s + nz)
    b = nx * ny * a
    t = torch.stack([1.0 + s * nx * nx * a, s * b, -s * nx], dim=-1)
    bt = torch.stack([b, s + ny * ny * a, -ny], dim=-1)
    return t * v[..., 0:1] + bt * v[..., 1:2] + n * v[..., 2:3]


