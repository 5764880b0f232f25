"""``shadow:lights``: the composed ``shadow_light_visibility`` of ``lib/shadow.glsl`` as the
lighting pass evaluates it (``light_visibility`` of passes/lights.glsl) on a rendered scene, against
:func:`learned.twins.shadow.shadow_light_visibility` computed from the same shadow map texture, read
back from the frame. A floor and a sphere under one soft light of each kind (directional, spot,
point), and a directional light's cascades (``shadow_cascade_visibility`` against its twin) over a
100 m floor; the GLSL's visibility is the lit radiance over the same frame without shadows (nothing
but that light lights the scene), the twin's is evaluated at each pixel's surface point rebuilt from
the G-buffer's depth as the pass rebuilds it. ``shadow:environment``: the environment's shadow
directions (``env_shadow`` of passes/lights.glsl, composing ``shadow_tile_visibility``) on a floor
and a sphere in the procedural studio, the GLSL's being the floor's radiance with them over the same
frame without (its diffuse environment light is all of it), against
:func:`learned.twins.lights.env_shadow` of the atlas read back."""
from __future__ import annotations

import numpy as np
import torch

from learned.twins.lights import light_surface_position
from learned.twins.shadow import (
    shadow_cascade_visibility,
    shadow_light_visibility,
    shadow_phi,
)

from ..results import compare
from . import collector

N = 64
LIGHTS = {"directional": {"type": "directional", "direction": [0.5, 1.0, 0.2],
                          "angular_diameter_deg": 6.0},
          "spot": {"type": "spot", "position": [0.6, 3.0, 0.3], "direction": [0.2, 1.0, 0.1],
                   "outer_cone_deg": 55, "inner_cone_deg": 45, "radius": 0.15},
          "point": {"type": "point", "position": [-0.8, 2.4, 0.6], "radius": 0.15},
          # 3 cascades over a 100 m floor (viewer/lighting/cascades.py)
          "cascaded": {"type": "directional", "direction": [0.5, 1.0, 0.2],
                       "angular_diameter_deg": 3.0}}
CASCADED = {"floor": 100.0, "render": {"shadow_cascades": 3}}
ENVELOPE = ("the surface point is rebuilt from depth by the same float32 expression on both "
            "sides up to contraction (~1e-7 relative), the lookups are exact (shadow:lookups): "
            "a pixel differs only where a tap's texel changes with that rounding; robust: 1 in "
            "100 pixels may differ, by at most one tap's share (1/4) where they do")


GREY = {"albedo": [0.5, 0.5, 0.5], "roughness": 1.0, "specular": 0.0}


def _scene(light: dict | None, floor: float = 8.0, render: dict | None = None,
           environment: dict | None = None):
    from viewer.scene.description import scene_from_dict

    return scene_from_dict({
        "camera": {"position": [0, 5, 0.01], "target": [0, 0, 0], "fov_y": 60, "size": [N, N]},
        "environment": environment or {"procedural": "white", "width": 32, "intensity": 0.0},
        "lights": [{"intensity": 10.0, **light}] if light else [],
        "objects": [{"type": "plane", "center": [0, 0, 0], "size": [floor, floor],
                     "normal": [0, 1, 0], "material": GREY},
                    {"type": "sphere", "center": [0, 1, 0], "radius": 0.5, "material": GREY}],
        # shadow maps and the environment's shadow directions are what these checks read: no
        # rays (they stand in for the sun's map and the environment's shadows)
        "render": {"tonemap": "none", "model": "ggx_split_sum", "multiscatter": False,
                   "raytrace": False, **(render or {})}})


def _read_map(frame) -> torch.Tensor:
    """The frame's shadow map of light 0, [H, W] in GL row order (read before the next draw)."""
    tex = frame.targets["shadowmap0"].texture
    w, h = tex.size
    return torch.from_numpy(np.frombuffer(tex.read(), np.float32).reshape(h, w).copy())


def _surface(gbuffer, cam):
    """Each pixel's surface point rebuilt from the G-buffer's depth as the lighting pass
    rebuilds it, its normal and fragment coordinates ([N, N, ...], GL rows)."""
    ys, xs = np.mgrid[0:N, 0:N]
    frag = torch.from_numpy(np.stack([xs + 0.5, ys + 0.5], -1).astype(np.float32))
    depth = torch.from_numpy(gbuffer["depth"][::-1, :, 0].copy())
    normal = torch.from_numpy(gbuffer["normal"][::-1].copy())
    p = light_surface_position(frag, depth, cam.position,
                               torch.from_numpy(cam.basis().astype(np.float32).T.copy()),
                               torch.tensor(cam.tan_half_fov(), dtype=torch.float32),
                               torch.tensor([N, N], dtype=torch.float32))
    return p, normal, frag


def _twin_visibility(renderer, scene, frame, depth_map, gbuffer) -> np.ndarray:
    from viewer.graph.frame import light_shadow_frame
    from viewer.passes.shadow_bindings import shadow_lens

    light = scene.lights[0]
    settings = scene.render.shadow
    sframe = light_shadow_frame(light, renderer.bounds(scene), settings, frame.camera)
    size = light.radius if light.positional else np.radians(light.angular_diameter_deg) / 2.0
    lens = torch.tensor(shadow_lens(sframe, size * settings.softness), dtype=torch.float32)
    offset = sframe.texel_world * settings.bias
    p, normal, frag = _surface(gbuffer, frame.camera)
    if light.positional:
        to = torch.tensor(light.position, dtype=torch.float32) - p
        l = to / torch.linalg.vector_norm(to, dim=-1, keepdim=True)
    else:
        l = torch.tensor(light.direction, dtype=torch.float32).expand_as(p)
    m = torch.from_numpy(sframe.matrix.astype(np.float32))
    if hasattr(sframe, "boxes"):  # cascades
        c = torch.from_numpy(sframe.uniforms())
        vis = shadow_cascade_visibility(depth_map, m, lens, offset, c[0], c[1], c[2], c[3],
                                        sframe.count, l, p, normal, shadow_phi(frag))
        return vis.numpy()[::-1]
    vis = shadow_light_visibility(depth_map, m, lens, offset, light.position, l, p, normal,
                                  shadow_phi(frag))
    return vis.numpy()[::-1]  # image rows (row 0 at the top)


def checks() -> dict:
    found, register_pass_check = collector()

    @register_pass_check("shadow:lights")
    def check_lights(programs):
        from viewer.renderer import Renderer

        renderer = Renderer(ctx=programs.ctx)
        out = []
        try:
            for kind, light in LIGHTS.items():
                scene = _scene(light, **(CASCADED if kind == "cascaded" else {}))
                frame = renderer.draw(scene, aovs=("depth", "normal"))
                depth_map = _read_map(frame)
                lit = renderer.render(scene, aovs=("depth", "normal"))  # the same frame, reused
                gbuffer = lit.aovs
                with torch.no_grad():
                    twin = _twin_visibility(renderer, scene, frame, depth_map, gbuffer)
                free = renderer.render(scene.with_render(shadows=False)).radiance[..., 0]
                ok = (free > 1e-4) & (gbuffer["normal"][..., 1] > 0.2)  # lit by it, facing up
                gl = lit.radiance[..., 0][ok] / free[ok]
                ref = twin[ok]
                diff = np.abs(gl - ref)
                bad = diff > 1e-4
                fn = "shadow_cascade_visibility" if kind == "cascaded" else \
                    "shadow_light_visibility"
                res = compare(f"{fn} ({kind})", gl[~bad], ref[~bad],
                              atol=1e-4, rtol=0.0, kind="pass",
                              measured=f"{int(bad.sum())} of {int(ok.sum())} pixels beyond 1e-4 "
                                       f"on llvmpipe; {int(((ref > 0) & (ref < 1)).sum())} in "
                                       f"penumbrae, {int((ref == 0).sum())} in umbrae",
                              envelope=ENVELOPE)
                res.passed = bool(res.passed and bad.mean() <= 0.01
                                  and (diff[bad] <= 0.25 + 1e-4).all()
                                  and (ref == 0).sum() > 20
                                  # the cascaded scene's map is the 3 cascades' 2 x 2 atlas
                                  and (kind != "cascaded" or depth_map.shape[0]
                                       == depth_map.shape[1] == 2 * scene.render.shadow.size))
                out.append(res)
        finally:
            renderer.release()
        return out

    @register_pass_check("shadow:environment")
    def check_environment(programs):
        from learned.twins.lights import env_shadow
        from viewer.graph.shadows import _env_frames
        from viewer.passes.shadow_bindings import shadow_lens
        from viewer.renderer import Renderer

        renderer = Renderer(ctx=programs.ctx)
        try:
            scene = _scene(None, render={"env_shadows": 8, "sun": False, "ao": False},
                           environment={"procedural": "studio", "width": 64})
            frame = renderer.draw(scene, aovs=("depth", "normal"))
            tex = frame.targets["shadowmapenvdirs"].texture
            w, h = tex.size
            atlas = torch.from_numpy(np.frombuffer(tex.read(), np.float32).reshape(h, w).copy())
            lit = renderer.render(scene, aovs=("depth", "normal"))
            free = renderer.render(scene.with_render(env_shadows=0)).radiance[..., 0]
            frames = _env_frames(renderer, scene, renderer.bounds(scene), 8, sunless=False)
            settings = scene.render.shadow
            k = frames.count
            matrices = torch.from_numpy(np.stack([f.matrix for f in frames.faces]).astype(
                np.float32))
            dirs = torch.tensor([(*d, s) for d, s in zip(frames.directions, frames.shares)],
                                dtype=torch.float32)
            lenses = torch.tensor([shadow_lens(f, frames.penumbra_radius(i, settings.softness))
                                   for i, f in enumerate(frames.faces)], dtype=torch.float32)
            offsets = torch.tensor([f.texel_world * settings.bias for f in frames.faces],
                                   dtype=torch.float32)
            p, normal, frag = _surface(lit.aovs, frame.camera)
            with torch.no_grad():
                twin = env_shadow(atlas, matrices, dirs, lenses, offsets, p, normal,
                                  shadow_phi(frag)).numpy()[::-1]
            ok = (free > 1e-4) & (lit.aovs["normal"][..., 1] > 0.99)  # the floor
            gl = lit.radiance[..., 0][ok] / free[ok]
            ref = twin[ok]
            diff = np.abs(gl - ref)
            bad = diff > 1e-4
            res = compare(f"env_shadow ({k} directions)", gl[~bad], ref[~bad], atol=1e-4,
                          rtol=0.0, kind="pass",
                          measured=f"{int(bad.sum())} of {int(ok.sum())} pixels beyond 1e-4 "
                                   f"on llvmpipe; {int((ref < 0.9).sum())} below 0.9",
                          envelope=ENVELOPE)
            res.passed = bool(res.passed and bad.mean() <= 0.01
                              and (diff[bad] <= 0.25 + 1e-4).all() and (ref < 0.9).sum() > 20)
            return [res]
        finally:
            renderer.release()

    return found
