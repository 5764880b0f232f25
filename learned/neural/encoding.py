"""Fourier positional encoding (Mildenhall et al. 2020, eq. 4; thesis sec. 4.3.2).

``fourier_encode(x, L)`` maps every input component x_i to
``[x_i, sin(pi 2^0 x_i), cos(pi 2^0 x_i), ..., sin(pi 2^(L-1) x_i), cos(pi 2^(L-1) x_i)]`` - the raw
value first, then the pairs, component by component. The generated GLSL (``viewer/neural/``)
emits the same order through ``fourier_feature`` of ``shaders/lib/neural.glsl``.
"""
from __future__ import annotations

import math

import torch


def frequencies(num_freqs: int) -> list[float]:
    """Angular frequencies pi 2^k, k < num_freqs (float32-exact powers of two times pi)."""
    return [math.pi * float(2 ** k) for k in range(num_freqs)]


def encoded_size(dims: int, num_freqs: int) -> int:
    return dims * (1 + 2 * num_freqs)


def fourier_encode(x: torch.Tensor, num_freqs: int) -> torch.Tensor:
    """``x [..., D]`` -> ``[..., D (1 + 2 L)]`` (order in the module docstring)."""
    if num_freqs == 0:
        return x
    freqs = torch.tensor(frequencies(num_freqs), dtype=x.dtype, device=x.device)  # [L]
    ang = x[..., :, None] * freqs  # [..., D, L]
    pairs = torch.stack([torch.sin(ang), torch.cos(ang)], dim=-1).flatten(-2)  # [..., D, 2L]
    return torch.cat([x[..., :, None], pairs], dim=-1).flatten(-2)
