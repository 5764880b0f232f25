"""Synthetic splat scenes whose true materials and light are known (for decomposition tests,
benchmarks and examples).

* :func:`sphere_splats` - flat Gaussians tiling a sphere, with smoothly varying albedo, roughness
  and metallic and outward normals (the relightable layout).
* :func:`sky_cubemap` - a 6-face cubemap light: sky gradient plus a warm sun.
* The baked-colour (plain 3DGS) version of a relightable cloud needs the torch shading model:
  it is :func:`learned.splats.decompose.baked`.
* :func:`random_cloud` - N random Gaussians in a box (benchmarks).
"""
from __future__ import annotations

import numpy as np

from .data import Splats, make_splats, matrix_to_quat


def sphere_splats(n: int = 2000, radius: float = 0.8, seed: int = 0) -> Splats:
    """``n`` flat splats on a sphere (Fibonacci lattice), opacity 0.95, normals outward."""
    rng = np.random.default_rng(seed)
    i = np.arange(n) + 0.5
    phi = np.arccos(1 - 2 * i / n)
    theta = np.pi * (1 + 5 ** 0.5) * i
    nrm = np.stack([np.cos(theta) * np.sin(phi), np.cos(phi), np.sin(theta) * np.sin(phi)], -1)
    means = nrm * radius
    spacing = radius * np.sqrt(4 * np.pi / n)
    helper = np.where(np.abs(nrm[:, 1:2]) < 0.9, [[0.0, 1.0, 0.0]], [[1.0, 0.0, 0.0]])
    t1 = np.cross(helper, nrm)
    t1 /= np.linalg.norm(t1, axis=1, keepdims=True)
    t2 = np.cross(nrm, t1)
    rot = np.stack([t1, t2, nrm], axis=-1)  # columns: local x, y, z
    scales = np.stack([np.full(n, 0.7 * spacing), np.full(n, 0.7 * spacing),
                       np.full(n, 0.02 * spacing)], -1)
    x, y, z = means.T / radius
    albedo = np.stack([0.5 + 0.35 * np.sin(3 * x + 1), 0.45 + 0.3 * np.cos(2 * y),
                       0.4 + 0.3 * np.sin(2 * z + x)], -1).clip(0.05, 0.95)
    roughness = (0.55 + 0.3 * np.sin(2 * x + y)).clip(0.2, 0.9)
    metallic = np.where(y > 0.6, 0.8, 0.0) + rng.uniform(0, 0.02, n)
    return make_splats(means, scales, matrix_to_quat(rot), np.full(n, 0.95), albedo=albedo,
                       roughness=roughness, metallic=metallic.clip(0, 1), normals=nrm)


def cube_directions(res: int) -> np.ndarray:
    """``[6, res, res, 3]`` unit directions of texel centres, faces +X, -X, +Y, -Y, +Z, -Z (the
    OpenGL cubemap convention: rows top to bottom)."""
    c = (np.arange(res) + 0.5) / res * 2 - 1
    u, v = np.meshgrid(c, -c)  # u across, v up
    one = np.ones_like(u)
    faces = [np.stack([one, v, -u], -1), np.stack([-one, v, u], -1),
             np.stack([u, one, -v], -1), np.stack([u, -one, v], -1),
             np.stack([u, v, one], -1), np.stack([-u, v, -one], -1)]
    d = np.stack(faces)
    return d / np.linalg.norm(d, axis=-1, keepdims=True)


def cube_solid_angles(res: int) -> np.ndarray:
    """``[6, res, res]`` solid angle of each texel (sums to 4 pi)."""
    c = (np.arange(res) + 0.5) / res * 2 - 1
    u, v = np.meshgrid(c, c)
    area = (2.0 / res) ** 2 / (1 + u * u + v * v) ** 1.5
    return np.broadcast_to(area, (6, res, res)).copy()


def sky_cubemap(res: int = 8, sun=(0.5, 0.7, 0.4), sun_power: float = 4.0,
                tint=(1.0, 0.95, 0.85)) -> np.ndarray:
    """``[6, res, res, 3]`` float32 linear radiance: blue-ish sky, darker ground, a sun lobe."""
    d = cube_directions(res)
    s = np.asarray(sun, np.float64)
    s /= np.linalg.norm(s)
    up = d[..., 1:2]
    sky = np.where(up > 0, 0.35 + 0.25 * up * np.array([0.6, 0.8, 1.0]), 0.15 + 0.05 * up)
    lobe = np.exp(6.0 * ((d @ s) - 1.0))[..., None] * sun_power * np.asarray(tint)
    return (sky + lobe).astype(np.float32)


def random_cloud(n: int, seed: int = 0, sh_degree: int = 1, extent: float = 1.0,
                 scale_range=(0.004, 0.05)) -> Splats:
    """``n`` random Gaussians in [-extent, extent]^3 with random SH (benchmarks)."""
    rng = np.random.default_rng(seed)
    k = (sh_degree + 1) ** 2
    sh = rng.normal(0, 0.2, (n, k, 3)).astype(np.float32)
    sh[:, 0] += rng.uniform(-1.5, 1.5, (n, 3))
    lo, hi = np.log(scale_range[0]), np.log(scale_range[1])
    return make_splats(rng.uniform(-extent, extent, (n, 3)), np.exp(rng.uniform(lo, hi, (n, 3))),
                       rng.normal(size=(n, 4)), rng.uniform(0.1, 1.0, n), sh=sh)
