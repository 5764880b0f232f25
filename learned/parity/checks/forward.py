"""The forward pass for transparent surfaces (glTF alphaMode BLEND) against
:func:`learned.twins.forward.shade_forward`: the renderer draws a scene with opaque objects and
overlapping blended quads; the twin takes the opaque radiance (the same scene without the quads),
the opaque G-buffer and each quad alone as a G-buffer layer, and shades, depth-tests, sorts and
blends them itself."""
from __future__ import annotations

import dataclasses
import math

import numpy as np
import torch

from learned.twins.forward import ForwardLayer, shade_forward
from viewer.models import model_info
from viewer.passes.forward import forward_model, forward_variant
from viewer.scene.description import scene_from_dict

from ..results import compare_envelope, device_filter_bits
from . import collector
from .models import (
    MODEL_ATOL,
    MODEL_RTOL,
    PARITY_LIGHT,
    PARITY_SCENE,
    env_for_pass,
    gl_gbuffer,
    gl_texture,
    one_renderer,
)

# (model, render settings, with the [light]): every model that runs forward, and ggx_mc, whose
# blended surfaces fall back to ggx_split_sum over its own Monte-Carlo opaque radiance
VARIANTS = (("unlit", {}, False), ("blinn_phong", {}, False), ("ggx_split_sum", {}, False),
            ("ggx_split_sum", {"multiscatter": False, "ao": False}, True),
            ("blinn_phong", {}, True), ("ggx_mc", {"samples": 2, "sampling": "mis"}, False))


def checks() -> dict:
    found, register_pass_check = collector()

    def check(programs):
        with one_renderer(programs) as r:  # programs and environment built once (models.py)
            return [_check_forward(programs, model, settings, light, r)
                    for model, settings, light in VARIANTS]

    register_pass_check("forward:blend")(check)
    return found


def blended_quads():
    """Three transparent quads in front of the parity scene: two overlapping each other and the
    spheres (one double-sided with a constant COLOR_0 alpha, one emissive metal), one behind the
    left sphere (hidden there by the depth test)."""
    from viewer.geometry.primitives import plane
    from viewer.scene.material import Material

    a = plane(center=(-0.2, 0.1, 0.9), size=(1.2, 0.9), normal=(0.0, 0.1, 1.0),
              material=Material(albedo=(0.9, 0.2, 0.1), roughness=0.3, specular=0.5))
    a.base_alpha = 0.6
    a.colors = np.tile(np.float32([1.0, 1.0, 1.0, 0.8]), (a.vertex_count, 1))
    b = plane(center=(0.3, -0.1, 1.2), size=(1.0, 1.0), normal=(0.2, 0.0, 1.0),
              material=Material(albedo=(0.2, 0.4, 0.9), roughness=0.6, metallic=1.0))
    b.base_alpha = 0.35
    b.emissive = (0.5, 0.25, 0.0)
    c = plane(center=(-0.6, 0.0, -1.0), size=(1.4, 1.4), normal=(0.0, 0.0, 1.0),
              material=Material(albedo=(0.1, 0.8, 0.2), roughness=0.1))
    c.base_alpha = 0.5
    out = []
    for mesh, double_sided in ((a, True), (b, False), (c, False)):
        mesh.alpha_mode, mesh.double_sided = "BLEND", double_sided
        out.append(mesh)
    return out


def _check_forward(programs, model: str, settings: dict, light: bool, renderer):
    quads = blended_quads()
    doc = PARITY_SCENE if not light else {**PARITY_SCENE, "light": PARITY_LIGHT}
    opaque_doc = doc
    doc = {**doc, "objects": doc["objects"] + [{"type": "mesh", "path": f"blend{i}.glb"}
                                               for i in range(len(quads))]}
    scene = scene_from_dict(doc).with_render(model=model, **settings)
    opaque_scene = scene_from_dict(opaque_doc).with_render(model=model, **settings)
    for obj, quad in zip(scene.objects[-len(quads):], quads):
        renderer.add_geometry(obj, [quad])
    targets = renderer.draw(scene)
    glsl = gl_texture(targets.radiance)
    opaque = gl_gbuffer(targets)
    if not (opaque["depth"][..., 0] > 0).any():
        raise AssertionError("the opaque G-buffer has no depth channel")
    radiance = torch.from_numpy(gl_texture(renderer.draw(opaque_scene).radiance))
    camera = targets.camera
    view = camera.view_matrix()
    layers = []
    for obj, quad in zip(scene.objects[-len(quads):], quads):
        alone = dataclasses.replace(scene, objects=(obj,)).with_render(specialize=False)
        solid = dataclasses.replace(quad, alpha_mode="OPAQUE")
        renderer.add_geometry(obj, [solid])
        lo, hi = quad.bounds()
        alpha = float(quad.base_alpha) * (1.0 if quad.colors is None
                                          else float(quad.colors[0, 3]))
        layers.append(ForwardLayer(gbuffer=gl_gbuffer(renderer.draw(alone)), alpha=alpha,
                                   centre_depth=float(-(view[2, :3] @ ((lo + hi) * 0.5)
                                                        + view[2, 3]))))
    # the forward model shades the environment's sun itself when it can (as the renderer)
    sun = scene.render.sun and model_info(forward_model(model)).analytic_sun
    env = env_for_pass(renderer, scene, sun=sun)
    envelope = {"weight_bits": device_filter_bits(programs)}
    with torch.enable_grad():  # the envelope differentiates through the lookups
        ref = shade_forward(forward_model(model), radiance, opaque, layers, camera, env,
                            scene.environment.intensity,
                            math.radians(scene.environment.rotation_deg),
                            forward_variant(scene.render, scene.light,
                                            sun=env["sun"] is not None).defines,
                            light=scene.light, envelope=envelope).detach().numpy()
    name = f"forward:{model}" + ("" if not settings else ":" + ",".join(
        f"{k}={v}" for k, v in settings.items())) + (":light" if light else "")
    bound = MODEL_ATOL + MODEL_RTOL * np.abs(ref)
    bound[..., :3] += envelope["bound"].numpy()
    return compare_envelope(
        name, glsl, ref, bound, kind="model",
        measured="max abs 2.9e-6 on radiance to ~12, max rel 2.2e-6 (llvmpipe, every variant)",
        envelope=f"per pixel: atol {MODEL_ATOL:g} + rtol {MODEL_RTOL:g} (the lighting-pass "
                 f"twin's arithmetic, as model:<name>) + the sum over the blended layers of their "
                 f"lookup envelopes (each blend step scales what is under it by 1 - alpha <= 1); "
                 f"the opaque radiance is the GL render of the scene without the quads, so it "
                 f"adds nothing")
