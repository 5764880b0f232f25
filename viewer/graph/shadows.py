"""The frame's shadow passes: one map per shadowing light (``shadow<i>`` into ``shadowmap<i>``)
and for the environment's sun and other compact lights (``shadowsun``, ``shadowenv<k>``); a
directional light's or the sun's map is cascaded (:mod:`viewer.lighting.cascades`) where the scene needs
it, and only then does the camera enter the pass's inputs."""
from __future__ import annotations

import dataclasses
import math

from ..lighting.cascades import MAX_TILE, ShadowCascades, cascade_count, cascade_frames
from ..lighting.lights import as_lights, shadowing
from ..lighting.shadow_frames import (
    EnvShadowFrames,
    ShadowCube,
    cube_frames,
    directional_frame,
    env_shadow_frames,
    spot_frame,
)
from ..models import ShadeVariant
from ..scene.description import Scene
from ..scene.settings import ShadowSettings
from ..specialize import Specialization
from .graph import FrameGraph
from .resources import ShadowMapDesc


def shadow_passes(g: FrameGraph, renderer, scene: Scene, spec: Specialization,
                  camera=None, also: ShadeVariant | None = None) -> dict:
    """One shadow map per shadowing light (``shadow<i>`` into ``shadowmap<i>``: orthographic,
    perspective for a spot light, a cube atlas for a point light) and for the environment's
    analytic sun (``shadowsun``), fitted to the scene's bounds and sized by the shadow budget
    (:func:`budgeted`), and the environment's shadow
    directions' atlas (``shadowenvdirs`` into ``shadowmapenvdirs``, ENV_SHADOWS); only where the
    lighting pass reads them (LIGHT_SHADOWS, SUN_SHADOW, ENV_SHADOWS). Returns light index (or
    ``"sun"``, ``"env<k>"``) -> (resource, frame, light size: angular radius in radians or
    radius in world units, normal offset) for the lighting pass, and ``"envdirs"`` ->
    (resource, :class:`~viewer.lighting.shadow_frames.EnvShadowFrames`, softness, bias); ``camera``: the view
    the cascades follow (None: one map each); ``also``: another program that reads the maps
    (the forward pass of transparent surfaces), whose LIGHT_SHADOWS, SUN_SHADOW, ENV_LIGHTS and
    ENV_SHADOWS add to the lighting pass's."""
    settings = scene.render
    defines = dict(spec.variant.defines)
    for key, value in (also.define_items if also is not None else ()):
        if key in ("LIGHT_SHADOWS", "SUN_SHADOW", "ENV_LIGHTS", "ENV_SHADOWS"):
            defines[key] = max(int(defines.get(key, 0)), int(value))
    if not (defines.get("LIGHT_SHADOWS") or defines.get("SUN_SHADOW")
            or defines.get("ENV_SHADOWS")):
        return {}
    lights = as_lights(scene.light)
    bounds = renderer.bounds(scene)
    if bounds is None:  # an image stack alone: nothing to cast a shadow map from
        return {}
    contents = [(obj, renderer.geometry(obj)) for obj in scene.objects]
    meshes = [m for obj, c in contents if obj.type not in ("gbuffer", "splats") for m in c]
    clouds = [c for obj, c in contents if obj.type == "splats"]
    spass = renderer.resources.shadow_pass()
    # the light maps this frame draws, each at the size the shadow budget leaves it
    lit = shadowing(lights, settings.shadow.enabled) if defines.get("LIGHT_SHADOWS") else ()
    others = renderer.resources.env_lights(scene.environment)[1:] \
        if defines.get("SUN_SHADOW") else []  # the environment's other compact lights
    others = others[:defines.get("ENV_LIGHTS", 0)]
    maps = len(lit) + (1 + len(others) if defines.get("SUN_SHADOW") else 0)
    shadow = budgeted(settings.shadow, maps)
    casters = []  # (light index or "sun", frame, penumbra size: angular or world radius)
    casters += [(i, light_shadow_frame(lights[i], bounds, shadow, camera),
                 lights[i].radius if lights[i].positional
                 else math.radians(lights[i].angular_diameter_deg) / 2.0) for i in lit]
    if defines.get("SUN_SHADOW"):
        sun = renderer.resources.sun(scene.environment)
        # the sun's direction is in the environment's frame: turned by its rotation
        direction = env_to_world(sun.direction, scene.environment.rotation_deg)
        casters.append(("sun", _directional(bounds, direction, shadow, camera),
                        float(sun.angular_radius)))
        # the environment's other compact lights (ENV_LIGHTS): "env<k>", shadowenv<k>
        casters += [(f"env{k}", directional_frame(
                         bounds, env_to_world(li.direction, scene.environment.rotation_deg),
                         int(shadow.size)), float(li.angular_radius))
                    for k, li in enumerate(others)]
    # what casts shadows: the objects without their materials (a material slider keeps the maps)
    shapes = tuple(dataclasses.replace(o, material=None) for o in scene.objects)
    error = float(settings.shadow.lod_error)  # each mesh's level of detail in the maps
    # meshes and clouds are every surface that reads the maps unless an image stack does too
    # (its pixels have no box): a flat mesh hiding none of them is then left out
    flat = not any(obj.type == "gbuffer" for obj in scene.objects)
    out = {}
    if defines.get("ENV_SHADOWS"):  # the environment's shadow directions: one atlas
        frames = _env_frames(renderer, scene, bounds, int(defines["ENV_SHADOWS"]),
                             sunless=bool(defines.get("SUN_LIGHT")))
        name = g.create("shadowmapenvdirs", ShadowMapDesc(frames.resolution, 1,
                                                          max(2, frames.count)), kept=True)

        def draw_env(f, name=name, frames=frames):
            spass.draw(f[name], frames, meshes, clouds, error, flat)
        g.add_pass("shadowenvdirs", draw_env, writes=(name,),
                   inputs={"shapes": shapes, "geometry": renderer.geometry_cache.version,
                           "frame": _frame_key(frames), "lod_error": error})
        out["envdirs"] = (name, frames, settings.shadow.softness, settings.shadow.bias)
    for i, frame, size in casters:
        cube = isinstance(frame, ShadowCube)
        cascaded = isinstance(frame, ShadowCascades)
        name = g.create(f"shadowmap{i}", ShadowMapDesc(frame.resolution, 6 if cube else 1,
                                                       frame.count if cascaded else 1),
                        kept=True)
        inputs = {"shapes": shapes, "geometry": renderer.geometry_cache.version,
                  "frame": _frame_key(frame), "lod_error": error}
        if cascaded:  # the cascades follow the camera (their frames, so the key, already do)
            inputs["camera"] = camera

        def draw(f, name=name, frame=frame):
            spass.draw(f[name], frame, meshes, clouds, error, flat)
        # the light's colour and intensity do not enter: a light slider reuses the map
        g.add_pass(f"shadow{i}", draw, writes=(name,), inputs=inputs)
        out[i] = (name, frame, size * settings.shadow.softness,
                  frame.texel_world * settings.shadow.bias)
    return out


def budgeted(shadow: ShadowSettings, maps: int) -> ShadowSettings:
    """``shadow`` with the sizes each of a frame's ``maps`` light maps gets (its lights', the
    environment's sun's and other compact lights'; the environment's shadow directions have an
    atlas of their own): where there are more maps than ``shadow.budget``, every map's side and
    cube face shrinks by sqrt(budget / maps), down to a multiple of 16 texels (at least 64, or
    32 for a cube face, or the set size where that is smaller), so that together they hold
    about ``budget`` maps' texels: four lights under the default budget of one map get maps of
    half the side. A shadow pass on a software rasteriser costs about its map's texels, and a
    budget is how a shadow atlas shares its texels among lights (Unity's). Unchanged for
    ``budget`` 0 (no limit) or ``maps <= budget``."""
    budget = float(shadow.budget)
    if budget <= 0.0 or maps <= budget:
        return shadow
    scale = math.sqrt(budget / maps)

    def side(n: int, least: int) -> int:
        return max(min(int(n), least), int(n * scale) // 16 * 16)
    return dataclasses.replace(shadow, size=side(shadow.size, 64),
                               cube_size=side(shadow.cube_size, 32))


def env_shadow_tile(size: int) -> int:
    """Texels a side of each tile of the environment's shadow atlas: a quarter of the lights'
    maps (``shadow_size``; the broad lights' penumbrae are wide), 64 to 1024."""
    return max(64, min(1024, int(size) // 4))


def _env_frames(renderer, scene: Scene, bounds, count: int, sunless: bool) -> EnvShadowFrames:
    """The environment's ``count`` shadow directions (:func:`viewer.environment.sampling.median_cut` of
    the light its irradiance map holds: without its compact lights where ``sunless``), turned
    by its rotation, each a frame fitted to ``bounds``."""
    env = scene.environment
    dirs, shares, radii = renderer.resources.env_shadow_lights(env, count, sunless)
    world = [env_to_world(d, env.rotation_deg) for d in dirs]
    return env_shadow_frames(bounds, world, shares, radii,
                             env_shadow_tile(scene.render.shadow.size))


def cascade_variant(variant: ShadeVariant, shadows: dict) -> ShadeVariant:
    """The lighting pass's ``variant`` with LIGHT_CASCADES / SUN_CASCADES set where a light's /
    the sun's map in ``shadows`` (:func:`shadow_passes`) is cascaded; unchanged otherwise."""
    extra = {}
    for i, (_, frame, _, _) in shadows.items():
        if isinstance(frame, ShadowCascades):
            extra["SUN_CASCADES" if i == "sun" else "LIGHT_CASCADES"] = 1
    if not extra:
        return variant
    return variant.with_defines(extra)


def _directional(bounds, direction, shadow, camera):
    """A directional light's frame: one map fitted to ``bounds``, or its cascades over what
    ``camera`` sees where :func:`viewer.lighting.cascades.cascade_count` asks for more than one."""
    count = cascade_count(shadow.cascades, bounds, camera, int(shadow.size), direction) \
        if camera is not None else 1
    if count > 1:  # tiles of at most MAX_TILE texels: the atlas is 2 tiles wide
        return cascade_frames(bounds, direction, camera, count, min(int(shadow.size), MAX_TILE))
    return directional_frame(bounds, direction, int(shadow.size))


def light_shadow_frame(light, bounds, shadow, camera=None):
    """The shadow frame of ``light`` fitted to ``bounds`` (``shadow``: the render settings'
    :class:`~viewer.scene.settings.ShadowSettings`): orthographic (cascaded over what ``camera``
    sees where the scene needs it), perspective (spot) or a cube (point)."""
    if light.type == "spot":
        return spot_frame(bounds, light.position, light.direction, light.outer_cone_deg,
                          int(shadow.size))
    if light.type == "point":
        return cube_frames(bounds, light.position, int(shadow.cube_size))
    return _directional(bounds, light.direction, shadow, camera)


def _frame_key(frame) -> tuple:
    """What a shadow map's contents depend on besides the shapes: its frame's numbers."""
    faces = getattr(frame, "faces", (frame,))
    return tuple((f.matrix.tobytes(), f.resolution, f.near, f.depth_range) for f in faces)


def env_to_world(direction, rotation_deg: float) -> tuple[float, float, float]:
    """A direction of the environment's frame in world space (``rotate_y`` of
    ``lib/equirect.glsl`` by the environment's rotation)."""
    a = math.radians(rotation_deg)
    c, s = math.cos(a), math.sin(a)
    x, y, z = (float(v) for v in direction)
    return (c * x + s * z, y, -s * x + c * z)
