"""Twins of ``shaders/lib/anisotropy.glsl``: glTF KHR_materials_anisotropy's anisotropic GGX,
its visible-normal sampling, the IBL bent normal and the G-buffer direction encoding. Scalars
``[...]``, ``vec2`` ``[..., 2]``, ``vec3`` ``[..., 3]``."""
from __future__ import annotations

import math

import torch

from .brdf import BRDF_MIN_DENOM
from .common import INV_PI, saturate, sq
from .sampling import tangent_to_world

ANISOTROPY_MIN_ALPHA = 1e-4


def _normalize(v: torch.Tensor) -> torch.Tensor:
    return v * torch.rsqrt((v * v).sum(-1, keepdim=True))


def anisotropy_alphas(a: torch.Tensor, strength: torch.Tensor) -> torch.Tensor:
    """GLSL ``vec2 anisotropy_alphas(float a, float strength)``: (mix(a, 1, s^2), a)."""
    s = saturate(strength)
    return torch.stack([a * (1.0 - s * s) + s * s, a], dim=-1)


def d_ggx_anisotropic(NoH, ToH, BoH, at, ab) -> torch.Tensor:
    """GLSL ``float d_ggx_anisotropic(float NoH, float ToH, float BoH, float at, float ab)``
    (Burley 2012, the extension's D)."""
    at = at.clamp_min(ANISOTROPY_MIN_ALPHA)
    ab = ab.clamp_min(ANISOTROPY_MIN_ALPHA)
    a2 = at * ab
    f = torch.stack([ab * ToH, at * BoH, a2 * saturate(NoH)], dim=-1)
    w2 = a2 / (f * f).sum(-1).clamp_min(1e-30)
    return a2 * w2 * w2 * INV_PI


def v_smith_ggx_correlated_anisotropic(NoV, NoL, ToV, BoV, ToL, BoL, at, ab) -> torch.Tensor:
    """GLSL ``float v_smith_ggx_correlated_anisotropic(...)`` (Heitz 2014 eq. 99, anisotropic
    Lambda)."""
    NoV = saturate(NoV)
    NoL = saturate(NoL)
    ggx_v = NoL * torch.linalg.vector_norm(torch.stack([at * ToV, ab * BoV, NoV], -1), dim=-1)
    ggx_l = NoV * torch.linalg.vector_norm(torch.stack([at * ToL, ab * BoL, NoL], -1), dim=-1)
    return 0.5 / (ggx_v + ggx_l).clamp_min(BRDF_MIN_DENOM)


def sample_ggx_vndf_anisotropic(u, v, at, ab) -> torch.Tensor:
    """GLSL ``vec3 sample_ggx_vndf_anisotropic(vec2 u, vec3 v, float at, float ab)`` (Heitz
    2018 with Dupuy & Benyoub 2023's caps): u ``[..., 2]``, v ``[..., 3]`` -> ``[..., 3]``."""
    at = saturate(at).clamp_min(ANISOTROPY_MIN_ALPHA)
    ab = saturate(ab).clamp_min(ANISOTROPY_MIN_ALPHA)
    vh = _normalize(torch.stack([at * v[..., 0], ab * v[..., 1],
                                 v[..., 2].clamp_min(0.0) + 1e-7], dim=-1))
    phi = (2.0 * math.pi) * u[..., 0]
    z = (1.0 - u[..., 1]) * (1.0 + vh[..., 2]) - vh[..., 2]
    sin_theta = torch.sqrt((1.0 - z * z).clamp(0.0, 1.0))
    hh = torch.stack([sin_theta * torch.cos(phi), sin_theta * torch.sin(phi), z], dim=-1) + vh
    h = torch.stack([at * hh[..., 0], ab * hh[..., 1], hh[..., 2].clamp_min(0.0)], dim=-1)
    len2 = (h * h).sum(-1, keepdim=True)
    up = torch.zeros_like(h)
    up[..., 2] = 1.0
    return torch.where(len2 > 1e-30, h * torch.rsqrt(len2.clamp_min(1e-30)), up)


def pdf_ggx_vndf_anisotropic(v, h, at, ab) -> torch.Tensor:
    """GLSL ``float pdf_ggx_vndf_anisotropic(vec3 v, vec3 h, float at, float ab)``:
    G1(v) D(h) / (4 n.v)."""
    NoV = saturate(v[..., 2])
    lam = torch.linalg.vector_norm(torch.stack([at * v[..., 0], ab * v[..., 1], NoV], -1), dim=-1)
    p = d_ggx_anisotropic(h[..., 2], h[..., 0], h[..., 1], at, ab) \
        / (2.0 * (NoV + lam).clamp_min(BRDF_MIN_DENOM))
    return torch.where(h[..., 2] > 0.0, p, torch.zeros_like(p))


def anisotropy_bent_normal(n, b, v, strength, roughness) -> torch.Tensor:
    """GLSL ``vec3 anisotropy_bent_normal(vec3 n, vec3 b, vec3 v, float strength, float
    roughness)`` (the extension's IBL bent normal)."""
    bent = torch.linalg.cross(torch.linalg.cross(b, v, dim=-1), b, dim=-1)
    len2 = (bent * bent).sum(-1, keepdim=True)
    bent = torch.where(len2 > 1e-20, bent * torch.rsqrt(len2.clamp_min(1e-30)), n)
    k = sq(sq(1.0 - saturate(strength) * (1.0 - saturate(roughness))))[..., None]
    return _normalize(bent * (1.0 - k) + n * k)


def anisotropy_encode(t, n, strength) -> torch.Tensor:
    """GLSL ``vec2 anisotropy_encode(vec3 t, vec3 n, float strength)``: s (cos, sin) of t in
    tangent_to_world's frame of n."""
    ex = torch.zeros_like(n)
    ex[..., 0] = 1.0
    ey = torch.zeros_like(n)
    ey[..., 1] = 1.0
    d = torch.stack([(t * tangent_to_world(ex, n)).sum(-1), (t * tangent_to_world(ey, n)).sum(-1)],
                    dim=-1)
    len2 = (d * d).sum(-1, keepdim=True)
    out = d * (saturate(strength)[..., None] * torch.rsqrt(len2.clamp_min(1e-30)))
    return torch.where(len2 > 1e-20, out, torch.zeros_like(out))


def anisotropy_decode(k, n) -> torch.Tensor:
    """GLSL ``vec4 anisotropy_decode(vec2 k, vec3 n)``: (direction, strength)."""
    s = torch.linalg.vector_norm(k, dim=-1)
    x = torch.zeros_like(k)
    x[..., 0] = 1.0
    d = torch.where(s[..., None] > 1e-20, k / s.clamp_min(1e-30)[..., None], x)
    d3 = torch.cat([d, torch.zeros_like(d[..., :1])], dim=-1)
    return torch.cat([tangent_to_world(d3, n), s[..., None]], dim=-1)
