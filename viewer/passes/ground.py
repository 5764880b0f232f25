"""The shadow-catcher ground's uniforms for the lighting passes (``shaders/passes/ground.glsl``).

A scene's catcher is its ``plane`` object with ``catcher = true`` (:func:`scene_catcher`; the
first one; ``relight render ASSET --floor`` makes it). The pass shows, on its pixels, the
environment behind it times the share of the ground's light that reaches it: its shaded radiance
over :func:`unshadowed_radiance`, the radiance the same Lambertian ground would have with nothing
occluding it. That share is 1 where nothing occludes the ground, so the catcher is the bare
environment there; it falls under shadows (maps, the ray-traced tier), screen-space occlusion and
the environment's shadows. The share fades to 1 from :data:`FADE_START` to :data:`FADE_END` of
the plane's half-side, so the catcher's edge is never seen whatever the model's shading.

The unshadowed radiance is exact for ``ggx_split_sum`` and ``blinn_phong`` (the catcher's
material has no specular lobe: albedo / pi x the irradiance at +Y) with the environment and
directional lights; point and spot lights are taken at the catcher's centre; ``unlit`` shows the
albedo, so its catcher is the bare environment. Other models shade the ground their own way: the
fade still hides the edge. The screen-space bounce (``[render] indirect``, which the neural
students turn on) adds nothing to the catcher (:mod:`viewer.passes.ssao` gets its centre too).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

CATCHER_CHANNELS = ("depth", "normal")  # the G-buffer channels the pass finds the catcher by
FADE_START = 0.35  # x the plane's half-side: the shadows show fully within this radius ...
FADE_END = 0.95  # ... and not at all from this one (the plane's edge is at 1)


@dataclass(frozen=True)
class Catcher:
    """What the lighting passes need of a catcher plane: its centre (world), the fade's radii
    (world units) and its albedo (linear RGB)."""

    center: tuple[float, float, float]
    fade_start: float
    fade_end: float
    albedo: tuple[float, float, float]


def scene_catcher(objects) -> Catcher | None:
    """The first ``plane`` object of ``objects`` marked ``catcher``, or None."""
    for obj in objects:
        if obj.type == "plane" and getattr(obj, "catcher", False):
            half = 0.5 * float(min(obj.size))
            albedo = obj.material.albedo if obj.material is not None else (0.8, 0.8, 0.8)
            return Catcher(tuple(float(c) for c in obj.center), FADE_START * half,
                           FADE_END * half, tuple(float(c) for c in albedo))
    return None


def sky_irradiance(ibl, sunless: bool) -> np.ndarray:
    """``[3]`` irradiance at a +Y-facing point from the whole environment (intensity 1): the
    irradiance map's +Y pole (its first row), plus, for the IBL without its compact lights
    (``sunless``: SUN_LIGHT passes), those lights' irradiance on the ground. Read back once per
    IBL (kept on it)."""
    cached = getattr(ibl, "_ground_irradiance", None)
    if cached is None:
        tex = ibl.irradiance
        w, h = tex.size
        rows = np.frombuffer(tex.read(), np.float32).reshape(h, w, tex.components)
        cached = rows[0, :, :3].astype(np.float64).mean(axis=0)
        ibl._ground_irradiance = cached
    e = np.array(cached)
    if sunless:
        for light in getattr(ibl, "lights", ()) or ():
            e += np.asarray(light.irradiance, np.float64) * max(float(light.direction[1]), 0.0)
    return e


def lights_irradiance(lights, at: np.ndarray) -> np.ndarray:
    """``[3]`` irradiance of the scene's punctual lights on a +Y-facing point ``at`` (no shadows;
    spot cones and range windows left out)."""
    e = np.zeros(3)
    for light in lights or ():
        power = np.asarray(light.color, np.float64) * float(light.intensity)
        if light.type == "directional":
            d = np.asarray(light.direction, np.float64)
            e += power * max(d[1] / max(np.linalg.norm(d), 1e-12), 0.0)
        else:
            v = np.asarray(light.position, np.float64) - at
            dist = max(float(np.linalg.norm(v)), 1e-6)
            e += power * max(v[1] / dist, 0.0) / dist ** 2
    return e


def unshadowed_radiance(catcher: Catcher, ibl, environment, lights, model: str,
                        sunless: bool) -> np.ndarray:
    """``[3]`` the catcher's radiance with nothing occluding it (module docstring)."""
    albedo = np.asarray(catcher.albedo, np.float64)
    if model == "unlit":
        return albedo
    e = (sky_irradiance(ibl, sunless) * float(environment.intensity)
         + lights_irradiance(lights, np.asarray(catcher.center, np.float64)))
    return albedo / math.pi * e


def ground_uniforms(catcher: Catcher | None, camera, ibl, environment, lights, model: str,
                    sunless: bool) -> dict[str, tuple[float, ...]]:
    """``u_ground_center`` and ``u_ground_unshadowed`` (passes/ground.glsl); w = 0 without a
    catcher, which leaves every pixel as it was."""
    if catcher is None:
        return {"u_ground_center": ground_center(None, camera),
                "u_ground_unshadowed": (0.0, 0.0, 0.0, 0.0)}
    l0 = unshadowed_radiance(catcher, ibl, environment, lights, model, sunless)
    return {"u_ground_center": ground_center(catcher, camera),
            "u_ground_unshadowed": tuple(float(v) for v in l0) + (float(catcher.fade_start),)}


def ground_center(catcher: Catcher | None, camera) -> tuple[float, ...]:
    """``u_ground_center``: the catcher's centre minus the camera's position, and the fade's end
    radius; zeros without a catcher (what the passes that find its pixels read)."""
    if catcher is None:
        return (0.0, 0.0, 0.0, 0.0)
    rel = np.asarray(catcher.center, np.float64) - np.asarray(camera.position, np.float64)
    return tuple(float(v) for v in rel) + (float(catcher.fade_end),)
