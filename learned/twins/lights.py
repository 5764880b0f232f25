"""Twins of ``shaders/lib/lights.glsl`` (punctual lights) and of the pass chunk
``shaders/passes/lights.glsl`` (the per-model sums over a scene's lights, the shadow hook)."""
from __future__ import annotations

import math

import torch

from .common import saturate, sq
from .shading import blinn_phong_directional_light, ggx_directional_light

LIGHT_TYPE_IDS = {"directional": 0, "point": 1, "spot": 2}  # LIGHT_TYPE_* of lib/lights.glsl


def light_range_window(d: torch.Tensor, range_: torch.Tensor) -> torch.Tensor:
    """GLSL ``float light_range_window(float d, float range)``: clamp(1 - (d/range)^4, 0, 1)^2,
    1 where range <= 0. [...]."""
    safe = torch.where(range_ > 0.0, range_, torch.ones_like(range_))
    q = d / safe
    q = q * q
    return torch.where(range_ > 0.0, sq(saturate(1.0 - q * q)), torch.ones_like(d))


def spot_cone_factor(cos_angle: torch.Tensor, cos_outer: torch.Tensor,
                     cos_inner: torch.Tensor) -> torch.Tensor:
    """GLSL ``float spot_cone_factor(float cos_angle, float cos_outer, float cos_inner)``: glTF's
    cone falloff t^2, t = saturate((cos_angle - cos_outer) / max(cos_inner - cos_outer, 1e-3))."""
    t = saturate((cos_angle - cos_outer) / torch.clamp(cos_inner - cos_outer, min=1e-3))
    return t * t


def punctual_light(type_: torch.Tensor, position: torch.Tensor, direction: torch.Tensor,
                   cone_range: torch.Tensor, p: torch.Tensor) -> torch.Tensor:
    """GLSL ``vec4 punctual_light(int type, vec3 position, vec3 direction, vec4 cone_range,
    vec3 p)``: (l, attenuation). type [...], position/direction/p [..., 3], cone_range [..., 4]."""
    to_light = position - p
    d2 = (to_light * to_light).sum(-1)
    ok = d2 > 0.0
    d = torch.sqrt(torch.where(ok, d2, torch.ones_like(d2)))
    l = to_light / d[..., None]
    att = light_range_window(d, cone_range[..., 2]) / torch.where(ok, d2, torch.ones_like(d2))
    spot = spot_cone_factor((l * direction).sum(-1), cone_range[..., 0], cone_range[..., 1])
    att = torch.where(type_ == 2, att * spot, att)
    att = torch.where(ok, att, torch.zeros_like(att))
    l = torch.where(ok[..., None], l, direction)
    directional = type_ == 0
    l = torch.where(directional[..., None], direction, l)
    att = torch.where(directional, torch.ones_like(att), att)
    return torch.cat([l, att[..., None]], dim=-1)


def light_visibility(i: int, p: torch.Tensor, n: torch.Tensor, l=None) -> torch.Tensor:
    """GLSL ``float light_visibility(int i, vec3 p, vec3 n, vec3 l)`` (passes/lights.glsl)
    without shadow maps or contact shadows (LIGHT_SHADOWS 0, CONTACT_SHADOWS 0, as the model
    parity checks render): 1. With a map it is :func:`learned.twins.shadow.shadow_light_visibility`
    of light i's map and uniforms (the pass check ``shadow:lights`` compares the two on a
    rendered scene's maps), with contact shadows times
    :func:`learned.twins.contact.contact_shadow`."""
    return torch.ones(p.shape[:-1], dtype=p.dtype)


def light_surface_position(frag_coord: torch.Tensor, depth: torch.Tensor, camera_position,
                           camera_to_world: torch.Tensor, tan_half_fov: torch.Tensor,
                           resolution: torch.Tensor) -> torch.Tensor:
    """GLSL ``vec3 light_surface_position(vec2 frag_coord, float depth)`` (passes/lights.glsl):
    the world position at view depth ``depth`` [...] of the pixel; camera_to_world [3, 3]
    (columns right, up, back)."""
    ndc = frag_coord / resolution * 2.0 - 1.0
    d_vs = torch.cat([ndc * tan_half_fov, -torch.ones_like(ndc[..., :1])], dim=-1)
    return torch.as_tensor(camera_position, dtype=torch.float32) + (d_vs @ camera_to_world.T) \
        * depth[..., None]


def _light_arrays(light) -> dict:
    cone = (math.cos(math.radians(light.outer_cone_deg)),
            math.cos(math.radians(light.inner_cone_deg)), light.range or 0.0, 0.0)
    f = torch.float32
    return {"type": torch.tensor(LIGHT_TYPE_IDS[light.type]),
            "position": torch.tensor(light.position, dtype=f),
            "direction": torch.tensor(light.direction, dtype=f),
            "cone_range": torch.tensor(cone, dtype=f),
            "intensity": torch.tensor([c * light.intensity for c in light.color], dtype=f)}


def scene_light(light, i: int, p: torch.Tensor, n: torch.Tensor) -> torch.Tensor:
    """GLSL ``vec4 scene_light(int i, vec3 p, vec3 n)`` for ``light`` (a viewer Light, the i-th
    uniform entry): punctual_light times light_visibility; 0 where n.l <= 0. [..., 4]."""
    a = _light_arrays(light)
    shape = p.shape[:-1]
    la = punctual_light(a["type"].expand(shape), a["position"].expand_as(p),
                        a["direction"].expand_as(p), a["cone_range"].expand(*shape, 4), p)
    facing = (n * la[..., :3]).sum(-1) > 0.0
    w = torch.where(facing, la[..., 3] * light_visibility(i, p, n, la[..., :3]),
                    torch.zeros_like(la[..., 3]))
    return torch.cat([la[..., :3], w[..., None]], -1)


def lights_ggx(lights, diffuse, f0, f90, a, dfg, multiscatter, n, v, p) -> torch.Tensor:
    """GLSL ``vec3 lights_ggx(...)`` (passes/lights.glsl) over ``lights`` (the uniform entries,
    in order): ggx_directional_light per light where its attenuation is > 0. [..., 3]."""
    c = torch.zeros_like(n)
    for i, light in enumerate(lights):
        la = scene_light(light, i, p, n)
        e = _light_arrays(light)["intensity"] * la[..., 3:]
        term = ggx_directional_light(diffuse, f0, f90, a, dfg, multiscatter, n, v, la[..., :3],
                                     e)
        c = c + torch.where(la[..., 3:] > 0.0, term, torch.zeros_like(term))
    return c


def lights_blinn_phong(lights, diffuse, f0, a, n, v, p) -> torch.Tensor:
    """GLSL ``vec3 lights_blinn_phong(...)`` (passes/lights.glsl) over ``lights``. [..., 3]."""
    c = torch.zeros_like(n)
    for i, light in enumerate(lights):
        la = scene_light(light, i, p, n)
        e = _light_arrays(light)["intensity"] * la[..., 3:]
        term = blinn_phong_directional_light(diffuse, f0, a, n, v, la[..., :3], e)
        c = c + torch.where(la[..., 3:] > 0.0, term, torch.zeros_like(term))
    return c


def env_shadow(map_, matrices, dirs, lenses, offsets, p, n, phi) -> torch.Tensor:
    """GLSL ``float env_shadow(GBuffer g, vec3 n)`` (passes/lights.glsl, ENV_SHADOWS) at the
    surface point ``p`` (rebuilt from g's depth: :func:`light_surface_position`): the tiles'
    :func:`~learned.twins.shadow.shadow_tile_visibility` weighted by share x max(n.l, 0);
    ``matrices`` [K, 4, 4] (rows as ``ShadowFrame.matrix``), ``dirs`` [K, 4] (direction, share),
    ``lenses`` [K, 4], ``offsets`` [K]: the uniforms; 1 where no direction lights n."""
    from .shadow import shadow_tile_visibility

    total = torch.zeros(p.shape[:-1])
    seen = torch.zeros(p.shape[:-1])
    for k in range(len(dirs)):
        d = dirs[k]
        w = d[3] * torch.clamp_min((n * d[:3]).sum(-1), 0.0)
        lit = w > 0.0
        v = shadow_tile_visibility(map_, matrices[k], lenses[k], offsets[k], k,
                                   d[:3].expand_as(p), p, n, phi)
        total = total + torch.where(lit, w, torch.zeros_like(w))
        seen = seen + torch.where(lit, w * v, torch.zeros_like(w))
    return torch.where(total > 0.0, seen / torch.where(total > 0.0, total, torch.ones_like(total)),
                       torch.ones_like(total))
