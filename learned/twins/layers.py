"""Twins of ``shaders/lib/layers.glsl``: material layers over the base BRDF (KHR_materials_clearcoat)
and the octahedral normal encoding. Scalars ``[...]``, ``vec3`` ``[..., 3]``."""
from __future__ import annotations

import torch

from .brdf import d_ggx, v_smith_ggx_correlated
from .common import half_vector, saturate

CLEARCOAT_F0 = 0.04


def clearcoat_weight(clearcoat: torch.Tensor, NoV: torch.Tensor) -> torch.Tensor:
    """GLSL ``float clearcoat_weight(float clearcoat, float NoV)``: c F_c(n_c.v), Schlick with
    F0 = 0.04."""
    x = 1.0 - saturate(NoV)
    x2 = x * x
    return saturate(clearcoat) * (CLEARCOAT_F0 + (1.0 - CLEARCOAT_F0) * (x2 * x2 * x))


def clearcoat_split_sum(w: torch.Tensor, dfg: torch.Tensor, prefiltered: torch.Tensor
                        ) -> torch.Tensor:
    """GLSL ``vec3 clearcoat_split_sum(float w, vec2 dfg, vec3 prefiltered)``: w dfg.y P."""
    return (w * dfg[..., 1])[..., None] * prefiltered


def clearcoat_light(w: torch.Tensor, a: torch.Tensor, n: torch.Tensor, v: torch.Tensor,
                    l: torch.Tensor) -> torch.Tensor:
    """GLSL ``float clearcoat_light(float w, float a, vec3 n, vec3 v, vec3 l)``: w D V n.l, 0
    where n.l <= 0."""
    NoL = (n * l).sum(-1)
    h = half_vector(v, l)
    NoV = saturate((n * v).sum(-1))
    out = w * d_ggx(saturate((n * h).sum(-1)), a) * v_smith_ggx_correlated(NoV, NoL, a) * NoL
    return torch.where(NoL > 0.0, out, torch.zeros_like(out))


def _sign_not_neg(x: torch.Tensor) -> torch.Tensor:
    return torch.where(x >= 0.0, torch.ones_like(x), -torch.ones_like(x))


def oct_encode(n: torch.Tensor) -> torch.Tensor:
    """GLSL ``vec2 oct_encode(vec3 n)`` (Cigolle et al. 2014). [..., 3] -> [..., 2]."""
    a = n.abs()
    p = n[..., :2] / (a[..., 0] + a[..., 1] + a[..., 2]).clamp_min(1e-30)[..., None]
    folded = (1.0 - p.flip(-1).abs()) * _sign_not_neg(p)
    return torch.where((n[..., 2] < 0.0)[..., None], folded, p)


def oct_decode(e: torch.Tensor) -> torch.Tensor:
    """GLSL ``vec3 oct_decode(vec2 e)``: the unit vector. [..., 2] -> [..., 3]."""
    z = 1.0 - e[..., 0].abs() - e[..., 1].abs()
    folded = (1.0 - e.flip(-1).abs()) * _sign_not_neg(e)
    xy = torch.where((z < 0.0)[..., None], folded, e)
    n = torch.cat([xy, z[..., None]], -1)
    return n / torch.linalg.vector_norm(n, dim=-1, keepdim=True)
