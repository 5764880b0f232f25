"""Analytic test geometry: spheres, planes and the material-ball grid.

Everything is tessellated in world space with analytic normals and glTF-convention UVs (v = 0 at
the top of a texture), plus analytic tangents (w = +1), so normal maps work on primitives too.
"""
from __future__ import annotations

import numpy as np

from ..scene.material import Material
from .mesh import Mesh


def sphere(center=(0.0, 0.0, 0.0), radius: float = 1.0, material: Material = Material(),
           segments: int = 192, rings: int = 96) -> Mesh:
    """A UV sphere with analytic normals (smooth silhouette and shading at 1024^2 by default).

    ``segments`` columns around +Y, ``rings`` rows from the north pole (+Y, v = 0) to the south
    pole (v = 1). The seam (u = 0 = 1) is duplicated and lies at the back (-Z); u = 0.5 faces +Z.
    Each pole has one vertex per column with the exact pole normal, and the degenerate triangle of
    each pole quad is dropped, so no normal is NaN and no triangle has zero area.
    """
    if segments < 3 or rings < 2:
        raise ValueError("a sphere needs segments >= 3 and rings >= 2")
    if radius <= 0:
        raise ValueError("sphere radius must be positive")
    i = np.arange(rings + 1, dtype=np.float64)
    j = np.arange(segments + 1, dtype=np.float64)
    theta = np.pi * i / rings  # polar angle from +Y
    u = j / segments
    uu, vv = np.meshgrid(u, i / rings)  # [rings + 1, segments + 1]
    # Pole vertices take the column's centre u so texture lookups there are not skewed.
    uu[0, :-1] += 0.5 / segments
    uu[-1, :-1] += 0.5 / segments
    phi = 2.0 * np.pi * j / segments
    st, ct = np.sin(theta)[:, None], np.cos(theta)[:, None]
    sp, cp = np.sin(phi)[None, :], np.cos(phi)[None, :]
    n = np.stack(np.broadcast_arrays(-st * sp, ct * np.ones_like(sp), -st * cp), axis=-1)
    n[0] = (0.0, 1.0, 0.0)  # exact poles: sin(pi) is not exactly 0
    n[-1] = (0.0, -1.0, 0.0)
    # d(position)/du direction; independent of theta, so defined at the poles as well.
    t = np.stack(np.broadcast_arrays(-cp, np.zeros_like(cp), sp), axis=-1)
    t = np.broadcast_to(t, n.shape)
    normals = n.reshape(-1, 3)
    positions = np.asarray(center, np.float64) + float(radius) * normals
    tangents = np.concatenate([t.reshape(-1, 3), np.ones((normals.shape[0], 1))], axis=1)
    uvs = np.stack([uu.ravel(), vv.ravel()], axis=1)

    cols = segments + 1
    r, c = np.meshgrid(np.arange(rings), np.arange(segments), indexing="ij")
    v00 = r * cols + c
    v01 = v00 + 1
    v10 = v00 + cols
    v11 = v10 + 1
    # Counter-clockwise seen from outside: a = (v00, v10, v11), b = (v00, v11, v01). In the top
    # row b is degenerate (v00 and v01 are both the north pole), in the bottom row a is.
    a = np.stack([v00, v10, v11], axis=-1)[:-1]
    b = np.stack([v00, v11, v01], axis=-1)[1:]
    tris = [a, b]
    indices = np.concatenate([x.reshape(-1, 3) for x in tris]).astype(np.uint32)
    return Mesh(positions=positions.astype(np.float32), normals=normals.astype(np.float32),
                uvs=uvs.astype(np.float32), tangents=tangents.astype(np.float32),
                indices=indices, material=material, name="sphere")


def plane(center=(0.0, 0.0, 0.0), size=(2.0, 2.0), normal=(0.0, 1.0, 0.0),
          material: Material = Material(), subdivisions: int = 1) -> Mesh:
    """A flat rectangle of ``size = (width, depth)`` facing ``normal``, with UVs in [0, 1].

    For the default normal +Y the width runs along +X (u) and the depth along +Z (v increases
    towards +Z, so the texture's top edge is at -Z). For a normal near +-Z the width runs along
    +X and v increases along -Y (a wall facing the default camera shows textures upright).
    """
    nrm = np.asarray(normal, np.float64)
    if nrm.shape != (3,) or np.linalg.norm(nrm) < 1e-12:
        raise ValueError("plane normal must be a non-zero 3-vector")
    nrm = nrm / np.linalg.norm(nrm)
    t = np.cross(nrm, (0.0, 0.0, 1.0))
    if np.linalg.norm(t) < 1e-6:
        t = np.cross((0.0, 1.0, 0.0), nrm)
    t /= np.linalg.norm(t)
    b = np.cross(t, nrm)  # direction of increasing v
    k = max(1, int(subdivisions))
    s = np.linspace(0.0, 1.0, k + 1)
    uu, vv = np.meshgrid(s, s)  # rows: v
    w, d = float(size[0]), float(size[1])
    pos = (np.asarray(center, np.float64) + ((uu - 0.5) * w)[..., None] * t
           + ((vv - 0.5) * d)[..., None] * b).reshape(-1, 3)
    count = pos.shape[0]
    r, c = np.meshgrid(np.arange(k), np.arange(k), indexing="ij")
    v00 = r * (k + 1) + c
    v01, v10 = v00 + 1, v00 + k + 1
    v11 = v10 + 1
    # Counter-clockwise seen from the normal side ((t, b, n) is left-handed: b = t x n).
    indices = np.concatenate([np.stack([v00, v10, v11], -1).reshape(-1, 3),
                              np.stack([v00, v11, v01], -1).reshape(-1, 3)]).astype(np.uint32)
    return Mesh(positions=pos.astype(np.float32),
                normals=np.tile(nrm, (count, 1)).astype(np.float32),
                uvs=np.stack([uu.ravel(), vv.ravel()], 1).astype(np.float32),
                tangents=np.tile(np.append(t, 1.0), (count, 1)).astype(np.float32),
                indices=indices, material=material, name="plane")


def material_ball_grid(rows: int = 3, cols: int = 5, spacing: float = 2.2, radius: float = 0.9,
                       albedo=(0.8, 0.8, 0.8), center=(0.0, 0.0, 0.0), segments: int = 96,
                       rings: int = 48) -> list[Mesh]:
    """``rows x cols`` spheres in the plane z = center.z, facing +Z, row-major from the top left.

    Columns sweep perceptual roughness from 0 (left) to 1 (right); rows sweep metallic from 0
    (top row) to 1 (bottom row). A single column has roughness 0.5, a single row metallic 0.
    All balls share ``albedo`` and the default specular 0.5.
    """
    balls = []
    cx, cy, cz = (float(x) for x in center)
    for r in range(rows):
        metallic = r / (rows - 1) if rows > 1 else 0.0
        for c in range(cols):
            roughness = c / (cols - 1) if cols > 1 else 0.5
            mat = Material(albedo=tuple(float(a) for a in albedo), roughness=roughness,
                           metallic=metallic)
            pos = (cx + (c - (cols - 1) / 2.0) * spacing, cy + ((rows - 1) / 2.0 - r) * spacing, cz)
            ball = sphere(pos, radius, mat, segments=segments, rings=rings)
            ball.name = f"ball r{r} c{c}"
            balls.append(ball)
    return balls
