"""Twins of ``shaders/lib/transmission.glsl``: KHR_materials_transmission's BTDFs (thin-walled:
the GGX lobe mirrored through the surface; volume: Walter et al. 2007's rough dielectric
without its Fresnel factor and radiance scale) and KHR_materials_volume's Beer-Lambert
attenuation, KHR_materials_dispersion's per-channel IORs. Scalars ``[...]``, ``vec3``
``[..., 3]``."""
from __future__ import annotations

import torch

from .brdf import d_ggx, v_smith_ggx_correlated
from .common import PI, half_vector, saturate


def _dot(a: torch.Tensor, b: torch.Tensor) -> torch.Tensor:
    return (a * b).sum(-1)


def mirror_through(n: torch.Tensor, l: torch.Tensor) -> torch.Tensor:
    """GLSL ``vec3 mirror_through(vec3 n, vec3 l)``: l - 2 (n.l) n."""
    return l - 2.0 * _dot(n, l)[..., None] * n


def thin_transmission_cos(a, n, v, l) -> torch.Tensor:
    """GLSL ``float thin_transmission_cos(float a, vec3 n, vec3 v, vec3 l)``: D V |n.l| with
    the half vector of v and l mirrored; 0 where l is not below."""
    NoL = -_dot(n, l)
    h = half_vector(v, mirror_through(n, l))
    NoV = saturate(_dot(n, v))
    out = d_ggx(saturate(_dot(n, h)), a) * v_smith_ggx_correlated(NoV, NoL, a) * NoL
    return torch.where(NoL > 0.0, out, torch.zeros_like(out))


def refraction_half_vector(n, v, l, eta) -> torch.Tensor:
    """GLSL ``vec3 refraction_half_vector(vec3 n, vec3 v, vec3 l, float eta)``:
    normalize(v + eta l) on n's side, 0 where it vanishes."""
    h = v + eta[..., None] * l
    len2 = _dot(h, h)[..., None]
    h = h * torch.rsqrt(len2.clamp_min(1e-30))
    h = torch.where((_dot(n, h) < 0.0)[..., None], -h, h)
    return torch.where(len2 > 1e-12, h, torch.zeros_like(h))


def _refraction_terms(a, eta, n, v, l):
    NoV = _dot(n, v)
    NoL = -_dot(n, l)
    h = refraction_half_vector(n, v, l, eta)
    VoH = _dot(v, h)
    LoH = _dot(l, h)
    ok = (NoV > 0.0) & (NoL > 0.0) & (VoH > 0.0) & (LoH < 0.0)
    denom = VoH + eta * LoH
    jacobian = eta * eta * (-LoH) / (denom * denom).clamp_min(1e-20)
    return NoV, NoL, h, VoH, jacobian, ok


def rough_refraction_cos(a, eta, n, v, l) -> torch.Tensor:
    """GLSL ``float rough_refraction_cos(float a, float eta, vec3 n, vec3 v, vec3 l)``: Walter's
    BTDF (no Fresnel, no radiance scale) times |n.l|."""
    NoV, NoL, h, VoH, jacobian, ok = _refraction_terms(a, eta, n, v, l)
    out = 4.0 * v_smith_ggx_correlated(NoV, NoL, a) * NoL * d_ggx(_dot(n, h), a) * VoH \
        * jacobian
    return torch.where(ok, out, torch.zeros_like(out))


def rough_refraction_pdf(a, eta, n, v, l) -> torch.Tensor:
    """GLSL ``float rough_refraction_pdf(float a, float eta, vec3 n, vec3 v, vec3 l)``: the
    visible-normal refraction's density of l."""
    NoV, _, h, VoH, jacobian, ok = _refraction_terms(a, eta, n, v, l)
    a2 = saturate(a) ** 2
    out = 2.0 * d_ggx(_dot(n, h), a) * VoH / (NoV + torch.sqrt(a2 + (1.0 - a2) * NoV * NoV)) \
        * jacobian
    return torch.where(ok, out, torch.zeros_like(out))


def dispersion_iors(ior, dispersion) -> torch.Tensor:
    """GLSL ``vec3 dispersion_iors(float ior, float dispersion)``: ior -/+ (ior - 1) 0.025
    dispersion for red / blue, ior for green; 0 where ior is not > 0 (a thin wall)."""
    half = (ior - 1.0) * 0.025 * dispersion
    out = torch.stack([ior - half, ior, ior + half], -1)
    return torch.where((ior > 0.0)[..., None], out, torch.zeros_like(out))


def dispersive_refraction_cos(a, etas, n, v, l) -> torch.Tensor:
    """GLSL ``vec3 dispersive_refraction_cos(float a, vec3 etas, vec3 n, vec3 v, vec3 l)``:
    :func:`rough_refraction_cos` with each channel's eta, ``[..., 3]``."""
    return torch.stack([rough_refraction_cos(a, etas[..., k], n, v, l) for k in range(3)], -1)


def dispersive_refraction_pdf(a, etas, w, n, v, l) -> torch.Tensor:
    """GLSL ``float dispersive_refraction_pdf(float a, vec3 etas, vec3 w, vec3 n, vec3 v, vec3
    l)``: :func:`rough_refraction_pdf` per channel's eta, weighted by w."""
    return sum(w[..., k] * rough_refraction_pdf(a, etas[..., k], n, v, l) for k in range(3))


def draw_channel(w, u) -> torch.Tensor:
    """GLSL ``vec2 draw_channel(vec3 w, float u)``: (the channel u falls in, by the shares w;
    u rescaled within it), ``[..., 2]``; green where u is past red's and green's shares and blue's
    is 0."""
    r, g, b = w[..., 0], w[..., 1], w[..., 2]
    u1 = u - r
    red = torch.stack([torch.zeros_like(u), u / r], -1)
    green = torch.stack([torch.ones_like(u), saturate(u1 / g.clamp_min(1e-30))], -1)
    blue = torch.stack([torch.full_like(u, 2.0), saturate((u1 - g) / b)], -1)
    out = torch.where(((u1 < g) | ~(b > 0.0))[..., None], green, blue)
    return torch.where((u < r)[..., None], red, out)


def volume_attenuation(sigma: torch.Tensor, distance: torch.Tensor) -> torch.Tensor:
    """GLSL ``vec3 volume_attenuation(vec3 sigma, float distance)``: exp(-sigma d)."""
    return torch.exp(-sigma * distance.clamp_min(0.0)[..., None])


def volume_exit_offset(n, v, thickness, ior) -> torch.Tensor:
    """GLSL ``vec3 volume_exit_offset(vec3 n, vec3 v, float thickness, float ior)``: GLSL
    ``refract(-v, n, 1 / ior)`` normalised times ``thickness``; 0 for a thin wall (ior or
    thickness not > 0) and under total internal reflection."""
    ok = (ior > 0.0) & (thickness > 0.0)
    eta = 1.0 / torch.where(ok, ior, torch.ones_like(ior))
    i = -v
    ni = _dot(n, i)
    k = 1.0 - eta * eta * (1.0 - ni * ni)
    t = eta[..., None] * i - (eta * ni + torch.sqrt(k.clamp_min(0.0)))[..., None] * n
    t = torch.where((k < 0.0)[..., None], torch.zeros_like(t), t)
    len2 = _dot(t, t)
    out = t * (torch.rsqrt(len2.clamp_min(1e-30)) * thickness)[..., None]
    keep = (ok & (len2 > 1e-12))[..., None]
    return torch.where(keep, out, torch.zeros_like(out))


def transmission_lod(r, ior, log2_width) -> torch.Tensor:
    """GLSL ``float transmission_lod(float r, float ior, float log2_width)``: log2_width times
    r, a volume's r scaled by clamp(2 ior - 2, 0, 1)."""
    rough = torch.where(ior > 0.0, r * saturate(2.0 * ior - 2.0), r)
    return log2_width * saturate(rough)


def transmission_irradiance(irradiance, transmission, refracted) -> torch.Tensor:
    """GLSL ``vec3 transmission_irradiance(vec3 irradiance, float transmission, vec3
    refracted)``: mix(E, pi L_refracted, saturate(T))."""
    t = saturate(transmission)[..., None]
    return irradiance * (1.0 - t) + PI * refracted * t
