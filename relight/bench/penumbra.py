"""Penumbra against truth: the width of a soft shadow's edge in a render and in the path tracer.

A Lambertian sphere (radius 0.5, centre 2.5 m up) above a floor, lit by one directional light
30 deg from the zenith with angular diameter ``diameter_deg``, no environment; the camera looks
straight down at the shadow's far edge (away from the sphere), framing ``VIEW`` m of floor, so
image rows run along world x through the shadow's centre line. A uniform disc source occluded by
a straight edge lights the floor by the fraction of the disc left uncovered (a circular-segment
area), which falls from 90 % to 10 % over ``0.687`` of the penumbra's full width
``D tan(2 alpha) / cos(theta)`` (``D`` the occluder's distance to the floor along the light).

:func:`visibility_profile` divides the middle rows' radiance by the unshadowed closed form
(albedo / pi x E cos theta) and averages ``ROWS`` rows (the edge is straight to within a tenth of
a pixel over them); :func:`transition_width` finds where the profile crosses 10 % and 90 % (linear
interpolation between pixels) and returns their distance in pixels.
"""
from __future__ import annotations

import math

import numpy as np

from viewer.scene.description import Scene, scene_from_dict

ALBEDO = 0.6
THETA_DEG = 30.0       # the light's angle from the zenith
CENTRE_Y = 2.5         # the sphere's centre above the floor
RADIUS = 0.5
VIEW = 1.2             # m of floor across the frame
ROWS = 7               # rows averaged around the image's middle
IRRADIANCE = 3.0


def shadow_edge_x() -> float:
    """World x where the sphere's shadow (umbra centre line, z = 0) ends away from the sphere."""
    t = math.radians(THETA_DEG)
    # the shadow of the sphere's centre, then its far side: the ellipse's semi-axis r / cos(theta)
    return -CENTRE_Y * math.tan(t) - RADIUS / math.cos(t)


def penumbra_scene(diameter_deg: float, size: int = 128, shadow_size: int = 2048) -> Scene:
    """The scene of the module docstring, ``size``^2 pixels, with shadows on."""
    t = math.radians(THETA_DEG)
    x = shadow_edge_x()
    height = 4.0
    fov = 2.0 * math.degrees(math.atan(VIEW / 2.0 / height))
    return scene_from_dict({
        "camera": {"position": [x, height, 1e-4], "target": [x, 0.0, 0.0], "fov_y": fov,
                   "size": [size, size]},
        "environment": {"procedural": "white", "width": 64, "intensity": 0.0},
        "render": {"multiscatter": False, "ao": False, "tonemap": "none",
                   "background": "transparent", "shadows": True, "shadow_size": shadow_size},
        "objects": [
            {"type": "sphere", "center": [0.0, CENTRE_Y, 0.0], "radius": RADIUS,
             "material": {"albedo": [ALBEDO] * 3, "specular": 0.0}},
            {"type": "plane", "center": [0.0, 0.0, 0.0], "size": [6.0, 6.0],
             "material": {"albedo": [ALBEDO] * 3, "specular": 0.0}}],
        "lights": [{"type": "directional", "direction": [math.sin(t), math.cos(t), 0.0],
                    "intensity": IRRADIANCE, "angular_diameter_deg": diameter_deg}]})


def expected_width_px(diameter_deg: float, size: int = 128) -> float:
    """The 10-90 % width of a uniform disc's penumbra at the shadow's far edge, in pixels (module
    docstring): ``0.687 x D tan(2 alpha) / cos(theta)`` with ``D`` the distance along the light from
    the silhouette's far point to the floor."""
    t = math.radians(THETA_DEG)
    # the silhouette point that casts the far edge: the sphere's point whose normal is (-cos t,
    # sin t, 0) (perpendicular to the light in the x-y plane), at height CENTRE_Y + r sin t
    dist = (CENTRE_Y + RADIUS * math.sin(t)) / math.cos(t)
    full = dist * 2.0 * math.tan(math.radians(diameter_deg) / 2.0) / math.cos(t)
    return 0.687 * full * size / VIEW


def visibility_profile(image: np.ndarray) -> np.ndarray:
    """``[W]``: the fraction of the light reaching the floor along the middle rows of ``image``
    (``[H, W, >=3]`` linear radiance of :func:`penumbra_scene`), ``ROWS`` rows averaged."""
    h = image.shape[0]
    rows = image[h // 2 - ROWS // 2: h // 2 + ROWS // 2 + 1, :, :3].astype(np.float64)
    unshadowed = ALBEDO / math.pi * IRRADIANCE * math.cos(math.radians(THETA_DEG))
    return rows.mean(axis=(0, 2)) / unshadowed


def transition_width(profile: np.ndarray, lo: float = 0.1, hi: float = 0.9) -> float:
    """Pixels between the profile's first crossings of ``lo`` and ``hi`` (linear interpolation)
    on its rising edge (shadow to light, in either direction along the row); NaN when it does not
    cross both."""
    p = np.asarray(profile, np.float64)
    if p[0] > p[-1]:
        p = p[::-1]

    def crossing(level: float) -> float:
        above = np.nonzero(p >= level)[0]
        if len(above) == 0 or above[0] == 0:
            return math.nan
        i = above[0]
        return i - 1 + (level - p[i - 1]) / (p[i] - p[i - 1])

    return crossing(hi) - crossing(lo)


def transition_width_noise(profile: np.ndarray, profile_stderr: np.ndarray,
                           lo: float = 0.1, hi: float = 0.9) -> float:
    """One standard error of :func:`transition_width` from the profile's own per-pixel standard
    errors (``profile_stderr``, the same shape): each crossing moves by the profile's error there
    over its slope there, and the two crossings' errors add in quadrature."""
    p = np.asarray(profile, np.float64)
    e = np.asarray(profile_stderr, np.float64)
    if p[0] > p[-1]:
        p, e = p[::-1], e[::-1]
    var = 0.0
    for level in (lo, hi):
        above = np.nonzero(p >= level)[0]
        if len(above) == 0 or above[0] == 0:
            return math.nan
        i = above[0]
        slope = max(p[i] - p[i - 1], 1e-6)
        var += (0.5 * (e[i] + e[i - 1]) / slope) ** 2
    return math.sqrt(var)


def profile_stderr(stderr: np.ndarray) -> np.ndarray:
    """``[W]``: the standard error of :func:`visibility_profile` from a reference's per-pixel
    standard errors (``[H, W, 3]``; pixels independent, channels equal on a grey scene)."""
    h = stderr.shape[0]
    rows = stderr[h // 2 - ROWS // 2: h // 2 + ROWS // 2 + 1, :, 0].astype(np.float64)
    unshadowed = ALBEDO / math.pi * IRRADIANCE * math.cos(math.radians(THETA_DEG))
    return np.sqrt((rows ** 2).sum(axis=0)) / rows.shape[0] / unshadowed


def pcss_bias_bound(diameter_deg: float, shadow_size: int = 2048) -> float:
    """The largest relative widening PCSS's blocker average can give the far edge's penumbra here.

    ``shadow_visibility`` (shaders/lib/shadow.glsl) searches blockers within
    ``s = z depth_range tan(alpha)`` of the receiver (``z`` its depth in the map fitted to the
    scene's bounds) and widens the penumbra with the receiver's distance to their *mean* depth.
    A sphere's front surface at ``r - s`` from its centre (in the map plane) is
    ``sqrt(2 r s - s^2)`` nearer the light than its silhouette, so no mean lies farther in front of
    the silhouette than that: the width is at most that over ``D`` (the silhouette's distance to
    the floor) too wide, and never narrower from this cause."""
    from viewer.lighting.shadow_frames import directional_frame
    from viewer.scene.bounds import Bounds

    t = math.radians(THETA_DEG)
    light = np.array([math.sin(t), math.cos(t), 0.0])
    bounds = Bounds((-3.0, 0.0, -3.0), (3.0, CENTRE_Y + RADIUS, 3.0))  # the 6 m floor, the sphere
    frame = directional_frame(bounds, light, shadow_size)
    z = float(frame.project(np.array([[shadow_edge_x(), 0.0, 0.0]]))[0, 2])
    s = min(z * frame.depth_range * math.tan(math.radians(diameter_deg) / 2.0), RADIUS)
    dist = (CENTRE_Y + RADIUS * math.sin(t)) / math.cos(t)
    return math.sqrt(2.0 * RADIUS * s - s * s) / dist
