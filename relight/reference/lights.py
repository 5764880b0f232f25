"""The scene's punctual lights (``[[lights]]``, ``[light]``, glTF ``KHR_lights_punctual``) as
Mitsuba 3 emitters, in the units the rasteriser shades them with (:mod:`viewer.lighting.lights`,
``shaders/lib/lights.glsl``): a directional light's ``intensity`` is its irradiance on a surface
facing it (W/m^2, the "lux" of the scene file), a point or spot light's its radiant intensity
(W/sr, the "candela"); glTF's photometric numbers are read as these radiometric ones with no
683 lm/W factor, so a Mitsuba ``intensity`` is ``color * intensity`` one to one.

* **directional**, ``angular_diameter_deg`` = 0: Mitsuba's ``directional`` (a delta, irradiance).
* **directional**, diameter 2 alpha > 0 (the sun's 0.53 deg by default): Mitsuba has no distant
  disc light (``directional`` is a delta; ``sunsky`` is an environment, of which a scene holds one,
  and its irradiance is a sky model's). It is traced as a **far disc**: a ``disk`` shape with an
  ``area`` emitter of radiance ``L = E / (pi sin^2 alpha)``, ``FAR`` scene radii away, facing the
  scene, of radius ``D tan alpha``. From a point on its axis it subtends exactly the cap of
  half-angle alpha, and a uniform cap gives irradiance ``int L (n . w) dw = pi L sin^2 alpha (n . c)`` =
  ``E cos theta`` exactly while the cap is above the horizon (the rasteriser's delta light times
  ``cos theta``), and the shadow of a uniform disc: the penumbra the PCSS filter models. Off the
  axis the direction moves by at most (scene radius / D) = 1 / ``FAR`` rad. What differs: the disc
  hides the environment behind it (at most ``E_env`` of that solid angle, 1.5e-2 sr at 8 deg, 6.7e-5
  at 0.53 deg) and a camera ray that meets it sees it (the rasteriser draws no sun disc).
* **point**: Mitsuba's ``point``; irradiance ``I cos theta / d^2``, as ``punctual_light``.
* **spot**: Mitsuba's ``spot`` falls off *linearly in the angle* between ``beam_width`` and
  ``cutoff_angle``; glTF's cone factor is ``t^2`` with ``t`` linear in the *cosine*
  (``spot_cone_factor``). Here the spot's own falloff is switched off (``beam_width`` =
  ``cutoff_angle`` = the outer cone) and glTF's factor is projected through the spot's ``texture``,
  a ``SPOT_TEXELS``^2 bitmap of the factor at each texel's direction, read bilinearly: equal to
  glTF's inside the inner cone (1) and outside the outer one (0), within the bitmap's interpolation
  error between them (measured in tests/reference/test_reference_lights.py).
* **range** (glTF's window, ``light_range_window``): Mitsuba has none; the light is traced without
  it, with a one-line warning.
"""
from __future__ import annotations

import math
import warnings

import numpy as np

from viewer.lighting.lights import Light
from viewer.scene.bounds import Bounds

FAR = 1.0e4        # a directional disc's distance, in scene radii (direction error 1e-4 rad)
SPOT_TEXELS = 512  # the spot cone's projected bitmap, texels a side


def disc_radiance(irradiance: float, angular_diameter_deg: float) -> float:
    """Radiance of a uniform disc of ``angular_diameter_deg`` whose irradiance on a surface
    facing it is ``irradiance``: ``E / (pi sin^2 alpha)`` (module docstring)."""
    s = math.sin(math.radians(angular_diameter_deg) / 2.0)
    return irradiance / (math.pi * s * s)


def spot_cone_factor(cos_angle, cos_outer: float, cos_inner: float):
    """``spot_cone_factor`` of ``shaders/lib/lights.glsl`` in numpy (glTF's cone)."""
    t = np.clip((cos_angle - cos_outer) / max(cos_inner - cos_outer, 1e-3), 0.0, 1.0)
    return t * t


def spot_texture(inner_deg: float, outer_deg: float, texels: int = SPOT_TEXELS) -> np.ndarray:
    """``[texels, texels, 3]`` float32: glTF's cone factor where Mitsuba's ``spot`` looks its
    ``texture`` up. Mitsuba reads uv = 0.5 + 0.5 (x, y) / (z tan cutoff) for the local direction
    (x, y, z) (and bilinear texels centred at (i + 0.5) / n): a texel at uv is the direction
    (2u - 1, 2v - 1) tan cutoff, 1). The factor depends on the angle alone, so the bitmap's axis
    orientation does not matter."""
    c = (np.arange(texels) + 0.5) / texels * 2.0 - 1.0
    x, y = np.meshgrid(c, c)
    tan = math.tan(math.radians(outer_deg))
    cos_angle = 1.0 / np.sqrt(1.0 + (x * x + y * y) * tan * tan)
    f = spot_cone_factor(cos_angle, math.cos(math.radians(outer_deg)),
                         math.cos(math.radians(inner_deg)))
    return np.ascontiguousarray(np.repeat(f[..., None], 3, axis=-1), dtype=np.float32)


def _rgb(value) -> dict:
    return {"type": "rgb", "value": [float(c) for c in value]}


def _up(direction) -> list[float]:
    return [0.0, 1.0, 0.0] if abs(direction[1]) < 0.99 else [1.0, 0.0, 0.0]


def far_disc(light: Light, bounds: Bounds | None, mi) -> dict:
    """A directional light of finite angular size as a far ``disk`` area emitter (module
    docstring), centred on the direction ``light.direction`` from the scene's bounds centre."""
    centre = bounds.center if bounds is not None else np.zeros(3)
    radius = max(bounds.radius if bounds is not None else 1.0, 1e-3)
    dist = FAR * radius
    half = math.radians(light.angular_diameter_deg) / 2.0
    d = np.asarray(light.direction, np.float64)
    origin = centre + dist * d
    scale = 1.0 / (math.pi * math.sin(half) ** 2)  # radiance per unit irradiance
    return {"type": "disk",
            "to_world": mi.ScalarTransform4f().look_at(
                origin=origin.tolist(), target=centre.tolist(), up=_up(light.direction))
            @ mi.ScalarTransform4f().scale([dist * math.tan(half)] * 2 + [1.0]),
            "emitter": {"type": "area", "radiance": _rgb(c * scale for c in light.radiant)},
            # black on its back (it faces the scene) and unseen by the BSDF at the front
            "bsdf": {"type": "diffuse", "reflectance": _rgb((0.0, 0.0, 0.0))}}


def mitsuba_light(light: Light, mi, bounds: Bounds | None = None, where: str = "[[lights]]"
                  ) -> dict:
    """One of our punctual lights as a Mitsuba emitter (or, for a directional light of finite
    size, a shape that emits), module docstring. ``bounds``: the scene's, to place a far disc."""
    if light.type == "directional":
        if light.angular_diameter_deg > 0.0:
            return far_disc(light, bounds, mi)
        return {"type": "directional", "direction": [-c for c in light.direction],
                "irradiance": _rgb(light.radiant)}
    if light.range is not None:
        warnings.warn(f"{where}: a {light.type} light's range = {light.range} (glTF's window) "
                      f"has no path-traced counterpart; the reference traces it without one",
                      stacklevel=2)
    position = [float(c) for c in light.position]
    if light.type == "point":
        return {"type": "point", "position": position, "intensity": _rgb(light.radiant)}
    target = [o - c for o, c in zip(position, light.direction)]  # direction points to the light
    texture = spot_texture(light.inner_cone_deg, light.outer_cone_deg)
    return {"type": "spot", "intensity": _rgb(light.radiant),
            "to_world": mi.ScalarTransform4f().look_at(origin=position, target=target,
                                                       up=_up(light.direction)),
            "cutoff_angle": float(light.outer_cone_deg),
            "beam_width": float(light.outer_cone_deg),
            "texture": {"type": "bitmap", "bitmap": mi.Bitmap(texture), "raw": True,
                        "filter_type": "bilinear", "wrap_mode": "clamp"}}
