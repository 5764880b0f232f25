"""Punctual lights: directional, point and spot (the scene file's ``[[lights]]`` and ``[light]``,
glTF ``KHR_lights_punctual``), in world space.

Units (docs/explanation/conventions.md): a directional light's ``intensity`` is its irradiance on a
surface facing it (W/m^2, "lux-like"), a point or spot light's its radiant intensity (W/sr,
"candela-like"); glTF's photometric values are used as these radiometric ones, without the
683 lm/W factor, as the ``[light]`` table always has. A point light at distance d gives irradiance
``color * intensity / d^2`` (times glTF's range window when it has a ``range``), a spot light that
times glTF's cone factor. The GLSL is ``shaders/lib/lights.glsl`` (maths) and
``shaders/passes/lights.glsl`` (uniform arrays, the per-model sums, the shadow hook
``light_visibility``).

The renderer shades the scene's lights plus the lights its mesh objects bring
(:func:`gather_lights`), at most :data:`MAX_LIGHTS` in all.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from ..errors import SceneError

MAX_LIGHTS = 8  # uniform array entries a lighting pass compiles at most (LIGHT_COUNT)
LIGHT_TYPES = ("directional", "point", "spot")
LIGHT_TYPE_IDS = {t: i for i, t in enumerate(LIGHT_TYPES)}  # LIGHT_TYPE_* of lib/lights.glsl
DEFAULT_RADIUS = 0.05  # metres: a point or spot light's size where the scene gives none

@dataclass(frozen=True)
class Light:
    """One punctual light. ``direction`` is a unit vector *towards* the light (a directional
    light's incoming direction; a spot light's axis reversed, from what it lights back to it);
    ``position`` a point or spot light's place. ``inner_cone_deg`` / ``outer_cone_deg``: a spot
    light's cone half-angles (full intensity inside the inner, none outside the outer, glTF's
    falloff between); ``range``: glTF's range window (None: none). ``shadow``: the light casts a
    shadow map when ``[render] shadows`` is on (``light_visibility`` in
    shaders/passes/lights.glsl): a directional light's penumbra follows its
    ``angular_diameter_deg``, a point or spot light's its ``radius`` (glTF's KHR_lights_punctual
    has no size: lights from glTF files get :data:`DEFAULT_RADIUS`)."""

    direction: tuple[float, float, float] = (0.0, 1.0, 0.0)
    color: tuple[float, float, float] = (1.0, 1.0, 1.0)  # linear RGB, >= 0
    intensity: float = 1.0  # W/m^2 (directional) or W/sr (point, spot), >= 0
    type: str = "directional"
    position: tuple[float, float, float] = (0.0, 0.0, 0.0)
    inner_cone_deg: float = 0.0
    outer_cone_deg: float = 45.0
    range: float | None = None
    # a directional light's angular size (the sun's 0.53 deg by default): its shadow's penumbra
    angular_diameter_deg: float = 0.53
    shadow: bool = True  # casts a shadow map (with [render] shadows)
    # a point or spot light's radius in metres (a sphere light): its shadow's penumbra
    radius: float = 0.05

    @property
    def radiant(self) -> tuple[float, float, float]:
        """``color * intensity``: irradiance facing a directional light, W/sr of a point/spot."""
        return tuple(c * self.intensity for c in self.color)

    @property
    def irradiance(self) -> tuple[float, float, float]:
        """A directional light's ``color * intensity`` (its name before point lights existed)."""
        return self.radiant

    @property
    def positional(self) -> bool:
        return self.type != "directional"

    def transformed(self, matrix: np.ndarray) -> "Light":
        """This light moved by a 4x4 ``matrix`` (column vectors): the position as a point, the
        direction as a direction (renormalised); intensity and range are unchanged."""
        m = np.asarray(matrix, np.float64)
        p = m[:3, :3] @ np.asarray(self.position, np.float64) + m[:3, 3]
        d = m[:3, :3] @ np.asarray(self.direction, np.float64)
        n = float(np.linalg.norm(d))
        if not n > 1e-12:
            raise SceneError("a light's transform collapses its direction to zero")
        return replace(self, position=tuple(float(x) for x in p),
                       direction=tuple(float(x) for x in d / n))


DirectionalLight = Light  # the ``[light]`` table's type before [[lights]]; type "directional"


def unit_direction(v: tuple[float, ...]) -> tuple[float, float, float] | None:
    """``v`` normalised, or ``None`` for a (near-)zero vector. A vector already of unit length
    (within 1e-12) is kept as it is, so saving and loading a scene gives back the same floats."""
    norm = math.sqrt(sum(x * x for x in v))
    if not norm > 1e-9 or not math.isfinite(norm):
        return None
    if abs(norm - 1.0) <= 1e-12:
        return (float(v[0]), float(v[1]), float(v[2]))
    return (v[0] / norm, v[1] / norm, v[2] / norm)


def check_count(lights, where: str | None = None) -> None:
    if len(lights) > MAX_LIGHTS:
        raise SceneError(f"{len(lights)} lights; a scene shades at most {MAX_LIGHTS} "
                         f"([[lights]], [light] and the meshes' own lights together)", where=where)


def as_lights(light) -> tuple[Light, ...]:
    """Whatever a caller passes as the lights (None, one :class:`Light`, a sequence) as a tuple."""
    if light is None:
        return ()
    if isinstance(light, Light):
        return (light,)
    return tuple(light)


def shadowing(light, shadows: bool = True) -> tuple[int, ...]:
    """Indices of the lights that cast a shadow map (those with ``shadow`` set), when shadows are
    on (``[render] shadows``): directional lights an orthographic map, spot lights a perspective
    one, point lights a cube map (:mod:`viewer.lighting.shadow_frames`)."""
    if not shadows:
        return ()
    return tuple(i for i, li in enumerate(as_lights(light)) if li.shadow)


def light_defines(light, shadows: bool = False) -> dict[str, int]:
    """The lighting passes' defines for these lights: LIGHT_COUNT, LIGHT_POSITIONAL (the
    surface position is rebuilt from depth only when a point or spot light needs it),
    LIGHT_SHADOWS (some light reads a shadow map: :func:`shadowing`) and, with shadows, the kinds
    of map read (``lib/shadow.glsl``: SHADOW_POSITIONAL for spot or point lights' maps,
    SHADOW_CUBE_MAPS for point lights')."""
    lights = as_lights(light)
    check_count(lights)
    casting = [lights[i].type for i in shadowing(lights, shadows)]
    out = {"LIGHT_COUNT": len(lights),
           "LIGHT_POSITIONAL": int(any(li.positional for li in lights)),
           "LIGHT_SHADOWS": int(bool(casting))}
    if casting:
        out["SHADOW_POSITIONAL"] = int(any(t != "directional" for t in casting))
        out["SHADOW_CUBE_MAPS"] = int("point" in casting)
    return out


def light_uniforms(light) -> dict[str, bytes]:
    """The uniform arrays of ``shaders/passes/lights.glsl`` (raw bytes, one entry per light)."""
    lights = as_lights(light)
    if not lights:
        return {}
    f4 = np.float32
    cone = [(math.cos(math.radians(li.outer_cone_deg)), math.cos(math.radians(li.inner_cone_deg)),
             li.range or 0.0, 0.0) for li in lights]
    return {"u_light_type": np.array([LIGHT_TYPE_IDS[li.type] for li in lights], np.int32).tobytes(),
            "u_light_direction": np.array([li.direction for li in lights], f4).tobytes(),
            "u_light_position": np.array([li.position for li in lights], f4).tobytes(),
            "u_light_intensity": np.array([li.radiant for li in lights], f4).tobytes(),
            "u_light_cone_range": np.array(cone, f4).tobytes(),
            # a directional light's disc for the path tracer (shade_path.frag); 0: a delta
            "u_light_angular_radius": np.array(
                [math.radians(li.angular_diameter_deg) / 2.0 if li.type == "directional" else 0.0
                 for li in lights], f4).tobytes()}


def gather_lights(scene, geometry):
    """``scene`` with its mesh objects' own lights (glTF ``KHR_lights_punctual``, world space
    after the object's transform: ``content.lights``) in ``scene.object_lights``; ``geometry``
    loads an object (``Renderer.geometry``). Idempotent: a scene already gathered is returned."""
    if scene.object_lights is not None:
        return scene
    found: list[Light] = []
    for obj in scene.objects:
        if obj.type == "mesh":
            found.extend(getattr(geometry(obj), "lights", ()))
    check_count(scene.lights + tuple(found), scene.source)
    return replace(scene, object_lights=tuple(found))
