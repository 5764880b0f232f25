"""Twin of the lighting passes ``shaders/passes/shade_<model>.frag`` on a G-buffer: :func:`shade`
evaluates a whole classical shading model (the neural ones: :mod:`learned.twins.neural`) with the
same environment resources the GL pass reads, so :mod:`learned.parity.checks.models` compares
them pixel by pixel. Images are in GL row order (row 0 at the bottom), as the passes see them.
"""
from __future__ import annotations

import torch

from .brdf import clamp_perceptual_roughness, compute_f0
from .deferred import env_dir, reflect, view_ray_ws
from .equirect import equirect_uv
from .ibl import (
    DIRECTION_ABS_ERROR,
    equirect_uv_error,
    ibl_dfg,
    ibl_specular_radiance,
    prefilter_lod,
    sample_bilinear,
    sample_trilinear_envelope,
)
from .sh import sh_irradiance
from .shade_ggx_mc import shade_ggx_mc
from .shading import (
    blinn_phong,
    blinn_phong_directional_light,
    diffuse_color,
    ggx_directional_light,
    ggx_split_sum,
    shading_normal,
)


def shade(model: str, gbuffer: dict[str, torch.Tensor], camera, env: dict, intensity: float,
          rotation_rad: float, defines: dict[str, int], ssao: torch.Tensor | None = None,
          mc: dict | None = None, light=None, envelope: dict | None = None) -> torch.Tensor:
    """The lighting pass ``model`` on a G-buffer (channel -> [H, W, C], GL row order).

    ``env``: ``radiance`` (list of mips [h, w, 4]), ``prefiltered`` (list), ``dfg`` ([n, n, 2]),
    ``sh`` ([9, 3]), ``levels``; for ``ggx_mc`` also the sampling distribution ``marginal``,
    ``conditional``, ``pdf`` (:func:`learned.twins.env_sampling.env_distribution` layout).
    ``defines`` as in :func:`viewer.passes.shade.shade_defines`; ``ssao`` ([H, W], the occlusion
    texture) when ``USE_SSAO``; ``mc``: ``start``, ``count``, ``seed`` of the Monte-Carlo batch;
    ``light``: the scene's :class:`~viewer.scene.DirectionalLight`, shaded when
    ``LIGHT_DIRECTIONAL`` (as the GLSL, the define decides, not the argument).
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
    if model == "unlit":
        if "color" in g:
            c = torch.where(alpha[..., None] > 0, g["color"] / alpha.clamp_min(1e-30)[..., None],
                            torch.zeros_like(g["color"]))
        else:
            c = g["albedo"]
    else:
        v = -d
        n = shading_normal(g["normal"], v)
        r = clamp_perceptual_roughness(g["roughness"][..., 0])
        sh = env["sh"]
        irradiance = sh_irradiance(env_dir(n, rotation_rad), sh) * intensity
        r_env = env_dir(reflect(-v, n), rotation_rad)
        prefiltered = ibl_specular_radiance(env["prefiltered"], r_env, r, env["levels"])
        prefiltered = traced("prefiltered", prefiltered, lambda: sample_trilinear_envelope(
            env["prefiltered"], equirect_uv(r_env),
            prefilter_lod(r, torch.full_like(r, float(env["levels"]))),
            equirect_uv_error(r_env, 2.0 * DIRECTION_ABS_ERROR), weight_bits=bits)[..., :3])
        prefiltered = prefiltered * intensity
        ao = g["ao"][..., 0] if defines.get("USE_AO", 1) else torch.ones_like(r)
        if defines.get("USE_SSAO", 0):
            ao = ao * ssao  # deferred.glsl ambient_occlusion()
        diffuse = diffuse_color(g["albedo"], g["metallic"][..., 0])
        f0 = compute_f0(g["albedo"], g["metallic"][..., 0], g["specular"][..., 0])
        nov = (n * v).sum(-1).clamp(0.0, 1.0)
        ms = torch.full_like(r, float(defines.get("MULTISCATTER", 1)))
        dfg = ibl_dfg(env["dfg"], nov, r) if model in ("ggx_split_sum", "ggx_mc") else None
        if dfg is not None:
            lut = env["dfg"]
            size = torch.tensor([float(lut.shape[1]), float(lut.shape[0])])
            uv_lut = (torch.stack([nov, r.clamp(0.0, 1.0)], -1) * (size - 1.0) + 0.5) / size
            dfg = traced("dfg", dfg, lambda: sample_trilinear_envelope(
                [lut], uv_lut, torch.zeros_like(r), torch.full_like(uv_lut, 1e-6),
                repeat_u=False, weight_bits=bits))
        if model == "ggx_split_sum":
            c = ggx_split_sum(diffuse, f0, ao, irradiance, prefiltered, dfg, ms)
        elif model == "blinn_phong":
            c = blinn_phong(diffuse, f0, ao, irradiance, prefiltered)
        elif model == "ggx_mc":

            mc = mc or {}
            covered = alpha > 0.0
            pix = torch.stack(torch.meshgrid(torch.arange(h), torch.arange(w), indexing="ij")[::-1],
                              dim=-1)  # [H, W, 2] (x, y), GL order
            c = torch.zeros_like(d)
            mc_envelope = None if envelope is None else {"weight_bits": bits}
            c[covered] = shade_ggx_mc(n[covered], v[covered], {k: t[covered] for k, t in g.items()},
                                      ao[covered], env, intensity, rotation_rad, defines,
                                      pix[covered], int(mc.get("start", 0)),
                                      int(mc.get("count", 1)), int(mc.get("seed", 0)),
                                      envelope=mc_envelope)
            if mc_envelope is not None:  # the samples' lookups; d out / d c = coverage
                mc_bound = torch.zeros_like(d)
                mc_bound[covered] = mc_envelope["bound"]
                lookups["mc"] = (None, mc_bound * alpha[..., None])
        else:
            raise ValueError(f"no torch twin for model {model!r}")
        if defines.get("LIGHT_DIRECTIONAL", 0):
            c = c + _directional_light(model, diffuse, f0, r * r, dfg, ms, n, v, light, defines,
                                       mc)
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


def _directional_light(model: str, diffuse, f0, a, dfg, ms, n, v, light, defines: dict,
                       mc: dict | None) -> torch.Tensor:
    """The ``LIGHT_DIRECTIONAL`` term of the lighting passes (no AO, no shadowing). ``ggx_mc``
    adds it only to batches with samples, as its GLSL does. [H, W, 3]."""
    l_ws = torch.tensor(light.direction, dtype=torch.float32).expand_as(n)
    irradiance = torch.tensor(light.irradiance, dtype=torch.float32).expand_as(n)
    if model == "blinn_phong":
        if not defines.get("SPECULAR_LOBE", 1):  # the specialised variant passes f0 = 0, a = 1
            f0, a = torch.zeros_like(f0), torch.ones_like(a)
        return blinn_phong_directional_light(diffuse, f0, a, n, v, l_ws, irradiance)
    if model == "ggx_split_sum" and not defines.get("SPECULAR_LOBE", 1):
        f0, a = torch.zeros_like(f0), torch.ones_like(a)
        dfg = torch.tensor([0.0, 1.0]).expand(*a.shape, 2)
        ms = torch.zeros_like(a)
    if model == "ggx_mc":
        ms = torch.full_like(a, float(defines.get("MULTISCATTER", 1)))
        if int((mc or {}).get("count", 1)) <= 0:
            return torch.zeros_like(n)
    return ggx_directional_light(diffuse, f0, a, dfg, ms, n, v, l_ws, irradiance)
