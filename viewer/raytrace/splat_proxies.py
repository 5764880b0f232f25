"""Splat clouds as rays see them: every Gaussian as a closed triangle proxy that **bounds** it,
and the Gaussian itself evaluated where a ray enters the proxy.

A splat of opacity alpha blocks the fraction ``alpha exp(-q^2 / 2)`` of the light along a line,
``q`` the smallest Mahalanobis distance of the line's points to its mean (the marginal of a
Gaussian along a direction is its projection's covariance; 3D Gaussian Ray Tracing,
Moenne-Loccoz et al. 2024, evaluates a particle at the same peak). So:

* **shadow rays** (``bvh_transmittance`` in ``passes/raytrace.glsl``) multiply
  ``1 - alpha exp(-q^2 / 2)`` over every splat they pass, ``q`` at the peak along the ray within
  ``[0, t_max]``: a surface tiled with splats is as opaque to them as its splats' overlap makes
  it, where each splat's **opaque core** alone (the line's opacity reaching 0.5,
  ``q <= sqrt(2 ln(2 alpha))``) leaves gaps. Measured on a plane tiled by
  :func:`learned.data.splat_tiling.scene_splats`: 29 % of the rays through it passed between the
  cores (light leaking through a surface: salt on the shadowed side of a splat capture).
* **closest hits** (``bvh_closest_hit``: bounce and reflection rays, what they see) stop where a
  ray enters a splat's opaque core, the ellipsoid itself (solved exactly), so what a ray hits is
  the shadow maps' rule (:mod:`viewer.passes.shadow`: a splat occludes where its projected
  opacity reaches 0.5).

Each proxy is an icosahedron (20 triangles, 12 vertices) around the ellipsoid ``d_M(x) <= r_b``,
``r_b = sqrt(2 ln(alpha / ALPHA_MIN))`` (beyond it a splat blocks less than :data:`ALPHA_MIN` of
a line's light), its vertices at ``mean + R S (r_b / INRADIUS) u`` for the icosahedron's unit
vertices u, so that its faces touch the ellipsoid from outside. A splat fainter than
:data:`ALPHA_MIN` has no proxy. The proxy counts only where a ray **enters** it
(:data:`~viewer.raytrace.scene.ENTERED_ONLY` in the surface row's cutoff): a ray that starts
inside a proxy (a splat surface's own G-buffer points lie inside the proxies of the splats that
make them) leaves it unhindered, as it leaves the surface it starts on, so one entry face counts
each splat once.

What the traversal reads of a splat: four texels of ``u_rt_splats``
(:func:`splat_rows`): the affine map to its unit-Gaussian frame and ``(alpha, r_core^2)``; a
proxy face's first edge texel names its splat (1 + its row:
:attr:`~viewer.raytrace.scene.TraceGeometry.edges`), so no storage buffer is read to find it.

Materials at a secondary hit: the splat's albedo, roughness and metallic, one texel per splat of
a ``base_color`` and a ``metallic_roughness`` map of :data:`~viewer.raytrace.scene.MAP_SIZE`
squared texels (each vertex's TEXCOORD_0 is its splat's texel centre; the factors are 1), so a
cloud becomes one proxy mesh per ``MAP_SIZE^2`` = 65 536 splats, each with its own two map layers.
The normal at every vertex is the splat's (stored, or its shortest axis), double-sided. At most
:data:`MAX_TRACED` splats are traced (the largest first, with a warning naming the cloud).

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

OPAQUE_AT = 0.5  # the shadow maps' opacity threshold (viewer.passes.shadow): the opaque core
# the opacity a splat blocks of a line at its proxy's surface: a ray passing outside a splat's
# proxy leaves out less than this of the light it would block. Measured on a plane the capture
# tiler covered (4000 rays through it, before the faces named their splats): 0.03 % of the rays
# passed at 0.1, none at 1/16 and 1/32, 0.09 % at 0.2; a still frame of the gun's capture took
# 5.7 s at 0.1 against 6.8 s at 1/16 and 4.3 s at 0.2 (the proxies' size is the cost)
ALPHA_MIN = 0.1
# at most this many splats are traced, the largest (proxy volume) first: 100 000 proxies are 2 M
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
# the distance of the unit-circumradius icosahedron's faces from its centre: its vertices at
# r / INRADIUS put its faces tangent to the sphere of radius r from outside
INRADIUS = math.sqrt((5.0 + 2.0 * math.sqrt(5.0)) / 15.0)

@dataclass(kw_only=True)
class ProxyMesh(Mesh):
    """A traced stand-in (never rasterised): counted only where a ray enters it; 12 vertices a
    splat, in the order of ``splat_rows``."""

    entered_only: bool = True
    splat_rows: np.ndarray = None  # [n, 4, 4] float32: splat_rows of its n splats


_PROXIES: "weakref.WeakKeyDictionary[Splats, list[ProxyMesh]]" = weakref.WeakKeyDictionary()


def core_radius(opacities: np.ndarray) -> np.ndarray:
    """The Mahalanobis radius of each splat's opaque core, ``sqrt(2 ln(2 alpha))``; 0 where the
    opacity does not reach :data:`OPAQUE_AT` (no core)."""
    a = np.asarray(opacities, np.float64)
    return np.sqrt(2.0 * np.log(np.maximum(a / OPAQUE_AT, 1.0)))


def bound_radius(opacities: np.ndarray) -> np.ndarray:
    """The Mahalanobis radius of each splat's proxy, ``sqrt(2 ln(alpha / ALPHA_MIN))``, where it
    blocks :data:`ALPHA_MIN` of a line's light; 0 for a splat fainter than that (no proxy)."""
    a = np.asarray(opacities, np.float64)
    return np.sqrt(2.0 * np.log(np.maximum(a / ALPHA_MIN, 1.0)))


def splat_rows(means: np.ndarray, rotations: np.ndarray, scales: np.ndarray,
               opacities: np.ndarray) -> np.ndarray:
    """``[n, 4, 4]`` float32: what ``passes/raytrace.glsl`` reads of each splat. Rows 0-2: the
    affine map ``x -> W x + c`` to the splat's unit-Gaussian frame (``W = S^-1 R^T``, the
    Gaussian there ``exp(-|x'|^2 / 2)``), ``W``'s row i in xyz and ``c_i`` in w; row 3: its
    opacity and its opaque core's squared radius (:func:`core_radius`; 0: no core)."""
    rot = quat_to_matrix(np.asarray(rotations, np.float64))  # [n, 3, 3], columns the axes
    w = np.swapaxes(rot, 1, 2) / np.asarray(scales, np.float64)[:, :, None]
    c = -np.einsum("nij,nj->ni", w, np.asarray(means, np.float64))
    out = np.zeros((len(w), 4, 4), np.float64)
    out[:, :3, :3] = w
    out[:, :3, 3] = c
    out[:, 3, 0] = opacities
    out[:, 3, 1] = core_radius(opacities) ** 2
    return out.astype(np.float32)


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
    r = bound_radius(splats.opacities)
    scales = np.asarray(splats.scales, np.float64)
    keep = np.flatnonzero((r > 0.0) & np.isfinite(splats.means).all(axis=1)
                          & (scales > 0.0).all(axis=1) & np.isfinite(scales).all(axis=1))
    if len(keep) > MAX_TRACED:
        volume = r[keep] ** 3 * scales[keep].prod(axis=1)
        largest = np.sort(keep[np.argsort(-volume, kind="stable")[:MAX_TRACED]])
        warnings.warn(f"{splats.source or 'a splat cloud'}: rays see the {MAX_TRACED:,} largest "
                      f"of its {len(keep):,} splats (the rest cast shadows in the shadow maps "
                      f"only)", stacklevel=4)
        keep = largest
    meshes = []
    for start in range(0, len(keep), PER_MESH):
        ids = keep[start:start + PER_MESH]
        meshes.append(_proxy_mesh(splats, ids, r[ids], len(meshes)))
    return meshes


def _proxy_mesh(splats: Splats, ids: np.ndarray, radius: np.ndarray, part: int) -> ProxyMesh:
    n = len(ids)
    rot = quat_to_matrix(np.asarray(splats.rotations, np.float64)[ids])  # [n, 3, 3]
    m = rot * (np.asarray(splats.scales, np.float64)[ids] * (radius / INRADIUS)[:, None])[
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
    name = f"{splats.source or 'splats'} (splat proxies, part {part + 1})"
    return ProxyMesh(positions=pos.reshape(-1, 3).astype(np.float32),
                     normals=normals.reshape(-1, 3).astype(np.float32),
                     uvs=np.repeat(uv[:, None, :], 12, axis=1).reshape(-1, 2).astype(np.float32),
                     indices=indices.astype(np.uint32),
                     material=Material(albedo=(1.0, 1.0, 1.0), roughness=1.0, metallic=1.0),
                     textures={"base_color": base.reshape(MAP_SIZE, MAP_SIZE, 4),
                               "metallic_roughness": mr.reshape(MAP_SIZE, MAP_SIZE, 4)},
                     double_sided=True, alpha_mode="OPAQUE", name=name, source=splats.source,
                     splat_rows=splat_rows(np.asarray(splats.means, np.float64)[ids],
                                           np.asarray(splats.rotations, np.float64)[ids],
                                           np.asarray(splats.scales, np.float64)[ids],
                                           np.asarray(splats.opacities, np.float64)[ids]))
