"""Twins of ``shaders/lib/brdf.glsl``: GGX / Smith / Schlick / Lambert / Blinn-Phong terms.

Same operation order as the GLSL so float32 results agree to a few ulp. Scalars are ``[...]``,
``vec3`` is ``[..., 3]``.
"""
from __future__ import annotations

import math

import torch

from .common import INV_PI, saturate, sq

MIN_PERCEPTUAL_ROUGHNESS = 0.045  # Filament's clamp, applied by shading passes
BRDF_MIN_A2 = 1e-8
BRDF_MIN_DENOM = 1e-8
BLINN_PHONG_MAX_SHININESS = 16384.0


def clamp_perceptual_roughness(perceptual_roughness: torch.Tensor) -> torch.Tensor:
    """GLSL ``float clamp_perceptual_roughness(float)``: clamp to [0.045, 1]."""
    return perceptual_roughness.clamp(MIN_PERCEPTUAL_ROUGHNESS, 1.0)


def compute_f0(base_color: torch.Tensor, metallic: torch.Tensor, specular: torch.Tensor
               ) -> torch.Tensor:
    """GLSL ``vec3 compute_f0(vec3 base_color, float metallic, float specular)``.

    base_color ``[..., 3]``, metallic/specular ``[...]`` -> ``[..., 3]``.
    """
    f0_dielectric = (0.16 * specular * specular)[..., None]
    m = saturate(metallic)[..., None]
    return f0_dielectric * (1.0 - m) + base_color * m  # GLSL mix(x, y, a) = x (1 - a) + y a


def f90_from_f0(f0: torch.Tensor) -> torch.Tensor:
    """GLSL ``float f90_from_f0(vec3 f0)`` (Filament): 1 for real materials, 0 when f0 = 0."""
    return (f0 * (50.0 * 0.33)).sum(-1).clamp(0.0, 1.0)


def dielectric_f0_ior(ior: torch.Tensor, specular_color: torch.Tensor,
                      specular_factor: torch.Tensor) -> torch.Tensor:
    """GLSL ``vec3 dielectric_f0_ior(float ior, vec3 specular_color, float specular_factor)``
    (KHR_materials_ior / _specular): min(((ior - 1) / (ior + 1))^2 colour, 1) factor; ior 0 ->
    F0 = 1. ior, specular_factor ``[...]``, specular_color ``[..., 3]`` -> ``[..., 3]``."""
    f0 = torch.where(ior == 0.0, torch.ones_like(ior), sq((ior - 1.0) / (ior + 1.0)))
    return torch.clamp_max(f0[..., None] * specular_color, 1.0) * specular_factor[..., None]


def surface_f0_f90(base_color: torch.Tensor, metallic: torch.Tensor, specular: torch.Tensor,
                   dielectric: torch.Tensor) -> torch.Tensor:
    """GLSL ``vec4 surface_f0_f90(vec3 base_color, float metallic, float specular, vec4
    dielectric)``: (f0, f90) from the dielectric channel where its a >= 0 (metals: F0 = base
    colour, F90 = 1), else Filament's compute_f0 / f90_from_f0. ``[..., 3]``, ``[...]``,
    ``[...]``, ``[..., 4]`` -> ``[..., 4]``."""
    f0 = compute_f0(base_color, metallic, specular)
    filament = torch.cat([f0, f90_from_f0(f0)[..., None]], -1)
    m = saturate(metallic)[..., None]
    ext = torch.cat([dielectric[..., :3] * (1.0 - m) + base_color * m,
                     dielectric[..., 3:] * (1.0 - m) + m], -1)
    return torch.where(dielectric[..., 3:] < 0.0, filament, ext)


def d_ggx(NoH: torch.Tensor, a: torch.Tensor) -> torch.Tensor:
    """GLSL ``float d_ggx(float NoH, float a)`` (Walter et al. 2007 eq. 33)."""
    NoH = saturate(NoH)
    a2 = sq(saturate(a)).clamp_min(BRDF_MIN_A2)
    f = NoH * NoH * a2 + (1.0 - NoH) * (1.0 + NoH)
    return a2 / (math.pi * f * f)


def v_smith_ggx_correlated(NoV: torch.Tensor, NoL: torch.Tensor, a: torch.Tensor) -> torch.Tensor:
    """GLSL ``float v_smith_ggx_correlated(float NoV, float NoL, float a)`` (Heitz 2014)."""
    NoV = saturate(NoV)
    NoL = saturate(NoL)
    a2 = sq(saturate(a))
    ggx_v = NoL * torch.sqrt((NoV * NoV * (1.0 - a2) + a2).clamp_min(0.0))
    ggx_l = NoV * torch.sqrt((NoL * NoL * (1.0 - a2) + a2).clamp_min(0.0))
    return 0.5 / (ggx_v + ggx_l).clamp_min(BRDF_MIN_DENOM)


def f_schlick(f0: torch.Tensor, f90: torch.Tensor, VoH: torch.Tensor) -> torch.Tensor:
    """GLSL ``vec3 f_schlick(vec3 f0, float f90, float VoH)``: f0 ``[..., 3]``, others ``[...]``."""
    c = saturate(VoH)
    x = 1.0 - c
    x2 = x * x
    x5 = x2 * x2 * x
    one_minus_x5 = c * (1.0 + x * (1.0 + x * (1.0 + x * (1.0 + x))))
    return f0 * one_minus_x5[..., None] + (f90 * x5)[..., None]


def fd_lambert() -> torch.Tensor:
    """GLSL ``float fd_lambert()``: 1/pi."""
    return torch.tensor(INV_PI, dtype=torch.float32)


def d_blinn_phong(NoH: torch.Tensor, shininess: torch.Tensor) -> torch.Tensor:
    """GLSL ``float d_blinn_phong(float NoH, float shininess)``: (s + 2)/(2 pi) NoH^s."""
    s = shininess.clamp(0.0, BLINN_PHONG_MAX_SHININESS)
    return (s + 2.0) * (0.5 * INV_PI) * torch.pow(saturate(NoH).clamp_min(1e-30), s)


def blinn_phong_shininess(a: torch.Tensor) -> torch.Tensor:
    """GLSL ``float blinn_phong_shininess(float a)``: 2/a^2 - 2 clamped to [0, 16384]."""
    a2 = sq(saturate(a)).clamp_min(BRDF_MIN_A2)
    return (2.0 / a2 - 2.0).clamp(0.0, BLINN_PHONG_MAX_SHININESS)


