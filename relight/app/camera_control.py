"""Orbit, pan and zoom as pure functions ``Camera -> Camera`` (no GL; unit-testable).

The camera orbits its ``target``: yaw turns about the camera's ``up`` axis through the target,
pitch about the camera's right axis, clamped so the view never flips over the pole. Pan moves
position and target together in the image plane, scaled so a point at the target's depth follows
the mouse. Zoom scales the distance to the target. Mouse deltas are window pixels, +x right, +y
down (glfw/ImGui convention).
"""
from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from viewer.scene.camera import Camera

ORBIT_DEG_PER_PIXEL = 0.3
MAX_PITCH_DEG = 89.0  # from the plane orthogonal to ``up``
MIN_DISTANCE = 1e-3


def _unit(v: np.ndarray) -> np.ndarray:
    return v / np.linalg.norm(v)


def _rotate(v: np.ndarray, axis: np.ndarray, angle_rad: float) -> np.ndarray:
    """Rodrigues' rotation of ``v`` about the unit ``axis`` (right-hand rule)."""
    c, s = math.cos(angle_rad), math.sin(angle_rad)
    return v * c + np.cross(axis, v) * s + axis * float(axis @ v) * (1.0 - c)


def _tuple(v: np.ndarray) -> tuple[float, float, float]:
    return (float(v[0]), float(v[1]), float(v[2]))


def orbit(camera: Camera, yaw_deg: float, pitch_deg: float) -> Camera:
    """Turn the camera about its target: ``yaw_deg`` about ``up`` (positive = the camera moves to
    its right, counter-clockwise seen from above), ``pitch_deg`` upwards (positive = the camera
    rises). The distance to the target is unchanged; pitch stops ``MAX_PITCH_DEG`` from the pole."""
    target = np.asarray(camera.target, np.float64)
    offset = np.asarray(camera.position, np.float64) - target
    up = _unit(np.asarray(camera.up, np.float64))
    offset = _rotate(offset, up, math.radians(yaw_deg))
    dist = float(np.linalg.norm(offset))
    elevation = math.degrees(math.asin(max(-1.0, min(1.0, float(offset @ up) / dist))))
    new_elevation = max(-MAX_PITCH_DEG, min(MAX_PITCH_DEG, elevation + pitch_deg))
    right = np.cross(up, offset)  # horizontal, perpendicular to the offset
    if np.linalg.norm(right) > 1e-12:
        offset = _rotate(offset, _unit(right), -math.radians(new_elevation - elevation))
    return replace(camera, position=_tuple(target + offset))


def pan(camera: Camera, dx_px: float, dy_px: float) -> Camera:
    """Slide the camera and its target in the image plane so that the point under the mouse at
    the target's depth follows a drag of ``(dx_px, dy_px)`` window pixels (the image moves with the
    mouse: the camera moves the other way)."""
    basis = camera.basis()  # rows: right, up, back
    dist = float(np.linalg.norm(np.asarray(camera.position) - np.asarray(camera.target)))
    world_per_px = 2.0 * dist * math.tan(math.radians(camera.fov_y) / 2.0) / camera.height
    move = (-dx_px * basis[0] + dy_px * basis[1]) * world_per_px
    return replace(camera, position=_tuple(np.asarray(camera.position) + move),
                   target=_tuple(np.asarray(camera.target) + move))


def zoom(camera: Camera, factor: float) -> Camera:
    """Scale the distance to the target by ``factor`` (< 1 moves closer)."""
    target = np.asarray(camera.target, np.float64)
    offset = np.asarray(camera.position, np.float64) - target
    dist = float(np.linalg.norm(offset))
    new = max(MIN_DISTANCE, dist * float(factor))
    return replace(camera, position=_tuple(target + offset * (new / dist)))


def wheel_factor(wheel_steps: float) -> float:
    """Zoom factor for mouse-wheel steps (positive = scroll up = closer): 10% per step."""
    return 0.9 ** float(wheel_steps)


def drag_orbit(camera: Camera, dx_px: float, dy_px: float) -> Camera:
    """Orbit for a mouse drag: dragging right turns the scene right (the camera left)."""
    return orbit(camera, -dx_px * ORBIT_DEG_PER_PIXEL, dy_px * ORBIT_DEG_PER_PIXEL)
