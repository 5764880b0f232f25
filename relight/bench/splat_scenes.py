"""Splat clouds made from mesh scenes with known materials, and their colours as a capture sees
them (the inputs of the ``splat_decomp`` suite, :mod:`relight.bench.splat_decomp`).

* :data:`DECOMP_SCENES` - spheres of different materials on a bounded floor, as
  :class:`~viewer.scene.description.Scene` objects (analytic spheres and a plane, so the path tracer and the
  splats see the same surfaces).
* :func:`surface_splats` - flat Gaussians tiling every sphere (Fibonacci lattice) and the floor
  (a square grid), each with its surface's true albedo, roughness, metallic and normal.
* :func:`bake_traced` - each splat's baked colour: the outgoing radiance of its surface point,
  path-traced with Mitsuba 3 and our BSDF (:mod:`relight.reference`) in ``directions`` directions
  over its hemisphere - light from the environment *with* shadowing and inter-reflection, what a
  multi-view capture records - then fitted with degree-2 SH (3DGS convention, ridge-regularised:
  the lower hemisphere is never seen).
* :func:`bake_shaded` - the same fit of the torch shading model's radiance
  (:func:`learned.splats.decompose.shade`, no visibility): a fast stand-in for tests.
"""
from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from viewer.environment.maps import EnvironmentSpec
from viewer.scene.camera import Camera
from viewer.scene.description import ObjectSpec, Scene
from viewer.scene.material import Material
from viewer.splats.data import (
    Splats,
    concat,
    make_splats,
    matrix_to_quat,
    sh_basis_3dgs,
)

SH_DEGREE = 2
RIDGE = 1e-2  # SH fit regularisation, relative to the mean squared basis value
_RENDER = {"multiscatter": False, "ao": False, "tonemap": "none", "background": "transparent"}


def _scene(objects, camera: Camera) -> Scene:
    return Scene(camera=camera, environment=EnvironmentSpec(path=None, procedural="studio"),
                 objects=tuple(objects)).with_render(**_RENDER)


def _sphere(center, radius, albedo, roughness, metallic) -> ObjectSpec:
    return ObjectSpec("sphere", center=tuple(center), radius=radius,
                      material=Material(albedo=tuple(albedo), roughness=roughness,
                                        metallic=metallic))


def _floor(half: float, albedo=(0.6, 0.6, 0.55), roughness: float = 0.7) -> ObjectSpec:
    return ObjectSpec("plane", center=(0.0, 0.0, 0.0), size=(2 * half, 2 * half),
                      material=Material(albedo=tuple(albedo), roughness=roughness))


def _camera(size: int) -> Camera:
    # a viewpoint between the decomposition's training views (relight.bench.splat_decomp)
    return Camera(position=(0.9, 1.5, 2.6), target=(0.0, 0.3, 0.0), fov_y=40.0, size=(size, size))


def decomp_scenes(size: int = 96) -> dict[str, Scene]:
    """The suite's scenes, rendered at ``size``^2: three spheres (diffuse red, rough gold,
    glossy blue dielectric) on a grey floor, and a shiny copper and a matte green sphere on a
    warm floor."""
    return {
        "three_spheres": _scene([
            _sphere((-0.55, 0.35, 0.0), 0.35, (0.8, 0.2, 0.15), 0.8, 0.0),
            _sphere((0.4, 0.3, -0.35), 0.3, (0.95, 0.75, 0.35), 0.35, 1.0),
            _sphere((0.3, 0.25, 0.45), 0.25, (0.15, 0.3, 0.8), 0.25, 0.0),
            _floor(1.1)], _camera(size)),
        "copper_matte": _scene([
            _sphere((-0.35, 0.4, 0.1), 0.4, (0.95, 0.6, 0.45), 0.2, 1.0),
            _sphere((0.5, 0.3, -0.1), 0.3, (0.2, 0.6, 0.25), 0.9, 0.0),
            _floor(1.1, albedo=(0.7, 0.55, 0.4), roughness=0.5)], _camera(size)),
    }


DECOMP_SCENES = ("three_spheres", "copper_matte")


# ---- splats on the surfaces ------------------------------------------------------------------

def _frame(normals: np.ndarray) -> np.ndarray:
    """[N, 3, 3] rotation matrices whose third column is the normal."""
    helper = np.where(np.abs(normals[:, 1:2]) < 0.9, [[0.0, 1.0, 0.0]], [[1.0, 0.0, 0.0]])
    t1 = np.cross(helper, normals)
    t1 /= np.linalg.norm(t1, axis=1, keepdims=True)
    t2 = np.cross(normals, t1)
    return np.stack([t1, t2, normals], axis=-1)


def _patch(means, normals, spacing: float, material: Material) -> Splats:
    n = len(means)
    rot = _frame(normals)
    scales = np.stack([np.full(n, 0.7 * spacing), np.full(n, 0.7 * spacing),
                       np.full(n, 0.02 * spacing)], -1)
    return make_splats(means, scales, matrix_to_quat(rot), np.full(n, 0.95),
                       albedo=np.tile(np.asarray(material.albedo, np.float32), (n, 1)),
                       roughness=np.full(n, material.roughness),
                       metallic=np.full(n, material.metallic),
                       normals=normals)


def surface_splats(scene: Scene, spacing: float = 0.04) -> Splats:
    """Flat splats ``spacing`` apart on every sphere and plane (+Y normals) of ``scene``, with the
    object's material and the surface normal; the floor's splats under a sphere's contact are
    kept (hidden, as on the mesh)."""
    parts = []
    for obj in scene.objects:
        if obj.type == "sphere":
            n = max(16, int(4 * math.pi * obj.radius ** 2 / spacing ** 2))
            i = np.arange(n) + 0.5
            phi = np.arccos(1 - 2 * i / n)
            theta = np.pi * (1 + 5 ** 0.5) * i
            nrm = np.stack([np.cos(theta) * np.sin(phi), np.cos(phi),
                            np.sin(theta) * np.sin(phi)], -1)
            means = np.asarray(obj.center) + obj.radius * nrm
            parts.append(_patch(means, nrm, obj.radius * math.sqrt(4 * math.pi / n),
                                obj.material))
        elif obj.type == "plane":
            if tuple(obj.normal) != (0.0, 1.0, 0.0):
                raise ValueError("surface_splats: planes must face +Y")
            k = max(2, int(round(obj.size[0] / spacing)))
            c = (np.arange(k) + 0.5) / k - 0.5
            gx, gz = np.meshgrid(c * obj.size[0], c * obj.size[1])
            means = np.stack([gx.ravel(), np.zeros(gx.size), gz.ravel()], -1) + np.asarray(
                obj.center)
            nrm = np.tile([0.0, 1.0, 0.0], (len(means), 1))
            parts.append(_patch(means, nrm, obj.size[0] / k, obj.material))
        else:
            raise ValueError(f"surface_splats: {obj.type} objects have no splat sampler")
    return concat(parts)


# ---- baking -----------------------------------------------------------------------------------

def hemisphere_directions(count: int) -> np.ndarray:
    """[count, 3] a Fibonacci lattice over the upper (+Z) hemisphere, from 5 deg above the
    horizon (grazing views of a flat splat cover no pixels)."""
    i = np.arange(count) + 0.5
    cos_t = 1.0 - (1.0 - math.sin(math.radians(5.0))) * i / count
    sin_t = np.sqrt(1 - cos_t ** 2)
    phi = np.pi * (1 + 5 ** 0.5) * i
    return np.stack([sin_t * np.cos(phi), sin_t * np.sin(phi), cos_t], -1)


def _world_directions(splats: Splats, count: int) -> np.ndarray:
    """[N, D, 3] the hemisphere lattice around every splat's normal."""
    return np.einsum("nij,dj->ndi", _frame(splats.normals.astype(np.float64)),
                     hemisphere_directions(count))


def fit_sh(dirs: np.ndarray, radiance: np.ndarray, degree: int = SH_DEGREE) -> np.ndarray:
    """[N, k, 3] 3DGS SH (colour = SH . basis + 0.5) ridge-fitted per splat to ``radiance``
    [N, D, 3] seen along ``dirs`` [N, D, 3] (unit, from the surface towards the eye). The basis
    is evaluated at the view direction camera -> splat, i.e. ``-dirs``."""
    k = (degree + 1) ** 2
    n, d, _ = dirs.shape
    basis = sh_basis_3dgs((-dirs).reshape(-1, 3), k).reshape(n, d, k)
    gram = np.einsum("ndk,ndl->nkl", basis, basis)
    lam = RIDGE * float(np.mean(basis * basis)) * d  # ~ RIDGE x a Gram diagonal
    rhs = np.einsum("ndk,ndc->nkc", basis, radiance - 0.5)
    reg = np.eye(k) * lam
    reg[0, 0] = 0.0  # the mean colour is not shrunk
    return np.linalg.solve(gram + reg, rhs).astype(np.float32)


def _as_baked(splats: Splats, sh: np.ndarray) -> Splats:
    out = make_splats(splats.means, splats.scales, splats.rotations, splats.opacities, sh=sh,
                      normals=splats.normals)
    return replace(out, source=splats.source)


def bake_shaded(splats: Splats, environment: EnvironmentSpec, directions: int = 24,
                light_res: int = 8) -> Splats:
    """Baked-colour splats from the torch shading model under ``environment`` (no visibility)."""
    import torch

    from learned.splats.decompose import shade

    from .splat_relight import environment_cubemap

    light = torch.from_numpy(environment_cubemap(environment, light_res))
    dirs = _world_directions(splats, directions)
    n, d = dirs.shape[:2]
    with torch.no_grad():
        rad = shade(torch.from_numpy(splats.albedo)[:, None].expand(-1, d, -1),
                    torch.from_numpy(splats.normals)[:, None].expand(-1, d, -1),
                    torch.from_numpy(splats.roughness)[:, None].expand(-1, d),
                    torch.from_numpy(splats.metallic)[:, None].expand(-1, d),
                    torch.from_numpy(dirs).float(), light).numpy().astype(np.float64)
    return _as_baked(splats, fit_sh(dirs, rad))


def bake_traced(scene: Scene, splats: Splats, directions: int = 16, spp: int = 32,
                max_depth: int = 4, seed: int = 0, progress=None) -> tuple[Splats, dict]:
    """Baked-colour splats of ``scene`` (its environment is the capture's light A): per splat
    and direction the mean of ``spp`` path-traced samples of the radiance leaving the splat's
    surface point (a ray from 2 mm out along the direction back at the point; analytic spheres,
    so the point lies on the traced surface). Returns the splats and
    ``{"rays", "miss_fraction", "seconds"}`` (a miss: a ray that hit nothing, e.g. from a point
    inside another object - left at 0)."""
    import time

    from relight.reference import ReferenceError, load_mitsuba
    from relight.reference.scene import to_mitsuba

    mi, dr, variant = load_mitsuba(None)
    if variant.startswith("scalar"):
        raise ReferenceError("baking splats needs Mitsuba's LLVM variant (libLLVM >= 19): the "
                             "scalar one would take hours", where="splat_decomp")
    t0 = time.perf_counter()
    mscene = mi.load_dict(to_mitsuba(scene, mi, dr, max_depth, "analytic"))
    integrator = mscene.integrator()
    dirs = _world_directions(splats, directions)  # [N, D, 3]
    n, d = dirs.shape[:2]
    origins = (splats.means.astype(np.float64)[:, None] + 0.002 * dirs).reshape(-1, 3)
    rays_d = (-dirs).reshape(-1, 3)
    total = np.zeros((n * d, 3))
    hits = np.zeros(n * d)
    lanes = max(1, (1 << 21) // (n * d))  # samples per ray per batch
    done = 0
    while done < spp:
        count = min(lanes, spp - done)
        o = np.repeat(origins, count, axis=0)
        v = np.repeat(rays_d, count, axis=0)
        ray = mi.Ray3f(mi.Point3f(np.ascontiguousarray(o.T, np.float32)),
                       mi.Vector3f(np.ascontiguousarray(v.T, np.float32)))
        sampler = mi.load_dict({"type": "independent"})
        sampler.seed((seed * 1_000_003 + done) & 0x7FFFFFFF, len(o))
        value, _, _ = integrator.sample(mscene, sampler, ray)
        hit = mscene.ray_intersect(ray).is_valid()
        dr.eval(value, hit)
        total += np.asarray(value, np.float64).T.reshape(n * d, count, 3).sum(1)
        hits += np.asarray(hit, bool).reshape(n * d, count).sum(1)
        done += count
        if progress is not None:
            progress(done, spp)
    rad = (total / spp).reshape(n, d, 3)
    info = {"rays": n * d, "spp": spp, "miss_fraction": float(1 - hits.sum() / (n * d * spp)),
            "seconds": time.perf_counter() - t0, "variant": variant}
    return _as_baked(splats, fit_sh(dirs, rad)), info
