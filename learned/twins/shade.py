"""Twin of the lighting passes ``shaders/passes/shade_<model>.frag`` on a G-buffer: :func:`shade`
evaluates a whole classical shading model (the neural ones: :mod:`learned.twins.neural`) with the
same environment resources the GL pass reads, so :mod:`learned.parity.checks.models` compares
them pixel by pixel. Images are in GL row order (row 0 at the bottom), as the passes see them.
"""
from __future__ import annotations

from dataclasses import dataclass

import torch

from .brdf import clamp_perceptual_roughness, surface_f0_f90
from .deferred import emitted_radiance, env_dir, reflect, view_ray_ws
from .equirect import equirect_uv, rotate_y
from .ibl import (
    ATAN_ABS_ERROR,
    DIRECTION_ABS_ERROR,
    equirect_uv_error,
    ibl_dfg,
    ibl_dominant_factor,
    ibl_specular_radiance,
    ibl_specular_radiance_sun,
    irradiance_lookup,
    prefilter_lod,
    sample_bilinear,
    sample_trilinear_envelope,
    specular_dominant_direction,
)
from .lights import light_surface_position, lights_blinn_phong, lights_ggx
from .shade_ggx_mc import shade_ggx_mc
from .shading import (
    blinn_phong,
    diffuse_color,
    disc_light,
    env_lights_ggx,
    ggx_environment_sun,
    ggx_split_sum,
    shading_normal,
    specular_occlusion,
    sun_specular_weight,
)


def shade(model: str, gbuffer: dict[str, torch.Tensor], camera, env: dict, intensity: float,
          rotation_rad: float, defines: dict[str, int], ssao: torch.Tensor | None = None,
          mc: dict | None = None, light=None, envelope: dict | None = None) -> torch.Tensor:
    """The lighting pass ``model`` on a G-buffer (channel -> [H, W, C], GL row order).

    ``env``: ``radiance`` (list of mips [h, w, 4]), ``prefiltered`` (list), ``dfg`` ([n, n, 2]),
    ``irradiance`` ([h, w, 4], the irradiance map), ``levels``; for ``ggx_mc`` also the sampling distribution ``marginal``,
    ``conditional``, ``pdf`` (:func:`learned.twins.env_sampling.env_distribution` layout).
    ``defines`` as in :func:`viewer.passes.shade.shade_defines`; ``ssao`` ([H, W], the occlusion
    texture) when ``USE_SSAO``; ``mc``: ``start``, ``count``, ``seed`` of the Monte-Carlo batch;
    ``light``: the scene's lights (``Scene.light``: a tuple of :class:`~viewer.lighting.lights.Light` or
    None), shaded when ``LIGHT_COUNT`` > 0 (as the GLSL, the define decides, not the argument).
    Returns [H, W, 4]: composited radiance and coverage.

    ``envelope`` (a dict, filled in): ``"bound"`` [H, W, 3], how far a conforming GPU may land
    from this result through its texture lookups - each lookup's
    :func:`~learned.twins.ibl.sample_trilinear_envelope` (the device's filter bits,
    ``envelope["weight_bits"]``, default 8) times |d radiance / d lookup| by autograd - for the
    environment background, the prefiltered specular and the DFG LUT (not the Monte-Carlo
    samples of ``ggx_mc``).
    """
    lookups: dict[str, tuple[torch.Tensor, torch.Tensor]] = {}
    bits = (envelope or {}).get("weight_bits", 8)

    def traced(name, value, bound_fn):
        """Mark a lookup for the envelope: its value (now a leaf needing grad) and its bound."""
        if envelope is None:
            return value
        value = value.detach().requires_grad_(True)
        with torch.no_grad():
            lookups[name] = (value, bound_fn())
        return value

    h, w = gbuffer["alpha"].shape[:2]
    ys, xs = torch.meshgrid(torch.arange(h, dtype=torch.float32) + 0.5,
                            torch.arange(w, dtype=torch.float32) + 0.5, indexing="ij")
    frag = torch.stack([xs, ys], dim=-1)
    basis = torch.tensor(camera.basis(), dtype=torch.float32)  # rows right, up, back
    d = view_ray_ws(frag, basis.T, torch.tensor(camera.tan_half_fov(), dtype=torch.float32),
                    torch.tensor([float(w), float(h)]))
    if defines.get("BACKGROUND_ENVIRONMENT", 1):
        d_env = env_dir(d, rotation_rad)
        background = sample_bilinear(env["radiance"][0], equirect_uv(d_env))[..., :3]
        background = traced("background", background, lambda: sample_trilinear_envelope(
            env["radiance"][:1], equirect_uv(d_env), torch.zeros(d.shape[:-1]),
            equirect_uv_error(d_env), weight_bits=bits)[..., :3]) * intensity
    else:
        background = torch.zeros_like(d)
    g = gbuffer
    alpha = g["alpha"][..., 0]
    if model not in PASS_TWINS:
        raise ValueError(f"no torch twin for model {model!r} (known: {', '.join(PASS_TWINS)})")
    surf = None
    if model != "unlit":
        v = -d
        n = shading_normal(g["normal"], v)
        r = clamp_perceptual_roughness(g["roughness"][..., 0])
        n_env = env_dir(n, rotation_rad)
        irradiance = irradiance_lookup(env["irradiance"], n_env)
        irradiance = traced("irradiance", irradiance, lambda: _irradiance_bound(
            env["irradiance"], n_env, bits)) * intensity
        reflected = reflect(-v, n)
        direction_error = torch.full_like(r, 2.0 * DIRECTION_ABS_ERROR)
        if model == "ggx_split_sum":  # shade_ggx_split_sum.frag looks up the dominant direction
            nov_d = (n * v).sum(-1).clamp(0.0, 1.0)
            t = ibl_dominant_factor(env["dominant"], nov_d, r)
            reflected = specular_dominant_direction(n, reflected, t)
            # a GPU's filtered t may differ by its lookup envelope: the direction moves by up to
            # |dt| |r - n| / |mix(n, r, t)| <= 2 |dt| (|mix| >= 1/sqrt(2) for n.r >= 0)
            size = torch.tensor([float(env["dominant"].shape[1]),
                                 float(env["dominant"].shape[0])])
            uv_t = (torch.stack([nov_d, r.clamp(0.0, 1.0)], -1) * (size - 1.0) + 0.5) / size
            dt = sample_trilinear_envelope([env["dominant"]], uv_t, torch.zeros_like(r),
                                           torch.full_like(uv_t, 1e-6), repeat_u=False,
                                           weight_bits=bits)[..., 0]
            direction_error = direction_error + 2.0 * dt + 1e-6
        r_env = env_dir(reflected, rotation_rad)

        def lookup_bound(chain):
            lod = prefilter_lod(r, torch.full_like(r, float(env["levels"])))
            return sample_trilinear_envelope(chain, equirect_uv(r_env), lod,
                                             _uv_error(r_env, direction_error),
                                             weight_bits=bits)[..., :3]

        if model == "ggx_split_sum" and defines.get("SUN_LIGHT", 0):
            # the sun's specular light: analytic for the share w (_shade_ggx_split_sum), looked up
            # in the chain of the whole environment for the rest; the bound mixes as the lookups
            w = sun_specular_weight(r * r, torch.full_like(r, _widest(env)))
            w3 = w[..., None]
            prefiltered = ibl_specular_radiance_sun(env["prefiltered"], env["prefiltered_full"],
                                                    r_env, r, env["levels"], w)
            prefiltered = traced("prefiltered", prefiltered, lambda: torch.where(
                w3 < 1.0, lookup_bound(env["prefiltered_full"]) * (1.0 - w3)
                + lookup_bound(env["prefiltered"]) * w3, lookup_bound(env["prefiltered"])))
        else:
            prefiltered = ibl_specular_radiance(env["prefiltered"], r_env, r, env["levels"])
            prefiltered = traced("prefiltered", prefiltered,
                                 lambda: lookup_bound(env["prefiltered"]))
        ao = g["ao"][..., 0] if defines.get("USE_AO", 1) else torch.ones_like(r)
        if defines.get("USE_SSAO", 0):
            ao = ao * ssao  # deferred.glsl ambient_occlusion()
        nov = (n * v).sum(-1).clamp(0.0, 1.0)
        if defines.get("SPECULAR_OCCLUSION", 0):  # shade_ggx_split_sum.frag
            prefiltered = prefiltered * specular_occlusion(nov, ao, r * r)[..., None]
        lut = env["dfg"]
        size = torch.tensor([float(lut.shape[1]), float(lut.shape[0])])
        uv_lut = (torch.stack([nov, r.clamp(0.0, 1.0)], -1) * (size - 1.0) + 0.5) / size
        dfg = traced("dfg", ibl_dfg(lut, nov, r), lambda: sample_trilinear_envelope(
            [lut], uv_lut, torch.zeros_like(r), torch.full_like(uv_lut, 1e-6), repeat_u=False,
            weight_bits=bits))
        if defines.get("LIGHT_POSITIONAL", 0):  # passes/lights.glsl light_surface_position
            size_px = torch.tensor([float(frag.shape[1]), float(frag.shape[0])])
            p_ws = light_surface_position(frag, g["depth"][..., 0], camera.position, basis.T,
                                          torch.tensor(camera.tan_half_fov(), dtype=torch.float32),
                                          size_px)
        else:
            p_ws = torch.zeros_like(n)
        fresnel = surface_f0_f90(g["albedo"], g["metallic"][..., 0], g["specular"][..., 0],
                                 dielectric_channel(g))
        surf = _Surface(n=n, v=v, r=r, ao=ao, irradiance=irradiance, p=p_ws,
                        prefiltered=prefiltered * intensity, dfg=dfg,
                        diffuse=diffuse_color(g["albedo"], g["metallic"][..., 0]),
                        f0=fresnel[..., :3], f90=fresnel[..., 3],
                        ms=torch.full_like(r, float(defines.get("MULTISCATTER", 1))))
    mc_envelope = None if envelope is None else {"weight_bits": bits}
    c = PASS_TWINS[model](g, surf, defines, env=env, intensity=intensity,
                          rotation_rad=rotation_rad, mc=mc or {}, light=light,
                          envelope=mc_envelope)
    c = c + emitted_radiance(g)  # write_radiance(c + emitted_radiance(g), ...) in every pass
    if mc_envelope is not None and "bound" in mc_envelope:  # Monte-Carlo lookups, in radiance
        lookups["mc"] = (None, mc_envelope["bound"] * alpha[..., None])
    covered = alpha > 0.0
    a = alpha[..., None]
    out = torch.where(covered[..., None], background + (c - background) * a, background)
    if envelope is not None:
        bound = torch.zeros_like(out)
        direct = {k: b for k, (v, b) in lookups.items() if v is None}  # bounds already in radiance
        traced_lookups = {k: e for k, e in lookups.items() if e[0] is not None}
        for b in direct.values():
            bound = bound + b
        if traced_lookups and out.requires_grad:
            values = [v for v, _ in traced_lookups.values()]
            grads = torch.autograd.grad(out.sum(), values, allow_unused=True)
            for (value, lookup_bound), grad in zip(traced_lookups.values(), grads):
                if grad is not None:  # |d out / d lookup| summed over the lookup's components
                    bound = bound + (grad.abs() * lookup_bound).sum(-1, keepdim=True) \
                        if grad.shape[-1] != 3 else bound + grad.abs() * lookup_bound
        envelope["bound"] = bound.detach()
        out = out.detach()
    return torch.cat([out, alpha[..., None]], dim=-1)


def _widest(env: dict) -> float:
    """``u_sun_radius`` as :meth:`viewer.environment.ibl.IBL.bind` sets it: the widest extracted light's."""
    return max(float(li.angular_radius) for li in env.get("lights", (env["sun"],)))


def _irradiance_bound(irradiance: torch.Tensor, n_env: torch.Tensor, bits: int) -> torch.Tensor:
    """The lookup envelope of ``irradiance_lookup`` at ``n_env`` (rows from pole to pole; at the
    poles, where u is undefined, every texel of the row holds the pole's value: 0)."""
    uv = equirect_uv(n_env)
    h = float(irradiance.shape[0])
    uv = torch.stack([uv[..., 0], (uv[..., 1] * (h - 1.0) + 0.5) / h], -1)
    err = _uv_error(n_env, torch.full(n_env.shape[:-1], 2.0 * DIRECTION_ABS_ERROR)) + 1e-7
    return torch.nan_to_num(sample_trilinear_envelope([irradiance], uv, torch.zeros(
        n_env.shape[:-1]), err, weight_bits=bits)[..., :3], nan=0.0)


def _uv_error(d: torch.Tensor, direction_error: torch.Tensor) -> torch.Tensor:
    """:func:`~learned.twins.ibl.equirect_uv_error` with a per-pixel direction error ``[...]``."""
    rho = torch.sqrt(d[..., 0] * d[..., 0] + d[..., 2] * d[..., 2])
    e = direction_error
    du = (e / torch.maximum(rho, e) + ATAN_ABS_ERROR) / (2.0 * torch.pi)
    dv = (e + ATAN_ABS_ERROR) / torch.pi
    return torch.stack([du, dv], dim=-1)


@dataclass
class _Surface:
    """What every lit pass computes first (``deferred.glsl``): [H, W, ...] each."""

    n: torch.Tensor  # shading normal
    v: torch.Tensor  # towards the viewer
    r: torch.Tensor  # clamped perceptual roughness
    ao: torch.Tensor  # G-buffer AO x SSAO (as enabled)
    irradiance: torch.Tensor  # the irradiance map's E(n) x intensity
    prefiltered: torch.Tensor  # prefiltered radiance along the mirror direction x intensity
    dfg: torch.Tensor  # DFG LUT at (n.v, r)
    diffuse: torch.Tensor
    f0: torch.Tensor
    f90: torch.Tensor  # surface_f0_f90's a
    ms: torch.Tensor  # MULTISCATTER as 0/1
    p: torch.Tensor  # world position (LIGHT_POSITIONAL; else 0)


def dielectric_channel(g: dict) -> torch.Tensor:
    """The G-buffer's ``dielectric`` channel ``[H, W, 4]``, its background (0, 0, 0, -1) where
    the layout has none (viewer/gbuffer.py)."""
    if "dielectric" in g:
        return g["dielectric"]
    bg = torch.tensor([0.0, 0.0, 0.0, -1.0])
    return bg.expand(*g["alpha"].shape[:-1], 4)


def _lights(light, defines) -> tuple:
    """The lights a pass compiled in: the first LIGHT_COUNT of ``light`` (a tuple, one Light or
    None)."""
    lights = () if light is None else (light,) if hasattr(light, "type") else tuple(light)
    count = int(defines.get("LIGHT_COUNT", 0))
    if count != len(lights):
        raise ValueError(f"LIGHT_COUNT {count} but {len(lights)} lights given")
    return lights


def _shade_unlit(g, s, defines, **_) -> torch.Tensor:
    """``shade_unlit.frag``: the baked colour (splats, un-premultiplied) or the albedo."""
    if "color" not in g:
        return g["albedo"]
    alpha = g["alpha"][..., 0]
    return torch.where(alpha[..., None] > 0, g["color"] / alpha.clamp_min(1e-30)[..., None],
                       torch.zeros_like(g["color"]))


def _shade_blinn_phong(g, s: _Surface, defines, light=None, **_) -> torch.Tensor:
    """``shade_blinn_phong.frag``: the environment terms, plus the punctual lights."""
    c = blinn_phong(s.diffuse, s.f0, s.ao, s.irradiance, s.prefiltered)
    if defines.get("LIGHT_COUNT", 0):
        f0, a = s.f0, s.r * s.r
        if not defines.get("SPECULAR_LOBE", 1):  # the specialised variant passes f0 = 0, a = 1
            f0, a = torch.zeros_like(f0), torch.ones_like(a)
        c = c + lights_blinn_phong(_lights(light, defines), s.diffuse, f0, a, s.n, s.v, s.p)
    return c


def _ggx_light(s: _Surface, f0, f90, a, dfg, ms, light, defines) -> torch.Tensor:
    return lights_ggx(_lights(light, defines), s.diffuse, f0, f90, a, dfg, ms, s.n, s.v, s.p)


def _shade_ggx_split_sum(g, s: _Surface, defines, light=None, env=None, intensity=1.0,
                         rotation_rad=0.0, **_) -> torch.Tensor:
    """``shade_ggx_split_sum.frag``: split-sum GGX + the irradiance map's diffuse, plus the punctual lights and
    (``SUN_LIGHT``) the environment's sun, ``env["sun"]`` (a :class:`viewer.environment.sun.Sun`)."""
    c = ggx_split_sum(s.diffuse, s.f0, s.f90, s.ao, s.irradiance, s.prefiltered, s.dfg, s.ms)
    f0, f90, a, dfg, ms = s.f0, s.f90, s.r * s.r, s.dfg, s.ms
    specular = defines.get("SPECULAR_LOBE", 1)
    if not specular:
        f0, f90, a = torch.zeros_like(f0), torch.zeros_like(f90), torch.ones_like(a)
        dfg = torch.tensor([0.0, 1.0]).expand(*a.shape, 2)
        ms = torch.zeros_like(a)
    if defines.get("LIGHT_COUNT", 0):
        c = c + _ggx_light(s, f0, f90, a, dfg, ms, light, defines)
    if defines.get("SUN_LIGHT", 0):
        sun = env["sun"]
        l_env = torch.tensor(sun.direction, dtype=torch.float32).expand_as(s.n)
        l_ws = rotate_y(l_env, torch.full(s.r.shape, rotation_rad, dtype=torch.float32))
        e = (torch.tensor(sun.irradiance, dtype=torch.float32) * intensity).expand_as(s.n)
        others = tuple(env.get("lights", (sun,)))[1:int(defines.get("ENV_LIGHTS", 0)) + 1]
        w = sun_specular_weight(s.r * s.r, torch.full_like(s.r, _widest(env))) \
            if specular else torch.ones_like(s.r)
        diffuse = s.diffuse * s.ao[..., None]
        disc = disc_light(s.n, l_ws, torch.full_like(s.r, float(sun.angular_radius)))
        c = c + ggx_environment_sun(diffuse, f0, f90, a, dfg, ms, s.n, s.v, disc[..., :3],
                                    e * disc[..., 3:], w)
        c = c + env_lights_ggx(others, diffuse, f0, f90, a, dfg, ms, s.n, s.v, w, intensity,
                               rotation_rad)
    return c


def _shade_ggx_mc(g, s: _Surface, defines, env=None, intensity=1.0, rotation_rad=0.0, mc=None,
                  light=None, envelope=None) -> torch.Tensor:
    """``shade_ggx_mc.frag`` on the covered pixels (:func:`shade_ggx_mc`), plus the punctual
    lights on batches with samples. ``envelope``: filled with the samples' lookup bound."""
    alpha = g["alpha"][..., 0]
    h, w = alpha.shape
    covered = alpha > 0.0
    pix = torch.stack(torch.meshgrid(torch.arange(h), torch.arange(w), indexing="ij")[::-1],
                      dim=-1)  # [H, W, 2] (x, y), GL order
    c = torch.zeros_like(s.n)
    c[covered] = shade_ggx_mc(s.n[covered], s.v[covered], {k: t[covered] for k, t in g.items()},
                              s.ao[covered], env, intensity, rotation_rad, defines,
                              pix[covered], int(mc.get("start", 0)), int(mc.get("count", 1)),
                              int(mc.get("seed", 0)), envelope=envelope)
    if envelope is not None:
        bound = torch.zeros_like(s.n)
        bound[covered] = envelope["bound"]
        envelope["bound"] = bound
    if defines.get("LIGHT_COUNT", 0) and int(mc.get("count", 1)) > 0:
        c = c + _ggx_light(s, s.f0, s.f90, s.r * s.r, s.dfg, s.ms, light, defines)
    return c


# the twin of each lighting pass, by model (the pass files are shaders/passes/shade_<model>.frag)
PASS_TWINS = {"unlit": _shade_unlit, "blinn_phong": _shade_blinn_phong,
              "ggx_split_sum": _shade_ggx_split_sum, "ggx_mc": _shade_ggx_mc}
