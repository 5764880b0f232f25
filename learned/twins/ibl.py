"""Twins of ``shaders/lib/ibl.glsl``: the split-sum lookups (prefiltered chain, DFG and dominant
direction LUTs) and the specular terms built from them.

The filtering they use (and its GPU error envelope) lives in :mod:`learned.twins.filtering`, the
twins of the precompute passes in :mod:`learned.twins.ibl_precompute`; both are re-exported here,
so ``learned.twins.ibl.radiance_chain`` and ``learned.twins.ibl.sample_trilinear_envelope`` keep
working.
"""
from __future__ import annotations

import torch

from .equirect import equirect_dir, equirect_uv  # noqa: F401 - equirect_dir re-exported
from .filtering import (  # noqa: F401 - re-exported
    ATAN_ABS_ERROR,
    DIRECTION_ABS_ERROR,
    FILTER_WEIGHT_BITS,
    equirect_uv_error,
    sample_bilinear,
    sample_trilinear,
    sample_trilinear_envelope,
)
from .ibl_precompute import (  # noqa: F401 - re-exported
    compose_level,
    compose_sample,
    dfg_lut,
    dominant_lut,
    downsample_box,
    prefilter_environment,
    prefilter_level,
    prefilter_level_envelope,
    radiance_chain,
    sh_project,
    texel_solid_angle,
)

# ---------------------------------------------------------------------------------------------
# lib/ibl.glsl
# ---------------------------------------------------------------------------------------------

def ibl_specular_radiance(prefiltered: list[torch.Tensor], r_ws: torch.Tensor,
                          perceptual_roughness: torch.Tensor, levels: float) -> torch.Tensor:
    """GLSL ``vec3 ibl_specular_radiance(sampler2D, vec3 r_ws, float r, float levels)``:
    prefiltered chain (list of ``[h, w, C]``), r_ws ``[..., 3]`` -> ``[..., 3]``."""
    lod = prefilter_lod(perceptual_roughness, torch.full_like(perceptual_roughness, float(levels)))
    return sample_trilinear(prefiltered, equirect_uv(r_ws), lod)[..., :3]


def ibl_specular_radiance_sun(sunless: list[torch.Tensor], full: list[torch.Tensor],
                              r_ws: torch.Tensor, perceptual_roughness: torch.Tensor,
                              levels: float, w: torch.Tensor) -> torch.Tensor:
    """GLSL ``vec3 ibl_specular_radiance_sun(sampler2D sunless, sampler2D full, vec3 r_ws, float r,
    float levels, float w)``: mix(full, sunless, w) of the two chains' lookups where w < 1, the
    sun-less lookup where w = 1. w ``[...]`` -> ``[..., 3]``."""
    p = ibl_specular_radiance(sunless, r_ws, perceptual_roughness, levels)
    f = ibl_specular_radiance(full, r_ws, perceptual_roughness, levels)
    w3 = w[..., None]
    return torch.where(w3 < 1.0, f * (1.0 - w3) + p * w3, p)


def irradiance_lookup(irradiance: torch.Tensor, n_ws: torch.Tensor) -> torch.Tensor:
    """GLSL ``vec3 irradiance_lookup(sampler2D irradiance, vec3 n_ws)``: the irradiance map
    ``[h, w, C]`` (rows from pole to pole, :mod:`viewer.environment.irradiance`) bilinear at the normal's
    equirect uv with v moved onto those rows. n_ws ``[..., 3]`` -> ``[..., 3]``."""
    uv = equirect_uv(n_ws)
    h = float(irradiance.shape[0])
    uv = torch.stack([uv[..., 0], (uv[..., 1] * (h - 1.0) + 0.5) / h], dim=-1)
    return sample_bilinear(irradiance, uv)[..., :3]


def prefilter_lod(perceptual_roughness: torch.Tensor, levels: torch.Tensor) -> torch.Tensor:
    """GLSL ``float prefilter_lod(float r, float levels)``: with alpha = r^2 and alpha_1 =
    2^(1 - (levels - 1)), alpha / alpha_1 min(levels - 1, 1) below alpha_1, else
    (levels - 1) + log2(alpha)."""
    last = (levels - 1.0).clamp_min(0.0)
    r = perceptual_roughness.clamp(0.0, 1.0)
    a = r * r
    a1 = torch.exp2(1.0 - last)
    return torch.where(a < a1, a / a1 * last.clamp_max(1.0), last + torch.log2(a))


def ibl_dfg(dfg: torch.Tensor, NoV: torch.Tensor, perceptual_roughness: torch.Tensor
            ) -> torch.Tensor:
    """GLSL ``vec2 ibl_dfg(sampler2D dfg, float NoV, float r)``: LUT ``[n, n, 2]`` -> ``[..., 2]``."""
    n = torch.tensor([float(dfg.shape[1]), float(dfg.shape[0])], dtype=torch.float32)
    x = torch.stack([NoV.clamp(0.0, 1.0), perceptual_roughness.clamp(0.0, 1.0)], dim=-1)
    uv = (x * (n - 1.0) + 0.5) / n  # texel centres on the end points (see dfg_lut)
    return sample_bilinear(dfg, uv, repeat_u=False)[..., :2]


def ibl_dominant_factor(dominant: torch.Tensor, NoV: torch.Tensor,
                        perceptual_roughness: torch.Tensor) -> torch.Tensor:
    """GLSL ``float ibl_dominant_factor(sampler2D dominant, float NoV, float r)``: LUT
    ``[n, n, 1]`` -> ``[...]``."""
    n = torch.tensor([float(dominant.shape[1]), float(dominant.shape[0])], dtype=torch.float32)
    x = torch.stack([NoV.clamp(0.0, 1.0), perceptual_roughness.clamp(0.0, 1.0)], dim=-1)
    uv = (x * (n - 1.0) + 0.5) / n
    return sample_bilinear(dominant, uv, repeat_u=False)[..., 0]


def specular_dominant_direction(n: torch.Tensor, r: torch.Tensor, t: torch.Tensor
                                ) -> torch.Tensor:
    """GLSL ``vec3 specular_dominant_direction(vec3 n, vec3 r, float t)`` =
    normalize(mix(n, r, t)): n, r ``[..., 3]``, t ``[...]`` -> ``[..., 3]``."""
    d = n + (r - n) * t[..., None]
    return d * torch.rsqrt((d * d).sum(-1, keepdim=True))


def ibl_specular_dfg(dfg: torch.Tensor, f0: torch.Tensor, f90: torch.Tensor) -> torch.Tensor:
    """GLSL ``vec3 ibl_specular_dfg(vec2 dfg, vec3 f0, float f90)`` = f0 (y - x) + f90 x."""
    x = dfg[..., 0:1]
    y = dfg[..., 1:2]
    return f0 * (y - x) + f90[..., None] * x


def ibl_energy_compensation(dfg: torch.Tensor, f0: torch.Tensor) -> torch.Tensor:
    """GLSL ``vec3 ibl_energy_compensation(vec2 dfg, vec3 f0)`` = 1 + f0 (1 / dfg.y - 1)."""
    return 1.0 + f0 * (1.0 / dfg[..., 1:2].clamp_min(1e-4) - 1.0)
