"""Twin of the Monte-Carlo lighting pass ``shaders/passes/shade_ggx_mc.frag``: per pixel, ``count``
samples of the GGX + Lambert BRDF against the environment, with the pass's strategies and MIS."""
from __future__ import annotations

import torch

from .brdf import clamp_perceptual_roughness, surface_f0_f90
from .common import INV_PI, saturate
from .deferred import env_dir, reflect
from .env_sampling import env_pdf, sample_env
from .equirect import equirect_uv, rotate_y
from .ibl import (DIRECTION_ABS_ERROR, equirect_uv_error, ibl_dfg, ibl_energy_compensation,
                  ibl_specular_dfg, sample_bilinear, sample_trilinear_envelope)
from .mc import (
    ggx_specular_brdf,
    mc_sample_2d,
    mis_weight,
    pdf_cosine_hemisphere,
    pdf_ggx_vndf,
    sample_cosine_hemisphere,
    sample_ggx_vndf,
    sample_uniform_hemisphere,
    specular_lobe_probability,
)
from .sampling import tangent_to_world
from .shading import diffuse_color


def shade_ggx_mc(n, v, g: dict, ao, env: dict, intensity: float, rotation_rad: float,
                 defines: dict, pixel: torch.Tensor, sample_start: int, sample_count: int,
                 seed: int, envelope: dict | None = None) -> torch.Tensor:
    """Twin of ``main()`` of ``passes/shade_ggx_mc.frag`` for covered pixels: the mean of samples
    ``sample_start ..`` of each pixel. n, v ``[P, 3]`` (shading normal, towards the viewer), ``g``
    the G-buffer channels ``[P, C]``, ao ``[P]``, pixel ``[P, 2]`` int64 (GL order). ``env`` as in
    :func:`learned.twins.shade.shade` plus ``marginal``, ``conditional``, ``pdf``.
    -> ``[P, 3]``.

    ``envelope`` (a dict, filled in): ``"bound"`` ``[P, 3]``, how far a conforming GPU may land
    from this mean through its radiance lookups: every sample's contribution is linear in its
    lookup, so the bound is the mean of |BRDF cos / pdf x weight| times
    :func:`~learned.twins.ibl.sample_trilinear_envelope` of the lookup (the device's filter bits,
    ``envelope["weight_bits"]``; the sampled direction known to 3 trig errors)."""
    sampling = int(defines.get("SAMPLING", 4))
    power = float(defines.get("MIS_POWER", 2))
    P = n.shape[0]
    ex = torch.tensor([1.0, 0.0, 0.0]).expand(P, 3)
    ey = torch.tensor([0.0, 1.0, 0.0]).expand(P, 3)
    t = tangent_to_world(ex, n)
    b = tangent_to_world(ey, n)
    NoV = saturate(_dot(n, v))
    r = clamp_perceptual_roughness(g["roughness"][..., 0])
    a = r * r
    dielectric = g["dielectric"] if "dielectric" in g else \
        torch.tensor([0.0, 0.0, 0.0, -1.0]).expand(P, 4)  # its background: no channel
    fresnel = surface_f0_f90(g["albedo"], g["metallic"][..., 0], g["specular"][..., 0], dielectric)
    f0, f90 = fresnel[..., :3], fresnel[..., 3]
    dfg = ibl_dfg(env["dfg"], NoV, r)
    if defines.get("MULTISCATTER", 1):
        spec_scale = ibl_energy_compensation(dfg, f0)
    else:
        spec_scale = torch.ones_like(f0)
    e_spec = ibl_specular_dfg(dfg, f0, f90) * spec_scale
    diffuse = diffuse_color(g["albedo"], g["metallic"][..., 0]) * (1.0 - e_spec).clamp_min(0.0)
    p_spec = specular_lobe_probability(diffuse, f0, f90, NoV)
    diffuse = diffuse * ao[..., None]
    level0 = env["radiance"][0]

    def radiance(l):
        return sample_bilinear(level0, equirect_uv(env_dir(l, rotation_rad)))[..., :3] * intensity

    bits = (envelope or {}).get("weight_bits", 8)
    bound = torch.zeros(P, 3)

    def radiance_bound(l):
        d = env_dir(l, rotation_rad)
        return sample_trilinear_envelope([level0], equirect_uv(d), torch.zeros(d.shape[:-1]),
                                         equirect_uv_error(d, 3.0 * DIRECTION_ABS_ERROR),
                                         weight_bits=bits)[..., :3] * intensity

    def brdf_cos(l):
        NoL = _dot(n, l)
        h = v + l
        h = h * torch.rsqrt((h * h).sum(-1, keepdim=True))
        NoH = saturate(_dot(n, h))
        VoH = saturate(_dot(v, h))
        spec = ggx_specular_brdf(f0, f90, NoV, NoL, NoH, VoH, a) * spec_scale
        out = (diffuse * INV_PI + spec) * NoL[..., None]
        return torch.where((NoL > 0.0)[..., None], out, torch.zeros_like(out))

    def brdf_pdf(l):
        NoL = _dot(n, l)
        h = v + l
        h = h * torch.rsqrt((h * h).sum(-1, keepdim=True))
        NoH = saturate(_dot(n, h))
        p = p_spec * pdf_ggx_vndf(NoV, NoH, a) + (1.0 - p_spec) * pdf_cosine_hemisphere(NoL)
        return torch.where(NoL > 0.0, p, torch.zeros_like(p))

    def sample_brdf(u):
        spec = u[..., 0] < p_spec
        us = torch.stack([u[..., 0] / torch.where(spec, p_spec, torch.ones_like(p_spec)),
                          u[..., 1]], dim=-1)
        v_t = torch.stack([_dot(v, t), _dot(v, b), NoV], dim=-1)
        h = tangent_to_world(sample_ggx_vndf(us, v_t, a), n)
        l_spec = reflect(-v, h)
        one_minus = 1.0 - p_spec
        ud = torch.stack([(u[..., 0] - p_spec) / torch.where(spec, torch.ones_like(p_spec),
                                                              one_minus), u[..., 1]], dim=-1)
        l_diff = tangent_to_world(sample_cosine_hemisphere(ud.clamp(0.0, 1.0)), n)
        return torch.where(spec[..., None], l_spec, l_diff)

    def env_sample(u):
        e = sample_env(env["marginal"], env["conditional"], env["pdf"], u)
        l = rotate_y(e[..., :3], torch.full(e.shape[:-1], rotation_rad, dtype=e.dtype))
        return l, e[..., 3]

    def weighted(l, pdf, w=None):
        nonlocal bound
        f = brdf_cos(l)
        c = radiance(l) * f
        scale = torch.where(pdf > 0.0, (w if w is not None else 1.0)
                            / torch.where(pdf > 0.0, pdf, torch.ones_like(pdf)),
                            torch.zeros_like(pdf))
        if envelope is not None:
            e = (f * scale[..., None]).abs() * radiance_bound(l)
            bound = bound + torch.where(torch.isfinite(e), e, torch.zeros_like(e))
        return c * scale[..., None]

    total = torch.zeros(P, 3)
    px, py = pixel[:, 0], pixel[:, 1]
    for k in range(sample_count):
        index = torch.full((P,), sample_start + k, dtype=torch.int64)
        u0 = mc_sample_2d(px, py, index, seed, 0)
        if sampling in (0, 1):
            if sampling == 0:
                l = tangent_to_world(sample_uniform_hemisphere(u0), n)
                pdf = torch.full((P,), 0.5 * INV_PI)
            else:
                l = tangent_to_world(sample_cosine_hemisphere(u0), n)
                pdf = pdf_cosine_hemisphere(_dot(n, l))
            c = weighted(l, pdf)
        elif sampling == 2:
            l, pdf = env_sample(u0)
            c = weighted(l, pdf)
        elif sampling == 3:
            l = sample_brdf(u0)
            c = weighted(l, brdf_pdf(l))
        else:
            lb = sample_brdf(u0)
            pb = brdf_pdf(lb)
            c = weighted(lb, pb, mis_weight(pb, env_pdf(env["pdf"], env_dir(lb, rotation_rad)),
                                            power))
            le, pe = env_sample(mc_sample_2d(px, py, index, seed, 1))
            c = c + weighted(le, pe, mis_weight(pe, brdf_pdf(le), power))
        c = torch.where(torch.isfinite(c).all(-1, keepdim=True), c, torch.zeros_like(c))
        total = total + c
    if envelope is not None:
        envelope["bound"] = bound / float(max(sample_count, 1))
    return total / float(max(sample_count, 1))


def _dot(a: torch.Tensor, b: torch.Tensor) -> torch.Tensor:
    return (a * b).sum(-1)
