"""The BVH traversal of ``passes/raytrace.glsl`` (closest hit and any hit, alpha-masked
surfaces, splats) against :mod:`learned.twins.bvh`, on small scenes: a tessellated sphere on a
floor, a soup of random triangles some of which are masked out, and a splat cloud over a floor
(proxies counted only where rays enter them; closest hits on the opaque cores, shadow rays
blocked by the opacity they gather through the Gaussians). The twin walks the same tree in the
same order, so the triangle indices agree exactly and the distances to float32 rounding; the
tests (``tests/viewer/test_raytrace.py``) check both against a brute-force search in float64."""
from __future__ import annotations

import numpy as np
import torch

from learned.twins.bvh import bvh_any_hit, bvh_closest_hit
from viewer.geometry import primitives
from viewer.geometry.mesh import Mesh
from viewer.gl.kernels import run_kernel
from viewer.raytrace.scene import build_trace_geometry, material_rows
from viewer.raytrace.splat_proxies import splat_proxies
from viewer.raytrace.upload import TraceBuffers
from viewer.scene.material import Material
from viewer.splats.data import Splats, make_splats

from ..results import compare
from . import collector

RAYS = 192  # the twin walks the tree ray by ray in Python: a few hundred keep it to seconds


def parity_scenes() -> dict[str, list]:
    """name -> meshes: ``sphere_floor`` (a sphere resting on a floor), ``soup_masked`` (60
    random triangles, a third of them in an alphaMode MASK mesh whose alpha is below its cutoff,
    so rays pass through them) and ``splat_cores`` (a splat cloud over a floor: closed proxies
    counted only where rays enter them)."""
    rng = np.random.default_rng(5)

    def soup(n, material=Material(), **kw):
        p = (rng.uniform(-1.0, 1.0, (n, 1, 3)) + rng.normal(0.0, 0.25, (n, 3, 3)))
        p = p.reshape(-1, 3).astype(np.float32)
        normals = np.tile(np.array([[0.0, 1.0, 0.0]], np.float32), (len(p), 1))
        return Mesh(positions=p, normals=normals,
                    indices=np.arange(3 * n, dtype=np.uint32).reshape(n, 3), material=material,
                    **kw)
    return {
        "sphere_floor": [primitives.sphere(center=(0.0, 0.0, 0.0), radius=1.0, segments=24,
                                           rings=12),
                         primitives.plane(center=(0.0, -1.0, 0.0), size=(6.0, 6.0))],
        "soup_masked": [soup(40), soup(20, alpha_mode="MASK", alpha_cutoff=0.5, base_alpha=0.3)],
        "splat_cores": [*splat_proxies(_cloud(rng)),
                        primitives.plane(center=(0.0, -1.0, 0.0), size=(6.0, 6.0))],
    }


def _cloud(rng) -> Splats:
    """40 splats over the parity scenes' space, a quarter of them too faint to have a core, some
    rays starting inside the cores (parity_rays' origins reach into them)."""
    n = 40
    return make_splats(means=rng.uniform(-1.2, 1.2, (n, 3)) + (0.0, 0.6, 0.0),
                       scales=rng.uniform(0.05, 0.5, (n, 3)),
                       rotations=rng.normal(size=(n, 4)),
                       opacities=np.where(np.arange(n) % 4 == 0, 0.4, rng.uniform(0.55, 0.99, n)))


def parity_rays(n: int, seed: int = 0) -> np.ndarray:
    """``[n, 7]`` float32: origins around the scenes, unit directions towards them, t_max (a
    quarter of the rays stop short of what they would hit)."""
    rng = np.random.default_rng(seed)
    o = rng.uniform(-3.0, 3.0, (n, 3))
    o[:, 1] = np.abs(o[:, 1]) + 0.5
    d = rng.uniform(-1.2, 1.2, (n, 3)) - o
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    t_max = np.where(rng.uniform(size=n) < 0.25, rng.uniform(0.5, 3.0, n), 100.0)
    return np.concatenate([o, d, t_max[:, None]], axis=1).astype(np.float32)


def trace_gl(programs, buffers: TraceBuffers, rays: np.ndarray) -> np.ndarray:
    """``[n, 5]``: closest hit (t, triangle, b1, b2) and any hit (0/1) of each ray, in GLSL."""
    return run_kernel(programs, "passes/parity_raytrace.comp", rays, 5,
                      lambda prog: buffers.bind(prog, 0))


def checks() -> dict:
    """This module's pass checks: name -> (model or None, check(programs) -> results)."""
    found, register_pass_check = collector()

    @register_pass_check("raytrace")
    def check_traversal(programs):
        results = []
        for name, meshes in parity_scenes().items():
            geo = build_trace_geometry(meshes)
            buffers = TraceBuffers(programs.ctx, geo)
            try:
                buffers.set_materials(meshes)
                rays = parity_rays(RAYS)
                gl = trace_gl(programs, buffers, rays)
            finally:
                buffers.release()
            with torch.no_grad():
                buffers_t = (torch.from_numpy(geo.nodes.reshape(-1, 4)),
                             torch.from_numpy(geo.triangles.astype(np.int64)),
                             torch.from_numpy(geo.vertices.reshape(-1, 4)),
                             torch.from_numpy(material_rows(meshes, geo.layers)),
                             torch.from_numpy(geo.splats.reshape(-1, 4)),
                             torch.from_numpy(geo.edges.reshape(-1, 4)))
                ray_t = (torch.from_numpy(rays[:, :3]), torch.from_numpy(rays[:, 3:6]),
                         torch.from_numpy(rays[:, 6]))
                ref = bvh_closest_hit(*ray_t, *buffers_t).numpy()
                blocked = bvh_any_hit(*ray_t, *buffers_t).numpy()
            results.append(compare(f"bvh_closest_hit:{name}:triangle", gl[:, 1], ref[:, 1],
                                   atol=0.0, rtol=0.0, kind="pass",
                                   measured="identical indices (sphere_floor, soup_masked, splat_cores)",
                                   envelope="same tree, same order, same ray_triangle roundings: "
                                            "a different index would be a traversal bug (the "
                                            "rays avoid edges only by chance; none of the "
                                            "seed's rays grazes one)"))
            results.append(compare(f"bvh_closest_hit:{name}:t,b", gl[:, [0, 2, 3]],
                                   ref[:, [0, 2, 3]], atol=2e-5, rtol=1e-5, kind="pass",
                                   measured="max abs 4.7e-6 on the meshes (t <= 7; llvmpipe "
                                            "contracts to FMA where torch does not), 4.1e-5 "
                                            "at t ~ 5 on the splats' cores (rel 3.9e-6)",
                                   envelope="ray_triangle's case envelope (~3e-5 abs at "
                                            "|sin| >= 0.1) on the same triangle; these rays "
                                            "meet surfaces at steeper angles; a core's entry: "
                                            "ellipsoid_entry's (5e-5 rel) after the affine "
                                            "map's ~1e-6"))
            results.append(compare(f"bvh_any_hit:{name}", gl[:, 4], blocked, atol=0.0,
                                   rtol=0.0, kind="pass", measured="identical",
                                   envelope="the same solid triangles; through splats the same "
                                            "product to ~1e-6 in another order, against 1/2: a "
                                            "ray within that of the threshold could differ "
                                            "(none of the seed's does)"))
        return results
    return found
