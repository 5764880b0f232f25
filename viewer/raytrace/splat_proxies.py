"""Splat clouds as rays see them: every Gaussian's **opaque core** as a closed triangle proxy.

The shadow maps' rule (:mod:`viewer.passes.shadow`) decides what of a splat occludes: a light ray
is blocked where the splat's projected opacity ``alpha exp(-q^2 / 2)`` reaches 0.5. Along a line
with direction d, the projected Gaussian's Mahalanobis distance ``q`` of the line equals the
smallest 3D Mahalanobis distance of the line's points to the mean (the marginal of a Gaussian
along d is the projection's covariance), so the blocked rays are exactly the rays through the
ellipsoid ``d_M(x) <= r = sqrt(2 ln(2 alpha))``: a splat of opacity alpha > 0.5 occludes within
its core, one of alpha <= 0.5 nowhere. Rays and shadow maps agree on what a splat casts.

Each core is an icosahedron (20 triangles, 12 vertices) through ``mean + R S (k r u)`` for the
icosahedron's unit vertices u, with ``k`` = 1.1821 making its volume the ellipsoid's: the proxy's
surface lies within -6 % (a face's centre, at the inradius 0.939) and +18 % (a vertex) of the
core's radius along any direction. The proxy is marked **solid only where a ray enters it**
(:data:`~viewer.raytrace.scene.ENTERED_ONLY` in the surface row's cutoff, ``rt_solid`` in ``passes/raytrace.glsl``): a
ray that starts inside a core (the splat surface's own G-buffer points lie inside the cores that
make them) leaves it unhindered, as it leaves the surface it starts on.

Materials at a secondary hit: the splat's albedo, roughness and metallic, one texel per splat of
a ``base_color`` and a ``metallic_roughness`` map of :data:`~viewer.raytrace.scene.MAP_SIZE`
squared texels (each vertex's TEXCOORD_0 is its splat's texel centre; the factors are 1), so a
cloud becomes one proxy mesh per ``MAP_SIZE^2`` = 65 536 splats, each with its own two map layers.
The normal at every vertex is the splat's (stored, or its shortest axis), double-sided. At most
:data:`MAX_TRACED` cores are traced (the largest first, with a warning naming the cloud).

Proxies are made once per cloud and kept while the cloud lives (a weak map keyed by the
:class:`~viewer.splats.data.Splats` object, which the bounded geometry cache owns), so the traced
scene's cache key, the proxies' identities, is stable from frame to frame.
"""
from __future__ import annotations

import math
import warnings
import weakref
from dataclasses import dataclass

import numpy as np

from ..geometry.mesh import Mesh
from ..scene.material import Material
from ..splats.data import Splats, min_axis, quat_to_matrix
from .scene import MAP_SIZE

OPAQUE_AT = 0.5  # the shadow maps' opacity threshold (viewer.passes.shadow)
# at most this many cores are traced, the largest (core volume) first: 100 000 cores are 2 M
# triangles, about 240 MB of traced scene (within the renderer's 256 MB raytrace budget) and a
# 9.4 s BVH build on the 2-core CI machine; a larger cloud's smaller splats are left to the
# shadow maps, with a warning
MAX_TRACED = 100_000
PER_MESH = MAP_SIZE * MAP_SIZE

_PHI = (1.0 + math.sqrt(5.0)) / 2.0
_ICO = np.array([(-1, _PHI, 0), (1, _PHI, 0), (-1, -_PHI, 0), (1, -_PHI, 0),
                 (0, -1, _PHI), (0, 1, _PHI), (0, -1, -_PHI), (0, 1, -_PHI),
                 (_PHI, 0, -1), (_PHI, 0, 1), (-_PHI, 0, -1), (-_PHI, 0, 1)], np.float64)
ICO_VERTICES = _ICO / np.linalg.norm(_ICO, axis=1, keepdims=True)  # unit circumradius
ICO_FACES = np.array([(0, 11, 5), (0, 5, 1), (0, 1, 7), (0, 7, 10), (0, 10, 11), (1, 5, 9),
                      (5, 11, 4), (11, 10, 2), (10, 7, 6), (7, 1, 8), (3, 9, 4), (3, 4, 2),
                      (3, 2, 6), (3, 6, 8), (3, 8, 9), (4, 9, 5), (2, 4, 11), (6, 2, 10),
                      (8, 6, 7), (9, 8, 1)], np.int64)  # counter-clockwise seen from outside
# circumradius giving the icosahedron the unit sphere's volume: V = (5/12)(3 + sqrt 5) a^3 with
# edge a = R / sin(2 pi / 5)
VOLUME_SCALE = (4.0 * math.pi / 3.0
                / (5.0 / 12.0 * (3.0 + math.sqrt(5.0)) / math.sin(2.0 * math.pi / 5.0) ** 3)
                ) ** (1.0 / 3.0)

@dataclass(kw_only=True)
class ProxyMesh(Mesh):
    """A traced stand-in (never rasterised): solid only where a ray enters it."""

    entered_only: bool = True


_PROXIES: "weakref.WeakKeyDictionary[Splats, list[ProxyMesh]]" = weakref.WeakKeyDictionary()


def core_radius(opacities: np.ndarray) -> np.ndarray:
    """The Mahalanobis radius of each splat's opaque core, ``sqrt(2 ln(2 alpha))``; 0 where the
    opacity does not reach :data:`OPAQUE_AT` (no core)."""
    a = np.asarray(opacities, np.float64)
    return np.sqrt(2.0 * np.log(np.maximum(a / OPAQUE_AT, 1.0)))


def splat_proxies(splats: Splats) -> list[ProxyMesh]:
    """The traced proxy meshes of ``splats`` (module docstring), made once per cloud."""
    found = _PROXIES.get(splats)
    if found is None:
        found = _build(splats)
        _PROXIES[splats] = found
    return found


def _splat_normals(normals: np.ndarray, rotations: np.ndarray,
                   scales: np.ndarray) -> np.ndarray:
    """Each splat's unit normal: the stored one, or (zero stored) its shortest axis."""
    n = np.asarray(normals, np.float64)
    length = np.linalg.norm(n, axis=1)
    stored = length > 1e-12
    return np.where(stored[:, None], n / np.where(stored, length, 1.0)[:, None],
                    min_axis(np.asarray(rotations, np.float64), scales))


def _build(splats: Splats) -> list[ProxyMesh]:
    r = core_radius(splats.opacities)
    scales = np.asarray(splats.scales, np.float64)
    keep = np.flatnonzero((r > 0.0) & np.isfinite(splats.means).all(axis=1)
                          & (scales > 0.0).all(axis=1) & np.isfinite(scales).all(axis=1))
    if len(keep) > MAX_TRACED:
        volume = r[keep] ** 3 * scales[keep].prod(axis=1)
        largest = np.sort(keep[np.argsort(-volume, kind="stable")[:MAX_TRACED]])
        warnings.warn(f"{splats.source or 'a splat cloud'}: rays see the {MAX_TRACED:,} largest "
                      f"of its {len(keep):,} opaque splats (the rest cast shadows in the shadow "
                      f"maps only)", stacklevel=4)
        keep = largest
    meshes = []
    for start in range(0, len(keep), PER_MESH):
        ids = keep[start:start + PER_MESH]
        meshes.append(_proxy_mesh(splats, ids, r[ids], len(meshes)))
    return meshes


def _proxy_mesh(splats: Splats, ids: np.ndarray, radius: np.ndarray, part: int) -> ProxyMesh:
    n = len(ids)
    rot = quat_to_matrix(np.asarray(splats.rotations, np.float64)[ids])  # [n, 3, 3]
    m = rot * (np.asarray(splats.scales, np.float64)[ids] * (radius * VOLUME_SCALE)[:, None])[
        :, None, :]
    pos = (np.asarray(splats.means, np.float64)[ids, None, :]
           + np.einsum("nij,vj->nvi", m, ICO_VERTICES))  # [n, 12, 3]
    normals = np.repeat(_splat_normals(splats.normals[ids], splats.rotations[ids],
                                       splats.scales[ids])[:, None, :], 12, axis=1)
    texel = np.arange(n)
    uv = np.stack([(texel % MAP_SIZE + 0.5) / MAP_SIZE, (texel // MAP_SIZE + 0.5) / MAP_SIZE], 1)
    base = np.zeros((PER_MESH, 4), np.float32)
    base[:, 3] = 1.0
    base[:n, :3] = np.clip(np.asarray(splats.albedo, np.float32)[ids], 0.0, 1.0)
    mr = np.zeros((PER_MESH, 4), np.float32)
    mr[:, 3] = 1.0
    mr[:n, 1] = np.clip(np.asarray(splats.roughness, np.float32)[ids], 0.0, 1.0)
    mr[:n, 2] = np.clip(np.asarray(splats.metallic, np.float32)[ids], 0.0, 1.0)
    indices = (np.arange(n, dtype=np.int64)[:, None, None] * 12 + ICO_FACES[None]).reshape(-1, 3)
    name = f"{splats.source or 'splats'} (opaque cores, part {part + 1})"
    return ProxyMesh(positions=pos.reshape(-1, 3).astype(np.float32),
                     normals=normals.reshape(-1, 3).astype(np.float32),
                     uvs=np.repeat(uv[:, None, :], 12, axis=1).reshape(-1, 2).astype(np.float32),
                     indices=indices.astype(np.uint32),
                     material=Material(albedo=(1.0, 1.0, 1.0), roughness=1.0, metallic=1.0),
                     textures={"base_color": base.reshape(MAP_SIZE, MAP_SIZE, 4),
                               "metallic_roughness": mr.reshape(MAP_SIZE, MAP_SIZE, 4)},
                     double_sided=True, alpha_mode="OPAQUE", name=name, source=splats.source)
