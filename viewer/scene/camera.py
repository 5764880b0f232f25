"""Pinhole camera: world-to-view and projection matrices, per-pixel view rays.

Matrices are numpy ``[4, 4]`` float64 acting on column vectors (``clip = P @ V @ p``); upload with
:func:`gl_bytes`. View space is right-handed, camera looking down -Z, +Y up. Pixel (i, j) with row 0
at the *top* of the image has its centre at ``((j + 0.5) / W, (i + 0.5) / H)``.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np


def _vec3(v) -> tuple[float, float, float]:
    a = tuple(float(x) for x in v)
    if len(a) != 3:
        raise ValueError("expected 3 numbers")
    return a  # type: ignore[return-value]


@dataclass(frozen=True)
class Camera:
    position: tuple[float, float, float] = (0.0, 0.0, 3.0)
    target: tuple[float, float, float] = (0.0, 0.0, 0.0)
    up: tuple[float, float, float] = (0.0, 1.0, 0.0)
    fov_y: float = 40.0  # vertical field of view, degrees
    size: tuple[int, int] = (512, 512)  # (W, H) pixels
    near: float = 0.05
    far: float = 1000.0

    @property
    def width(self) -> int:
        return int(self.size[0])

    @property
    def height(self) -> int:
        return int(self.size[1])

    @property
    def aspect(self) -> float:
        return self.width / self.height

    def with_size(self, width: int, height: int) -> "Camera":
        return replace(self, size=(int(width), int(height)))

    def basis(self) -> np.ndarray:
        """``[3, 3]`` rows: right, up, back (+Z of view space) in world space."""
        pos = np.asarray(self.position, np.float64)
        fwd = np.asarray(self.target, np.float64) - pos
        n = np.linalg.norm(fwd)
        if n < 1e-12:
            raise ValueError("camera position equals target")
        back = -fwd / n
        right = np.cross(np.asarray(self.up, np.float64), back)
        if np.linalg.norm(right) < 1e-9:  # up parallel to the view direction
            right = np.cross(np.array([0.0, 0.0, 1.0]) if abs(back[1]) > 0.9 else
                             np.array([0.0, 1.0, 0.0]), back)
        right /= np.linalg.norm(right)
        up = np.cross(back, right)
        return np.stack([right, up, back])

    def view_matrix(self) -> np.ndarray:
        """World -> view."""
        r = self.basis()
        m = np.eye(4)
        m[:3, :3] = r
        m[:3, 3] = -r @ np.asarray(self.position, np.float64)
        return m

    def projection_matrix(self) -> np.ndarray:
        """View -> clip (OpenGL, depth in [-1, 1])."""
        f = 1.0 / math.tan(math.radians(self.fov_y) / 2.0)
        n, fa = self.near, self.far
        p = np.zeros((4, 4))
        p[0, 0] = f / self.aspect
        p[1, 1] = f
        p[2, 2] = (fa + n) / (n - fa)
        p[2, 3] = 2.0 * fa * n / (n - fa)
        p[3, 2] = -1.0
        return p

    def tan_half_fov(self) -> tuple[float, float]:
        """(tan(fov_x / 2), tan(fov_y / 2))."""
        ty = math.tan(math.radians(self.fov_y) / 2.0)
        return ty * self.aspect, ty

    def view_rays_ws(self) -> np.ndarray:
        """``[H, W, 3]`` float32 unit directions from the camera through each pixel centre, world
        space, row 0 at the top."""
        tx, ty = self.tan_half_fov()
        j = (np.arange(self.width) + 0.5) / self.width * 2.0 - 1.0
        i = 1.0 - (np.arange(self.height) + 0.5) / self.height * 2.0
        x, y = np.meshgrid(j * tx, i * ty)
        d_vs = np.stack([x, y, -np.ones_like(x)], axis=-1)
        d_ws = d_vs @ self.basis()
        return (d_ws / np.linalg.norm(d_ws, axis=-1, keepdims=True)).astype(np.float32)


def gl_bytes(m: np.ndarray) -> bytes:
    """A ``[4, 4]`` (or [3, 3]) matrix as column-major float32 bytes for a GLSL ``mat4`` uniform."""
    return np.ascontiguousarray(np.asarray(m, np.float32).T).tobytes()
