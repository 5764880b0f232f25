"""Whole lighting passes (``shade_<model>.frag``) against :func:`learned.twins.shade.shade`: the
renderer draws a G-buffer, the twin shades the read-back G-buffer with the same environment
resources; classical models against a per-pixel envelope, Monte Carlo against a fixed bound."""
from __future__ import annotations

import math
from contextlib import contextmanager

import numpy as np
import torch

from learned.twins.shade import shade
from viewer.models import sample_count
from viewer.renderer import Renderer
from viewer.scene.description import scene_from_dict

from ..results import compare_envelope, device_filter_bits
from . import collector


def gl_gbuffer(targets: dict) -> dict[str, torch.Tensor]:
    """The G-buffer :meth:`viewer.renderer.Renderer.draw` produced, channel -> [H, W, C] tensors in
    GL row order (row 0 at the bottom), as the lighting passes and :func:`shade` see it."""
    return {k: torch.from_numpy(v[::-1].copy()) for k, v in targets.gbuffer.read().items()}


def gl_texture(texture) -> np.ndarray:
    """A float32 target (RGBA32F, or fewer channels) read back as [H, W, C] float32 in GL row
    order."""
    w, h = texture.size
    return np.frombuffer(texture.read(), dtype=np.float32).reshape(
        h, w, texture.components).copy()


def env_from_ibl(ibl) -> dict:
    """The GPU environment resources of :class:`viewer.environment.ibl.IBL`, read back as the ``env`` dict
    :func:`shade` takes (level 0 of the radiance, every prefiltered level, the DFG LUT, SH, the irradiance map)."""
    return {"radiance": [torch.from_numpy(ibl.read_level("radiance", 0))],
            "prefiltered": [torch.from_numpy(ibl.read_level("prefiltered", k))
                            for k in range(ibl.levels)],
            "dfg": torch.from_numpy(ibl.read_level("dfg", 0)),
            "dominant": torch.from_numpy(ibl.read_level("dominant", 0)),
            "sh": torch.from_numpy(np.asarray(ibl.sh, np.float32)),
            "irradiance": torch.from_numpy(ibl.read_level("irradiance", 0)),
            "levels": float(ibl.levels)}


def env_for_pass(renderer, scene, sun: bool) -> dict:
    """The ``env`` dict of the IBL a pass bound: with ``sun`` (SUN_LIGHT) the one without the
    environment's sun, plus the sun (``"sun"``) and the whole environment's prefiltered chain
    (``"prefiltered_full"``); else the plain IBL (``"sun"`` None)."""
    ibl = renderer.resources.ibl(scene.environment, sun=sun)
    env = {**env_from_ibl(ibl), "sun": ibl.sun, "lights": ibl.lights}
    if ibl.sun is not None:
        full = renderer.ibl(scene)
        env["prefiltered_full"] = [torch.from_numpy(full.read_level("prefiltered", k))
                                   for k in range(full.levels)]
    return env


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
    # no shadow maps: their lookups are the check shadow:lookups (checks/shadow.py), and the
    # twins of the lighting passes are compared on the same unshadowed light; no rays: the
    # real-time tier's traversal is the check raytrace (checks/raytrace.py), its filter and
    # accumulation lib/denoise.glsl's cases, and the twins here shade without it
    "render": {"shadows": False, "raytrace": False},
}


# Tolerance for whole models: texture lookups dominate (equirect atan differences of ~1e-6 in uv
# times the texel contrast of the sun). Measured on llvmpipe: max rel 7.6e-5, max abs 9.2e-4 on
# radiance up to ~12. GPUs filter with fixed-point weights; the headroom covers that.
MODEL_ATOL = 1e-4


MODEL_RTOL = 5e-4


# ggx_mc: both sides draw bit-identical sample sequences and pick identical CDF texels; the sampled
# directions agree to ~1e-7, which the 2000x sun disc of the sky (bilinear radiance lookups, divided
# by pdfs) amplifies: that part is the per-sample lookup envelope of learned.twins.shade_ggx_mc.
# What stays fixed is the arithmetic. Measured on llvmpipe over MC_VARIANTS: max abs 0.028 (uniform
# sampling, values to ~60), max rel 9e-4 elsewhere.
MC_ATOL = 1e-3


MC_RTOL = 2e-3


def checks() -> dict:
    """This module's pass checks: name -> (model or None, check(programs) -> results)."""
    found, register_pass_check = collector()


    for model in ("unlit", "blinn_phong", "ggx_split_sum"):
        def check(programs, model=model):
            with one_renderer(programs) as r:
                # the parity sky's sun is shaded analytically by ggx_split_sum (SUN_LIGHT) unless
                # sun = false
                results = [_check_model(programs, model, variant, renderer=r)
                           for variant in ({}, {"multiscatter": False, "ao": False,
                                                "background": "transparent", "sun": False})
                           if variant == {} or model != "unlit"]
                # the [light] variant: the scene's directional light on top of the environment;
                # the [[lights]] one: point, spot and directional lights (unlit: compiled out)
                return results + [_check_model(programs, model, {}, PARITY_LIGHT, renderer=r),
                                  _check_model(programs, model, {}, PARITY_LIGHTS, renderer=r)]

        register_pass_check(f"model:{model}", model=model)(check)

    def check_mc(programs):
        with one_renderer(programs) as r:
            return [_check_model(programs, "ggx_mc", v, renderer=r) for v in MC_VARIANTS] + \
                [_check_model(programs, "ggx_mc", v, PARITY_LIGHT, renderer=r)
                 for v in MC_LIGHT_VARIANTS] + \
                [_check_model(programs, "ggx_mc", MC_LIGHT_VARIANTS[0], PARITY_LIGHTS, renderer=r)]

    register_pass_check("model:ggx_mc", model="ggx_mc")(check_mc)

    def check_ssao_applied(programs):
        with one_renderer(programs) as r:
            return [_check_model(programs, model, {"ssao": True, "ssao_rays": 4,
                                                   "ssao_steps": 6}, renderer=r)
                    for model in ("blinn_phong", "ggx_split_sum")]

    register_pass_check("model:ssao_applied")(check_ssao_applied)

    def check_emission(programs):
        """An emissive, textured quad (glTF emission: the optional G-buffer channel) in the
        parity scene: every lighting pass adds it (``emitted_radiance``) as the twin does."""
        variants = [("unlit", {}), ("blinn_phong", {}), ("ggx_split_sum", {}),
                    ("ggx_mc", {"samples": 2, "sampling": "mis"})]
        with one_renderer(programs) as r:
            return [_check_model(programs, model, variant, emissive=True, renderer=r)
                    for model, variant in variants]

    register_pass_check("model:emission")(check_emission)
    return found


def emissive_quad():
    """A 1.2 x 0.8 quad in front of the parity scene's spheres, emitting (3, 1.5, 0.5) times a
    4 x 4 checker of 1 and 0.25 (linear), sampled with the default (trilinear) sampler."""
    from viewer.geometry.primitives import plane

    quad = plane(center=(0.0, 0.3, 0.9), size=(1.2, 0.8), normal=(0.0, 0.2, 1.0))
    checker = np.where((np.arange(4)[:, None] + np.arange(4)[None, :]) % 2 == 0, 1.0, 0.25)
    quad.textures = {"emissive": np.repeat(checker[..., None], 3, -1).astype(np.float32)}
    quad.emissive = (3.0, 1.5, 0.5)
    return quad


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


# The [[lights]] variants: a point light with a range window over the spheres and a spot light
# whose cone edge crosses the floor, besides a directional one (every LIGHT_TYPE_*).
PARITY_LIGHTS = [
    {"type": "point", "position": [0.2, 1.2, 1.0], "color": [1.0, 0.8, 0.6], "intensity": 3.0,
     "range": 4.0},
    {"type": "spot", "position": [-0.5, 1.5, 0.8], "direction": [0.3, 1.0, 0.4],
     "intensity": 6.0, "inner_cone_deg": 15.0, "outer_cone_deg": 35.0},
    {"type": "directional", "direction": [-0.4, 0.6, 0.2], "color": [0.4, 0.5, 1.0],
     "intensity": 1.5},
]


MC_LIGHT_VARIANTS = ({"samples": 2, "sampling": "mis"},
                     {"samples": 2, "sampling": "brdf", "multiscatter": False, "ao": False})


@contextmanager
def one_renderer(programs):
    """A renderer for all the frames of one check (:func:`_check_model`'s ``renderer``): its
    programs compile and its environment resources (IBL, sampling tables) are built once, not
    once per variant: the model:* checks on llvmpipe's SSE4.1 path, cold, 71 -> 46 s of CPU
    (ggx_mc 25 -> 9 s). Every frame still draws every pass (no reuse of the previous variant's
    targets)."""
    renderer = Renderer(ctx=programs.ctx)
    renderer.reuse_passes = False
    try:
        yield renderer
    finally:
        renderer.release()


def _check_model(programs, model: str, variant: dict, light: dict | list | None = None,
                 emissive: bool = False, environment: dict | None = None, renderer=None):
    # light: a [light] table (dict) or a [[lights]] array (list); environment: the scene's
    # [environment] instead of the parity sky (a map with several compact lights: ENV_LIGHTS);
    # renderer: one_renderer's (default: a renderer of this frame alone)
    if renderer is None:
        with one_renderer(programs) as own:
            return _check_model(programs, model, variant, light, emissive, environment, own)
    doc = PARITY_SCENE if light is None else \
        {**PARITY_SCENE, ("lights" if isinstance(light, list) else "light"): light}
    if environment is not None:
        doc = {**doc, "environment": environment}
    if emissive:  # + an in-memory mesh object (emissive_quad)
        doc = {**doc, "objects": doc["objects"] + [{"type": "mesh", "path": "emissive.glb"}]}
    # shadow maps off: their lookups are the check shadow:lookups (checks/shadow.py); the twin of
    # the lighting pass is compared on the same unshadowed light
    scene = scene_from_dict(doc).with_render(model=model, **{"shadows": False, **variant})
    if emissive:
        renderer.add_geometry(scene.objects[-1], [emissive_quad()])
    targets = renderer.draw(scene)
    gb = gl_gbuffer(targets)
    if emissive and not float(gb["emission"].max()) > 0.0:
        raise AssertionError("the emissive quad left no emission in the G-buffer")
    glsl = gl_texture(targets.radiance)
    defines = targets.variant.defines  # what the pass ran with (SUN_LIGHT from the scene)
    env = env_for_pass(renderer, scene, sun=bool(defines.get("SUN_LIGHT", 0)))
    if model == "ggx_mc":
        env.update({k: torch.from_numpy(v)
                    for k, v in renderer.env_sampling(scene).read().items()})
    ssao = None
    if scene.render.ssao.enabled:
        ssao = torch.from_numpy(gl_texture(targets.ssao)[..., 0].copy())
    mc = {"start": 0, "count": sample_count(scene.render), "seed": scene.render.mc.seed}
    envelope = {"weight_bits": device_filter_bits(programs)}
    with torch.enable_grad():  # the envelope differentiates through the lookups
        ref = shade(model, gb, targets.camera, env, scene.environment.intensity,
                    math.radians(scene.environment.rotation_deg),
                    defines, ssao=ssao, mc=mc,
                    light=scene.light, envelope=envelope).detach().numpy()
    name = f"model:{model}" + ("" if not variant else ":" + ",".join(
        f"{k}={v}" for k, v in variant.items())) + (
        "" if light is None else ":lights" if isinstance(light, list) else ":light") \
        + (":emission" if emissive else "")
    if model == "ggx_mc":
        atol, rtol = MC_ATOL, MC_RTOL
        measured = "max abs 0.028 (uniform sampling, sun texels), max rel 9e-4 elsewhere"
        arithmetic = ("per sample ~50 ops on contributions to ~60: 4e-4; MIS weights and pdfs "
                      "well conditioned")
        lookups = ("the mean over samples of |BRDF cos / pdf x weight| x the radiance lookup's "
                   "sample_trilinear_envelope (sampled directions known to 3 trig errors: the "
                   "sun's texel contrast times uv error), + the background/DFG lookups by autograd")
    else:
        atol, rtol = MODEL_ATOL, MODEL_RTOL
        measured = ("max rel 7.6e-5; max abs 9.2e-4 on radiance to ~12, 0.025 in the analytic "
                    "sun's highlights (SUN_LIGHT)")
        arithmetic = "arithmetic, SH, BRDF"
        lookups = ("sum over the background, prefiltered and DFG lookups of |d radiance / d "
                   "lookup| x sample_trilinear_envelope")
    bound = atol + rtol * np.abs(ref)
    bound[..., :3] += envelope["bound"].numpy()
    return compare_envelope(name, glsl, ref, bound, kind="model", measured=measured,
                            envelope=f"per pixel: atol {atol:g} + rtol {rtol:g} ({arithmetic}) "
                                     f"+ {lookups} (measured filter bits)")
