"""Twins of ``shaders/lib/shading.glsl``: the per-pixel shading models on pre-looked-up lighting."""
from __future__ import annotations

import torch

from .brdf import (
    blinn_phong_shininess,
    d_ggx,
    f_schlick,
    v_smith_ggx_correlated,
)
from .common import INV_PI, half_vector, saturate
from .ibl import ibl_energy_compensation, ibl_specular_dfg


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


def ggx_split_sum(diffuse: torch.Tensor, f0: torch.Tensor, f90: torch.Tensor, ao: torch.Tensor,
                  irradiance: torch.Tensor, prefiltered: torch.Tensor, dfg: torch.Tensor,
                  multiscatter: torch.Tensor) -> torch.Tensor:
    """GLSL ``vec3 ggx_split_sum(...)``: split-sum GGX IBL (Karis 2013, Filament).

    diffuse, f0, irradiance, prefiltered: [..., 3]; f90, ao, multiscatter: [...]; dfg: [..., 2].
    """
    e_spec = ibl_specular_dfg(dfg, f0, f90)
    e_spec = torch.where((multiscatter > 0.5)[..., None], e_spec * ibl_energy_compensation(dfg, f0),
                         e_spec)
    fd = diffuse * irradiance * INV_PI * ao[..., None] * (1.0 - e_spec).clamp_min(0.0)
    return fd + e_spec * prefiltered


def specular_occlusion(nov: torch.Tensor, ao: torch.Tensor, a: torch.Tensor) -> torch.Tensor:
    """GLSL ``float specular_occlusion(NoV, ao, a)``: the share of the prefiltered environment
    light a lobe of alpha ``a`` still sees at occlusion ``ao`` (Lagarde & de Rousiers 2014;
    Filament's ``computeSpecularAO``)."""
    return ((nov + ao) ** torch.exp2(-16.0 * a - 1.0) - 1.0 + ao).clamp(0.0, 1.0)


def blinn_phong(diffuse: torch.Tensor, f0: torch.Tensor, ao: torch.Tensor,
                irradiance: torch.Tensor, prefiltered: torch.Tensor) -> torch.Tensor:
    """GLSL ``vec3 blinn_phong(...)``: Lambert (keeping 1 - f0) + normalised Fresnel-free
    Blinn-Phong lobe."""
    return diffuse * irradiance * INV_PI * ao[..., None] * (1.0 - f0) + f0 * prefiltered


def _dot(a: torch.Tensor, b: torch.Tensor) -> torch.Tensor:
    return (a * b).sum(-1)


def ggx_environment_sun(diffuse: torch.Tensor, f0: torch.Tensor, f90: torch.Tensor,
                        a: torch.Tensor,
                        dfg: torch.Tensor, multiscatter: torch.Tensor, n: torch.Tensor,
                        v: torch.Tensor, l: torch.Tensor, irradiance: torch.Tensor,
                        specular_weight: torch.Tensor) -> torch.Tensor:
    """GLSL ``vec3 ggx_environment_sun(...)``: (f_d + w f_s)(v, l) E (n.l) for the GGX + Lambert
    BRDF with ggx_split_sum's energy split, the specular term weighted by ``specular_weight`` w
    (the environment's sun, viewer/environment/sun.py). diffuse, f0, n, v, l, irradiance [..., 3]; a,
    multiscatter, specular_weight [...]; dfg [..., 2] -> [..., 3]; 0 where n.l <= 0."""
    NoL = _dot(n, l)
    h = half_vector(v, l)
    NoV = saturate(_dot(n, v))
    NoH = saturate(_dot(n, h))
    VoH = saturate(_dot(v, h))
    spec_scale = torch.where((multiscatter > 0.5)[..., None], ibl_energy_compensation(dfg, f0),
                             torch.ones_like(f0))
    e_spec = ibl_specular_dfg(dfg, f0, f90) * spec_scale
    fd = diffuse * INV_PI * (1.0 - e_spec).clamp_min(0.0)
    fs = (d_ggx(NoH, a) * v_smith_ggx_correlated(NoV, NoL, a))[..., None] \
        * f_schlick(f0, f90, VoH) * spec_scale
    out = (fd + fs * specular_weight[..., None]) * irradiance * NoL[..., None]
    return torch.where((NoL > 0.0)[..., None], out, torch.zeros_like(out))


def sun_specular_weight(a: torch.Tensor, sun_radius: torch.Tensor) -> torch.Tensor:
    """GLSL ``float sun_specular_weight(float a, float sun_radius)``: the share of the sun's
    specular light shaded analytically, saturate(2 a / t - 1) (t floored at 1e-6)."""
    return saturate(2.0 * a / sun_radius.clamp_min(1e-6) - 1.0)


def atan_minus_z(z: torch.Tensor) -> torch.Tensor:
    """GLSL ``float atan_minus_z(float z)``: atan(z) - z, by its Taylor series (Horner, to z^17)
    below 0.35."""
    z2 = z * z
    p = torch.full_like(z, -1.0 / 17.0)
    for c in (1.0 / 15.0, -1.0 / 13.0, 1.0 / 11.0, -1.0 / 9.0, 1.0 / 7.0, -1.0 / 5.0, 1.0 / 3.0):
        p = c + z2 * p
    return torch.where(z < 0.35, -z * z2 * p, torch.atan(z) - z)


def disc_light(n: torch.Tensor, l: torch.Tensor, radius: torch.Tensor) -> torch.Tensor:
    """GLSL ``vec4 disc_light(vec3 n, vec3 l, float radius)``: (l_b, s) for a disc light of
    angular radius ``radius`` (Frostbite's illuminanceSphereOrDisk over its unclipped value, the
    horizon-cut share; l lifted to n.l_b >= 1e-3 where the horizon cuts it). n, l [..., 3] unit,
    radius [...] -> [..., 4]."""
    NoL = _dot(n, l)
    s2 = torch.sin(radius.clamp_max(1.5)).square().clamp_min(1e-12)
    sin_t = (1.0 - NoL * NoL).clamp_min(0.0).sqrt()
    x = (1.0 / s2 - 1.0).sqrt()
    y = (-x * NoL / sin_t).clamp(-1.0, 1.0)
    z = sin_t * (1.0 - y * y).clamp_min(0.0).sqrt() / x
    cut = ((NoL * torch.acos(y) + z + atan_minus_z(z) / s2) * INV_PI).clamp_min(0.0)
    c = torch.where(NoL * NoL < s2, cut, NoL.clamp_min(0.0))
    lb = torch.where((NoL >= 1e-3)[..., None], l,
                     torch.nn.functional.normalize(l + (1e-3 - NoL)[..., None] * n, dim=-1))
    s = torch.where(c > 0.0, c / _dot(n, lb), torch.zeros_like(c))
    return torch.cat([lb, s[..., None]], dim=-1)


def ggx_directional_light(diffuse: torch.Tensor, f0: torch.Tensor, f90: torch.Tensor,
                          a: torch.Tensor,
                          dfg: torch.Tensor, multiscatter: torch.Tensor, n: torch.Tensor,
                          v: torch.Tensor, l: torch.Tensor, irradiance: torch.Tensor
                          ) -> torch.Tensor:
    """GLSL ``vec3 ggx_directional_light(...)``: f(v, l) E (n.l) for the GGX + Lambert BRDF with
    ggx_split_sum's energy split (:func:`ggx_environment_sun` with w = 1). diffuse, f0, n, v, l,
    irradiance [..., 3]; a, multiscatter [...]; dfg [..., 2] -> [..., 3]; 0 where n.l <= 0."""
    return ggx_environment_sun(diffuse, f0, f90, a, dfg, multiscatter, n, v, l, irradiance,
                               torch.ones_like(a))


def blinn_phong_directional_light(diffuse: torch.Tensor, f0: torch.Tensor, a: torch.Tensor,
                                  n: torch.Tensor, v: torch.Tensor, l: torch.Tensor,
                                  irradiance: torch.Tensor) -> torch.Tensor:
    """GLSL ``vec3 blinn_phong_directional_light(...)``: Lambert keeping (1 - f0) + the normalised
    Blinn-Phong BRDF f0 (s + 8)/(8 pi) (n.h)^s (Real-Time Rendering 3rd ed. eq. 7.49), times E n.l.
    diffuse, f0, n, v, l, irradiance [..., 3]; a [...] -> [..., 3]; 0 where n.l <= 0."""
    NoL = _dot(n, l)
    NoH = saturate(_dot(n, half_vector(v, l)))
    s = blinn_phong_shininess(a)
    lobe = (s + 8.0) * (0.125 * INV_PI) * torch.pow(NoH.clamp_min(1e-30), s)
    out = (diffuse * INV_PI * (1.0 - f0) + f0 * lobe[..., None]) * irradiance * NoL[..., None]
    return torch.where((NoL > 0.0)[..., None], out, torch.zeros_like(out))




def env_lights_ggx(lights, diffuse: torch.Tensor, f0: torch.Tensor, f90: torch.Tensor,
                   a: torch.Tensor,
                   dfg: torch.Tensor, multiscatter: torch.Tensor, n: torch.Tensor,
                   v: torch.Tensor, w: torch.Tensor, intensity: float,
                   rotation_rad: float, p: torch.Tensor | None = None) -> torch.Tensor:
    """GLSL ``vec3 env_lights_ggx(...)`` (passes/env_lights.glsl): the sum of
    :func:`ggx_environment_sun` over ``lights`` (the environment's compact lights besides its sun,
    :class:`viewer.environment.sun.Sun` each; the uniforms ``u_env_light_*``), each turned by the
    environment's rotation, scaled by its intensity and cut by the horizon (:func:`disc_light`).
    ``p`` (the surface point) is where the GLSL reads each light's shadow map with SUN_SHADOW;
    as ``light_visibility``'s twin, this one is unshadowed (the model parity checks render
    without shadow maps; shadow_visibility and its parts are twinned in learned.twins.shadow). Shapes as ggx_environment_sun."""
    from .equirect import rotate_y

    c = torch.zeros_like(n)
    angle = torch.full(a.shape, float(rotation_rad), dtype=torch.float32)
    for light in lights:
        l_env = torch.tensor(light.direction, dtype=torch.float32).expand_as(n)
        disc = disc_light(n, rotate_y(l_env, angle),
                          torch.full(a.shape, float(light.angular_radius), dtype=torch.float32))
        e = torch.tensor(light.irradiance, dtype=torch.float32) \
            * (torch.tensor(float(intensity), dtype=torch.float32) * disc[..., 3:])
        c = c + ggx_environment_sun(diffuse, f0, f90, a, dfg, multiscatter, n, v, disc[..., :3],
                                    e, w)
    return c
