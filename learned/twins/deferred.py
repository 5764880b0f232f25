"""Twins of the lighting passes: ``shaders/passes/deferred.glsl`` and ``shade_<model>.frag``.

:func:`shade` evaluates a whole shading model on a G-buffer read back from GL, with the same
environment resources (prefiltered chain, DFG LUT, SH coefficients read back from the GPU), so the
registered ``model:<name>`` parity checks compare the torch path and the GLSL path pixel by pixel.
Images here are in GL row order (row 0 at the bottom), as the passes see them.
"""
from __future__ import annotations

import math

import numpy as np
import torch

from .brdf import clamp_perceptual_roughness, compute_f0
from .equirect import equirect_uv, rotate_y
from .ibl import (DIRECTION_ABS_ERROR, equirect_uv_error, ibl_dfg, ibl_specular_radiance,
                  prefilter_lod, sample_bilinear, sample_trilinear_envelope)
from .sh import sh_irradiance
from .shading import blinn_phong, blinn_phong_directional_light, diffuse_color, \
    ggx_directional_light, ggx_split_sum, shading_normal

PASS_LEVEL = ()


def gl_gbuffer(targets: dict) -> dict[str, torch.Tensor]:
    """The G-buffer :meth:`viewer.renderer.Renderer.draw` produced, channel -> [H, W, C] tensors in
    GL row order (row 0 at the bottom), as the lighting passes and :func:`shade` see it."""
    return {k: torch.from_numpy(v[::-1].copy()) for k, v in targets.gbuffer.read().items()}


def gl_texture(texture) -> np.ndarray:
    """An RGBA32F target read back as [H, W, 4] float32 in GL row order."""
    w, h = texture.size
    return np.frombuffer(texture.read(), dtype=np.float32).reshape(h, w, 4).copy()


def env_from_ibl(ibl) -> dict:
    """The GPU environment resources of :class:`viewer.ibl.IBL`, read back as the ``env`` dict
    :func:`shade` takes (level 0 of the radiance, every prefiltered level, the DFG LUT, SH)."""
    return {"radiance": [torch.from_numpy(ibl.read_level("radiance", 0))],
            "prefiltered": [torch.from_numpy(ibl.read_level("prefiltered", k))
                            for k in range(ibl.levels)],
            "dfg": torch.from_numpy(ibl.read_level("dfg", 0)),
            "sh": torch.from_numpy(np.asarray(ibl.sh, np.float32)),
            "levels": float(ibl.levels)}


def view_ray_ws(frag_coord: torch.Tensor, camera_to_world: torch.Tensor,
                tan_half_fov: torch.Tensor, resolution: torch.Tensor) -> torch.Tensor:
    """GLSL ``vec3 view_ray_ws(vec2 frag_coord)`` of ``passes/deferred.glsl``.
    frag_coord [..., 2] (pixel centres, origin bottom-left), camera_to_world [3, 3] (columns right,
    up, back) -> [..., 3] unit world directions."""
    ndc = frag_coord / resolution * 2.0 - 1.0
    d_vs = torch.cat([ndc * tan_half_fov, -torch.ones_like(ndc[..., :1])], dim=-1)
    d = d_vs @ camera_to_world.T
    return d / torch.linalg.vector_norm(d, dim=-1, keepdim=True)


def env_dir(d_ws: torch.Tensor, rotation: float) -> torch.Tensor:
    """GLSL ``vec3 env_dir(vec3 d_ws)``: world direction -> the rotated environment's frame."""
    return rotate_y(d_ws, torch.full(d_ws.shape[:-1], -rotation, dtype=d_ws.dtype))


def reflect(i: torch.Tensor, n: torch.Tensor) -> torch.Tensor:
    """GLSL built-in ``reflect(I, N)`` = I - 2 dot(N, I) N."""
    return i - 2.0 * (n * i).sum(-1, keepdim=True) * n


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
        if envelope is None or model == "ggx_mc":
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
            from .mc import shade_ggx_mc

            mc = mc or {}
            covered = alpha > 0.0
            pix = torch.stack(torch.meshgrid(torch.arange(h), torch.arange(w), indexing="ij")[::-1],
                              dim=-1)  # [H, W, 2] (x, y), GL order
            c = torch.zeros_like(d)
            c[covered] = shade_ggx_mc(n[covered], v[covered], {k: t[covered] for k, t in g.items()},
                                      ao[covered], env, intensity, rotation_rad, defines,
                                      pix[covered], int(mc.get("start", 0)),
                                      int(mc.get("count", 1)), int(mc.get("seed", 0)))
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
        if lookups and out.requires_grad:
            values = [v for v, _ in lookups.values()]
            grads = torch.autograd.grad(out.sum(), values, allow_unused=True)
            for (value, lookup_bound), grad in zip(lookups.values(), grads):
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


# ---------------------------------------------------------------------------------------------
# model-level parity: render in GL, shade the read-back G-buffer in torch, compare
# ---------------------------------------------------------------------------------------------

PARITY_SCENE = {
    "camera": {"position": [0.4, 0.8, 3.2], "target": [0, 0, 0], "fov_y": 45, "size": [64, 48]},
    "environment": {"procedural": "sky", "intensity": 1.7, "rotation_deg": 33, "width": 64},
    "objects": [
        {"type": "sphere", "center": [-0.6, 0, 0], "radius": 0.7,
         "material": {"albedo": [0.9, 0.6, 0.3], "roughness": 0.3, "metallic": 1.0}},
        {"type": "sphere", "center": [0.7, 0.1, -0.3], "radius": 0.6,
         "material": {"albedo": [0.2, 0.5, 0.8], "roughness": 0.0, "specular": 1.0}},
        {"type": "plane", "center": [0, -0.7, 0], "size": [6, 6],
         "material": {"albedo": [0.5, 0.5, 0.5], "roughness": 0.7, "ao": 0.6}},
    ],
}
# Tolerance for whole models: texture lookups dominate (equirect atan differences of ~1e-6 in uv
# times the texel contrast of the sun). Measured on llvmpipe: max rel 7.6e-5, max abs 9.2e-4 on
# radiance up to ~12. GPUs filter with fixed-point weights; the headroom covers that.
MODEL_ATOL = 1e-4
MODEL_RTOL = 5e-4
# ggx_mc: both sides draw bit-identical sample sequences and pick identical CDF texels; the sampled
# directions agree to ~1e-7, which the 2000x sun disc of the sky (bilinear radiance lookups, divided
# by pdfs) amplifies. Measured on llvmpipe over MC_VARIANTS: max abs 0.028 (uniform sampling, values
# to ~60), max rel 9e-4 elsewhere.
MC_ATOL = 1e-3
MC_RTOL = 2e-3


def _register_checks() -> None:
    from learned.parity import register_pass_check

    for model in ("unlit", "blinn_phong", "ggx_split_sum"):
        def check(programs, model=model):
            results = [_check_model(programs, model, variant)
                       for variant in ({}, {"multiscatter": False, "ao": False,
                                            "background": "transparent"})
                       if variant == {} or model != "unlit"]
            # the [light] variant: the scene's directional light on top of the environment
            return results + [_check_model(programs, model, {}, light=PARITY_LIGHT)]

        register_pass_check(f"model:{model}", model=model)(check)

    def check_mc(programs):
        return [_check_model(programs, "ggx_mc", variant) for variant in MC_VARIANTS] + \
            [_check_model(programs, "ggx_mc", variant, light=PARITY_LIGHT)
             for variant in MC_LIGHT_VARIANTS]

    register_pass_check("model:ggx_mc", model="ggx_mc")(check_mc)

    def check_ssao_applied(programs):
        return [_check_model(programs, model, {"ssao": True, "ssao_rays": 4, "ssao_steps": 6})
                for model in ("blinn_phong", "ggx_split_sum")]

    register_pass_check("model:ssao_applied")(check_ssao_applied)


# ggx_mc renders few samples in one batch; every strategy, both heuristics, the toggles.
MC_VARIANTS = (
    {"samples": 4, "sampling": "mis"},
    {"samples": 2, "sampling": "mis", "mis_heuristic": "balance", "seed": 7},
    {"samples": 2, "sampling": "brdf", "multiscatter": False, "ao": False,
     "background": "transparent"},
    {"samples": 2, "sampling": "env"},
    {"samples": 2, "sampling": "uniform"},
    {"samples": 2, "sampling": "cosine", "ssao": True, "ssao_rays": 4, "ssao_steps": 6},
)


# The [light] of the light variants: from the upper right front, warm, brighter than the sky; the
# environment stays (rotated by 33 degrees, which must not turn the light).
PARITY_LIGHT = {"direction": [0.6, 0.7, 0.4], "color": [1.0, 0.9, 0.7], "intensity": 4.0}
MC_LIGHT_VARIANTS = ({"samples": 2, "sampling": "mis"},
                     {"samples": 2, "sampling": "brdf", "multiscatter": False, "ao": False})


def _check_model(programs, model: str, variant: dict, light: dict | None = None):
    from learned.parity import compare, compare_envelope, device_filter_bits
    from viewer.passes.shade import shade_defines
    from viewer.renderer import Renderer
    from viewer.scene import scene_from_dict

    doc = PARITY_SCENE if light is None else {**PARITY_SCENE, "light": light}
    scene = scene_from_dict(doc).with_render(model=model, **variant)
    renderer = Renderer(ctx=programs.ctx)
    try:
        targets = renderer.draw(scene)
        gb = gl_gbuffer(targets)
        glsl = gl_texture(targets.radiance)
        env = env_from_ibl(renderer.ibl(scene))
        if model == "ggx_mc":
            env.update({k: torch.from_numpy(v)
                        for k, v in renderer.env_sampling(scene).read().items()})
        ssao = None
        if scene.render.ssao:
            ssao = torch.from_numpy(gl_texture(targets.ssao)[..., 0].copy())
        mc = {"start": 0, "count": scene.render.samples, "seed": scene.render.seed}
        envelope = {"weight_bits": device_filter_bits(programs)}
        with torch.enable_grad():  # the envelope differentiates through the lookups
            ref = shade(model, gb, targets.camera, env, scene.environment.intensity,
                        math.radians(scene.environment.rotation_deg),
                        shade_defines(model, scene.render, scene.light), ssao=ssao, mc=mc,
                        light=scene.light, envelope=envelope).detach().numpy()
    finally:
        renderer.release()
    name = f"model:{model}" + ("" if not variant else ":" + ",".join(
        f"{k}={v}" for k, v in variant.items())) + (":light" if light is not None else "")
    if model == "ggx_mc":
        return compare(name, glsl, ref, MC_ATOL, MC_RTOL, kind="model",
                       measured="max abs 0.028, max rel 9e-4 (uniform sampling, sun texels)",
                       envelope="not derived: measured on llvmpipe (per-sample radiance lookups "
                                "divided by pdfs amplify the sun's texel contrast); unverified on "
                                "8-bit GPU filtering")
    lookups = envelope["bound"].numpy()
    bound = MODEL_ATOL + MODEL_RTOL * np.abs(ref)
    bound[..., :3] += lookups
    return compare_envelope(
        name, glsl, ref, bound, kind="model",
        measured="max abs 9.2e-4 on radiance to ~12 (max rel 7.6e-5)",
        envelope=f"per pixel: atol {MODEL_ATOL:g} + rtol {MODEL_RTOL:g} (arithmetic, SH, "
                 "BRDF) + sum over the background, prefiltered and DFG lookups of |d radiance "
                 "/ d lookup| x sample_trilinear_envelope (measured filter bits)")


_register_checks()
