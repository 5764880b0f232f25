"""Twins of ``shaders/lib/anisotropy.glsl``: glTF KHR_materials_anisotropy's anisotropic GGX,
its visible-normal sampling, the IBL bent normal and the G-buffer direction encoding. Scalars
``[...]``, ``vec2`` ``[..., 2]``, ``vec3`` ``[..., 3]``."""
from __future__ import annotations

import math

import torch

from .brdf import BRDF_MIN_DENOM, d_ggx, f_schlick, v_smith_ggx_correlated
from .common import INV_PI, half_vector, saturate, sq
from .sampling import tangent_to_world

ANISOTROPY_MIN_ALPHA = 1e-4
ANISOTROPY_ALBEDO_GRID = 6  # lib/anisotropy.glsl: its quadrature's points a side


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
    d = (vh[..., 0] * vh[..., 0] + vh[..., 1] * vh[..., 1]) / (1.0 + vh[..., 2])
    e = (1.0 - u[..., 1]) * (1.0 + vh[..., 2]) + d
    sin_theta = torch.sqrt((e * (2.0 - e)).clamp(0.0, 1.0))
    hh = torch.stack([sin_theta * torch.cos(phi) + vh[..., 0],
                      sin_theta * torch.sin(phi) + vh[..., 1], e - d], dim=-1)
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


def anisotropy_map_direction(rotation, texel) -> torch.Tensor:
    """GLSL ``vec3 anisotropy_map_direction(vec2 rotation, vec3 texel)``: the map's direction
    (RG x 2 - 1, unit; +x where zero) turned by the rotation (cos, sin), and its B."""
    d = texel[..., :2] * 2.0 - 1.0
    len2 = (d * d).sum(-1, keepdim=True)
    x = torch.zeros_like(d)
    x[..., 0] = 1.0
    d = torch.where(len2 > 1e-12, d * torch.rsqrt(len2.clamp_min(1e-30)), x)
    c, s = rotation[..., 0], rotation[..., 1]
    out = torch.stack([c * d[..., 0] - s * d[..., 1], s * d[..., 0] + c * d[..., 1]], dim=-1)
    return torch.cat([out, texel[..., 2:3]], dim=-1)


def anisotropy_decode(k, n) -> torch.Tensor:
    """GLSL ``vec4 anisotropy_decode(vec2 k, vec3 n)``: (direction, strength)."""
    s = torch.linalg.vector_norm(k, dim=-1)
    x = torch.zeros_like(k)
    x[..., 0] = 1.0
    d = torch.where(s[..., None] > 1e-20, k / s.clamp_min(1e-30)[..., None], x)
    d3 = torch.cat([d, torch.zeros_like(d[..., :1])], dim=-1)
    return torch.cat([tangent_to_world(d3, n), s[..., None]], dim=-1)


def anisotropy_specular_delta(f0, f90, n, t, v, l, alphas) -> torch.Tensor:
    """GLSL ``vec3 anisotropy_specular_delta(vec3 f0, float f90, vec3 n, vec3 t, vec3 v, vec3 l,
    vec2 alphas)``: anisotropic minus isotropic (alpha_b) specular f cos."""
    def dot(a, b):
        return (a * b).sum(-1)
    NoL = dot(n, l)
    b = torch.linalg.cross(n, t, dim=-1)
    h = half_vector(v, l)
    NoV = saturate(dot(n, v))
    NoH = saturate(dot(n, h))
    at, ab = alphas[..., 0], alphas[..., 1]
    aniso = d_ggx_anisotropic(NoH, dot(t, h), dot(b, h), at, ab) \
        * v_smith_ggx_correlated_anisotropic(NoV, NoL, dot(t, v), dot(b, v), dot(t, l),
                                             dot(b, l), at, ab)
    iso = d_ggx(NoH, ab) * v_smith_ggx_correlated(NoV, NoL, ab)
    out = ((aniso - iso) * NoL)[..., None] * f_schlick(f0, f90, saturate(dot(v, h)))
    return torch.where((NoL > 0.0)[..., None], out, torch.zeros_like(out))


def anisotropy_albedo_ratio(v, alphas) -> torch.Tensor:
    """GLSL ``float anisotropy_albedo_ratio(vec3 v, vec2 alphas)``: the anisotropic lobe's
    white albedo over the isotropic (alpha_b) one's, 4 x 4 stratified visible normals each."""
    NoV = v[..., 2].clamp_min(1e-4)
    at, ab = alphas[..., 0], alphas[..., 1]
    sums = []
    for ax, ay in ((at, ab), (ab, ab)):
        e = torch.zeros_like(NoV)
        for k in range(ANISOTROPY_ALBEDO_GRID ** 2):
            g = ANISOTROPY_ALBEDO_GRID
            u = torch.tensor([(k % g + 0.5) / g, (k // g + 0.5) / g], dtype=v.dtype)
            h = sample_ggx_vndf_anisotropic(u.expand(v.shape[:-1] + (2,)), v, ax, ay)
            l = 2.0 * (v * h).sum(-1, keepdim=True) * h - v
            g1 = 2.0 * NoV / (NoV + torch.linalg.vector_norm(
                torch.stack([ax * v[..., 0], ay * v[..., 1], NoV], -1), dim=-1))
            term = 4.0 * NoV * l[..., 2] * v_smith_ggx_correlated_anisotropic(
                NoV, l[..., 2], v[..., 0], v[..., 1], l[..., 0], l[..., 1], ax, ay) / g1
            e = e + torch.where(l[..., 2] > 0.0, term, torch.zeros_like(term))
        sums.append(e)
    return torch.where(sums[1] > 0.0, sums[0] / sums[1].clamp_min(1e-30), torch.ones_like(NoV))
