"""Twins of ``shaders/lib/mc.glsl``: scrambled (0, 2)-sequences, hemisphere and GGX-VNDF sampling,
their pdfs, the GGX specular BRDF and MIS weights.

Integer functions run on int64 tensors holding uint32 values (products split so nothing overflows),
so the per-pixel sample sequence is bit-exact: a render's samples are a pure function of
(pixel, sample index, seed) in both languages.
"""
from __future__ import annotations

import math

import torch

from .brdf import BRDF_MIN_DENOM, d_ggx, f_schlick, v_smith_ggx_correlated
from .common import INV_PI, saturate, sq
from .sampling import _as_uint

_MASK32 = 0xFFFFFFFF
_LUMA = (0.2126, 0.7152, 0.0722)


def _mul32(x: torch.Tensor, c: int) -> torch.Tensor:
    """(x * c) mod 2^32 for uint32 values in int64 without overflow."""
    lo = x * (c & 0xFFFF)
    hi = ((x * (c >> 16)) & 0xFFFF) << 16
    return (lo + hi) & _MASK32


def hash_u32(x: torch.Tensor) -> torch.Tensor:
    """GLSL ``uint hash_u32(uint x)`` (Wellons' lowbias32) on int64 tensors holding uint32."""
    x = _as_uint(x)
    x = x ^ (x >> 16)
    x = _mul32(x, 0x7FEB352D)
    x = x ^ (x >> 15)
    x = _mul32(x, 0x846CA68B)
    x = x ^ (x >> 16)
    return x


def mc_scramble(px, py, seed, dim) -> torch.Tensor:
    """GLSL ``uint mc_scramble(uint px, uint py, uint seed, uint dim)``."""
    px, py, seed, dim = (_as_uint(torch.as_tensor(t)) for t in (px, py, seed, dim))
    inner = hash_u32((dim + 0x9E3779B9) & _MASK32)
    return hash_u32(px ^ hash_u32(py ^ hash_u32(seed ^ inner)))


_SOBOL2_V = []
_v = 1 << 31
for _ in range(32):
    _SOBOL2_V.append(_v)
    _v ^= _v >> 1


def sobol2_bits(i: torch.Tensor) -> torch.Tensor:
    """GLSL ``uint sobol2_bits(uint i)``: Sobol' dimension 2 as 32 bits (Kollig & Keller 2002)."""
    i = _as_uint(i)
    r = torch.zeros_like(i)
    for k, v in enumerate(_SOBOL2_V):
        r = r ^ torch.where(((i >> k) & 1) != 0, torch.full_like(i, v), torch.zeros_like(i))
    return r


def _reverse_bits(b: torch.Tensor) -> torch.Tensor:
    b = ((b << 16) | (b >> 16)) & _MASK32
    b = ((b & 0x55555555) << 1) | ((b & 0xAAAAAAAA) >> 1)
    b = ((b & 0x33333333) << 2) | ((b & 0xCCCCCCCC) >> 2)
    b = ((b & 0x0F0F0F0F) << 4) | ((b & 0xF0F0F0F0) >> 4)
    b = ((b & 0x00FF00FF) << 8) | ((b & 0xFF00FF00) >> 8)
    return b


def sobol_2d(index, scramble_x, scramble_y) -> torch.Tensor:
    """GLSL ``vec2 sobol_2d(uint index, uint scramble_x, uint scramble_y)`` -> ``[..., 2]``."""
    i = _as_uint(torch.as_tensor(index))
    x = _reverse_bits(i) ^ _as_uint(torch.as_tensor(scramble_x))
    y = sobol2_bits(i) ^ _as_uint(torch.as_tensor(scramble_y))
    x, y = torch.broadcast_tensors(x, y)
    return torch.stack([(x >> 8).to(torch.float32), (y >> 8).to(torch.float32)], dim=-1) \
        * 5.9604644775390625e-08


def mc_sample_2d(px, py, index, seed, dim) -> torch.Tensor:
    """GLSL ``vec2 mc_sample_2d(uint px, uint py, uint index, uint seed, uint dim)``."""
    d = _as_uint(torch.as_tensor(dim))
    return sobol_2d(index, mc_scramble(px, py, seed, 2 * d), mc_scramble(px, py, seed, 2 * d + 1))


def sample_uniform_hemisphere(u: torch.Tensor) -> torch.Tensor:
    """GLSL ``vec3 sample_uniform_hemisphere(vec2 u)``: ``[..., 2]`` -> ``[..., 3]``."""
    z = u[..., 0]
    r = torch.sqrt((1.0 - z * z).clamp_min(0.0))
    phi = (2.0 * math.pi) * u[..., 1]
    return torch.stack([r * torch.cos(phi), r * torch.sin(phi), z], dim=-1)


def sample_cosine_hemisphere(u: torch.Tensor) -> torch.Tensor:
    """GLSL ``vec3 sample_cosine_hemisphere(vec2 u)``: ``[..., 2]`` -> ``[..., 3]``."""
    r = torch.sqrt(u[..., 0])
    phi = (2.0 * math.pi) * u[..., 1]
    return torch.stack([r * torch.cos(phi), r * torch.sin(phi),
                        torch.sqrt((1.0 - u[..., 0]).clamp_min(0.0))], dim=-1)


def pdf_cosine_hemisphere(NoL: torch.Tensor) -> torch.Tensor:
    """GLSL ``float pdf_cosine_hemisphere(float NoL)`` = max(NoL, 0) / pi."""
    return NoL.clamp_min(0.0) * INV_PI


def g1_smith_ggx(NoV: torch.Tensor, a: torch.Tensor) -> torch.Tensor:
    """GLSL ``float g1_smith_ggx(float NoV, float a)``."""
    NoV = saturate(NoV)
    a2 = sq(saturate(a))
    return 2.0 * NoV / (NoV + torch.sqrt(a2 + (1.0 - a2) * NoV * NoV)).clamp_min(BRDF_MIN_DENOM)


def _normalize(v: torch.Tensor) -> torch.Tensor:
    return v * torch.rsqrt((v * v).sum(-1, keepdim=True))


def sample_ggx_vndf(u: torch.Tensor, v: torch.Tensor, a: torch.Tensor) -> torch.Tensor:
    """GLSL ``vec3 sample_ggx_vndf(vec2 u, vec3 v, float a)`` (Dupuy & Benyoub 2023):
    u ``[..., 2]``, v ``[..., 3]`` (tangent space), a ``[...]`` -> unit half vector ``[..., 3]``."""
    a = saturate(a).clamp_min(1e-4)
    vh = _normalize(torch.stack([a * v[..., 0], a * v[..., 1], v[..., 2].clamp_min(0.0) + 1e-7],
                                dim=-1))
    phi = (2.0 * math.pi) * u[..., 0]
    d = (vh[..., 0] * vh[..., 0] + vh[..., 1] * vh[..., 1]) / (1.0 + vh[..., 2])
    e = (1.0 - u[..., 1]) * (1.0 + vh[..., 2]) + d
    sin_theta = torch.sqrt((e * (2.0 - e)).clamp(0.0, 1.0))
    hh = torch.stack([sin_theta * torch.cos(phi) + vh[..., 0],
                      sin_theta * torch.sin(phi) + vh[..., 1], e - d], dim=-1)
    h = torch.stack([a * hh[..., 0], a * hh[..., 1], hh[..., 2].clamp_min(0.0)], dim=-1)
    len2 = (h * h).sum(-1, keepdim=True)
    up = torch.zeros_like(h)
    up[..., 2] = 1.0
    return torch.where(len2 > 1e-30, h * torch.rsqrt(len2.clamp_min(1e-30)), up)


def pdf_ggx_vndf(NoV: torch.Tensor, NoH: torch.Tensor, a: torch.Tensor) -> torch.Tensor:
    """GLSL ``float pdf_ggx_vndf(float NoV, float NoH, float a)``: pdf of the reflected
    direction."""
    NoV = saturate(NoV)
    a2 = sq(saturate(a))
    denom = 2.0 * (NoV + torch.sqrt(a2 + (1.0 - a2) * NoV * NoV)).clamp_min(BRDF_MIN_DENOM)
    return torch.where(NoH > 0.0, d_ggx(NoH, a) / denom, torch.zeros_like(denom))


def ggx_specular_brdf(f0, f90, NoV, NoL, NoH, VoH, a) -> torch.Tensor:
    """GLSL ``vec3 ggx_specular_brdf(vec3 f0, float f90, float NoV, NoL, NoH, VoH, float a)``."""
    return (d_ggx(NoH, a) * v_smith_ggx_correlated(NoV, NoL, a))[..., None] \
        * f_schlick(f0, f90, VoH)


def specular_lobe_probability(diffuse, f0, f90, NoV) -> torch.Tensor:
    """GLSL ``float specular_lobe_probability(vec3 diffuse, vec3 f0, float f90, float NoV)``."""
    y = torch.tensor(_LUMA, dtype=torch.float32)
    s = (f_schlick(f0, f90, NoV) * y).sum(-1)
    d = (diffuse * y).sum(-1)
    return torch.where(s + d > 0.0, s / torch.where(s + d > 0.0, s + d, torch.ones_like(s)),
                       torch.full_like(s, 0.5))


def mis_weight(pdf_a, pdf_b, power) -> torch.Tensor:
    """GLSL ``float mis_weight(float pdf_a, float pdf_b, float power)``: power 2 -> power
    heuristic, else balance."""
    a = pdf_a.clamp_min(0.0)
    b = pdf_b.clamp_min(0.0)
    p2 = torch.as_tensor(power) > 1.5
    a = torch.where(p2, a * a, a)
    b = torch.where(p2, b * b, b)
    s = a + b
    return torch.where(s > 0.0, a / torch.where(s > 0.0, s, torch.ones_like(s)),
                       torch.zeros_like(s))
