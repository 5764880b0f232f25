"""Twins of ``shaders/lib/sampling.glsl``: Hammersley points and GGX importance sampling.

Bit operations run on int64 tensors masked to 32 bits, so ``radical_inverse_vdc`` is bit-exact.
"""
from __future__ import annotations

import math

import torch

from ._cases import Arg, ParityCase
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


_UINT = Arg(kind="int", lo=0, hi=(1 << 24) - 1, adversarial=(0.0, 1.0, 2.0, 3.0, 255.0, 16777215.0))

# Envelopes: u = 2^-24. "first-order on the draws": per-operation error bounds (GLSL 4.60
# table on the GL side, correct rounding / 1 ulp libm on the torch side) propagated to first
# order through the function at the drawn inputs; machine-independent.
PARITY_CASES = [
    ParityCase("radical_inverse_vdc", (_UINT,), atol=0.0, rtol=0.0, measured="bit-exact",
               envelope="exact: integer bit reversal, 24-bit value converts exactly, x 2^-24 "
                        "exact"),
    ParityCase("hammersley", (Arg(kind="int", lo=0, hi=4095, adversarial=(0.0, 63.0, 4095.0)),
                              Arg(kind="int", lo=1, hi=4096, adversarial=(0.0, 1.0, 64.0, 4096.0))),
               atol=0.0, rtol=3.6e-7, measured="bit-exact on llvmpipe",
               envelope="radical inverse exact; float(i) / float(n): GLSL division 2.5 ulp "
                        "(GPUs use a * rcp(b)) + torch's 0.5 -> 3 ulp = 3.6e-7 rel (rtol widened "
                        "from 0)"),
    ParityCase("importance_sample_ggx",
               (Arg(components=2, adversarial=((0.0, 0.0), (0.999, 0.9999999), (0.5, 1.0))),
                Arg(lo=0.0, hi=1.0, adversarial=(0.0, 1e-4, 0.002025, 1.0))),
               atol=2e-6, rtol=1e-5, measured="max abs 1.2e-7 (seeds 0-7; sin/cos of phi)",
               envelope="sin_theta (cos, sin) phi: trig ~1e-6 abs (assumed) + 2 pi xi.x rounding "
                        "2.4e-7 + sin2 = a2 t / denom (2.5 ulp) and sqrt (4.5 ulp) -> 2e-6 abs "
                        "(first-order on the draws 1.7e-6; atol widened from 1e-6); z = "
                        "sqrt(cos2) ~8 ulp rel"),
    ParityCase("ggx_sample_d",
               (Arg(components=2, adversarial=((0.0, 0.0), (0.999, 0.9999999), (0.5, 1.0))),
                Arg(lo=0.0, hi=1.0, adversarial=(0.0, 1e-4, 0.002025, 0.0625, 1.0))),
               atol=0.0, rtol=1.2e-6, measured="max rel 1.2e-7 (seeds 0-7); nosse: 4.1e-7",
               envelope="q = (1 - t) + a2 t sums terms >= 0 (2 roundings), q q (5), a2 (1), "
                        "pi a2 (1), / 2.5 ulp (5) in units of 2^-24: 12 GPU + 8 torch = 1.2e-6 "
                        "rel (rtol widened from 1e-6)"),
    ParityCase("tangent_to_world",
               (Arg(kind="unit", components=3, adversarial=((0.0, 0.0, 1.0), (1.0, 0.0, 0.0))),
                Arg(kind="unit", components=3,
                    adversarial=((0.0, 0.0, 1.0), (0.0, 0.0, -1.0), (1.0, 0.0, 0.0),
                                 (0.0, 0.99999994, -0.0003452669)))),
               atol=1e-6, rtol=1e-5, measured="max abs 1.2e-7 (seeds 0-7)",
               envelope="Duff et al. basis: a = -1 / (s + n.z) with |s + n.z| >= 1 (2.5 ulp), "
                        "entries ~4 roundings, 3-term combination with |v| = 1 (cancels): "
                        "first-order 7e-7 abs near 0, 70% of the tolerance"),
]
