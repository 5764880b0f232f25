"""Twins of ``shaders/lib/shading.glsl``: the per-pixel shading models on pre-looked-up lighting."""
from __future__ import annotations

import math

import torch

from ._cases import Arg, ParityCase

INV_PI = 1.0 / math.pi


def diffuse_color(albedo: torch.Tensor, metallic: torch.Tensor) -> torch.Tensor:
    """GLSL ``vec3 diffuse_color(vec3 albedo, float metallic)``. albedo [..., 3], metallic [...]."""
    return albedo * (1.0 - metallic.clamp(0.0, 1.0))[..., None]


def shading_normal(n: torch.Tensor, v: torch.Tensor) -> torch.Tensor:
    """GLSL ``vec3 shading_normal(vec3 n, vec3 v)``: unit normal with n.v >= ~1e-4; zero-length or
    NaN normals face the viewer. n, v: [..., 3] (v unit, towards the viewer)."""
    len2 = (n * n).sum(-1, keepdim=True)
    bad = ~(len2 > 1e-12)
    nn = n * torch.rsqrt(torch.where(bad, torch.ones_like(len2), len2))
    nv = (nn * v).sum(-1, keepdim=True)
    bent = nn + (1e-4 - nv) * v
    bent = bent / torch.linalg.vector_norm(bent, dim=-1, keepdim=True)
    out = torch.where(nv < 1e-4, bent, nn)
    return torch.where(bad, v, out)


def ggx_split_sum(diffuse: torch.Tensor, f0: torch.Tensor, ao: torch.Tensor,
                  irradiance: torch.Tensor, prefiltered: torch.Tensor, dfg: torch.Tensor,
                  multiscatter: torch.Tensor) -> torch.Tensor:
    """GLSL ``vec3 ggx_split_sum(...)``: split-sum GGX IBL (Karis 2013, Filament).

    diffuse, f0, irradiance, prefiltered: [..., 3]; ao, multiscatter: [...]; dfg: [..., 2].
    """
    from .brdf import f90_from_f0
    from .ibl import ibl_energy_compensation, ibl_specular_dfg

    e_spec = ibl_specular_dfg(dfg, f0, f90_from_f0(f0))
    e_spec = torch.where((multiscatter > 0.5)[..., None], e_spec * ibl_energy_compensation(dfg, f0),
                         e_spec)
    fd = diffuse * irradiance * INV_PI * ao[..., None] * (1.0 - e_spec).clamp_min(0.0)
    return fd + e_spec * prefiltered


def blinn_phong(diffuse: torch.Tensor, f0: torch.Tensor, ao: torch.Tensor,
                irradiance: torch.Tensor, prefiltered: torch.Tensor) -> torch.Tensor:
    """GLSL ``vec3 blinn_phong(...)``: Lambert (keeping 1 - f0) + normalised Fresnel-free
    Blinn-Phong lobe."""
    return diffuse * irradiance * INV_PI * ao[..., None] * (1.0 - f0) + f0 * prefiltered


def _nonneg3(hi=1.0, adv=()):
    return Arg(lo=0.0, hi=hi, components=3, adversarial=adv)


def _fix_dfg(args):
    # the LUT never holds dfg.y = 0 or dfg.x > dfg.y; keep random inputs in the LUT's range
    dfg = args[5]
    dfg[:, 1] = dfg[:, 1].clip(1e-3, 1.0)
    dfg[:, 0] = dfg[:, 0].clip(0.0, None) * dfg[:, 1]
    return args


PARITY_CASES = [
    ParityCase("diffuse_color", (_nonneg3(), Arg(lo=-0.5, hi=1.5, adversarial=(0.0, 1.0))),
               atol=0.0, rtol=1e-7, measured="exact"),
    ParityCase("shading_normal",
               (Arg(kind="unit", components=3, adversarial=((0, 0, 0), (0, 0, -1), (0, 0, 1e-7),
                                                            (1, 0, 0), (0, 0, 5))),
                Arg(kind="hemisphere", components=3, adversarial=((0, 0, 1),))),
               atol=2e-6, rtol=1e-5, measured="max abs 1.8e-7"),
    ParityCase("ggx_split_sum",
               (_nonneg3(), _nonneg3(), Arg(), _nonneg3(10.0), _nonneg3(100.0, ((1e5, 0, 65504),)),
                Arg(lo=0.0, hi=1.0, components=2), Arg(kind="int", lo=0, hi=1)),
               atol=1e-6, rtol=2e-6, measured="max rel 2.4e-7", prepare=_fix_dfg),
    ParityCase("blinn_phong",
               (_nonneg3(), _nonneg3(), Arg(), _nonneg3(10.0), _nonneg3(100.0, ((1e5, 0, 65504),))),
               atol=1e-6, rtol=2e-6, measured="max rel 1.2e-7"),
]
