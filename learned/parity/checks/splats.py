"""The GLSL splat pass (``viewer/passes/splats.py``) against :func:`learned.splats.rasterize.rasterize`
on random clouds, with and without a mesh G-buffer underneath."""
from __future__ import annotations

import numpy as np
import torch

from learned.splats.rasterize import (
    _pixel_centres,
    alpha_chunks,
    project,
    rasterize,
    splat_tensors,
)
from learned.twins.splat import splat_mahalanobis2, splat_median_target
from viewer.gbuffer import GBufferLayout
from viewer.geometry import primitives
from viewer.passes.gbuffer import GBufferPass, GBufferTargets
from viewer.passes.splats import SplatPass
from viewer.scene.camera import Camera
from viewer.scene.material import Material
from viewer.splats.data import Splats, make_splats

from ..results import compare
from . import collector


def checks() -> dict:
    """This module's pass checks: name -> (model or None, check(programs) -> results)."""
    found, register_pass_check = collector()


    @register_pass_check("splats", model="splats")
    def check(programs):
        return parity_check(programs)
    return found


# Per G-buffer channel (values in [0, 1], depth in view units): a pixel sums T_i alpha_i x_i over
# up to ~100 overlapping splats; alpha = opacity exp(-d^2 / 2) with exp2 at (3 + 2|x|) ulp, |x|
# <= 6 (15 ulp) and d^2 a 5-op quadratic form of the conic (whose 2.5-ulp division carries the
# centre's and the covariance's rounding: ~20 ulp), blended in float32 (RGBA32F: full precision
# on GPUs too): ~100 layers x 35 ulp x 6e-8 = 2e-4, times 2 for the resolve's division and the
# normal's renormalisation -> 1e-3. Pixels on a yes/no discontinuity (d^2 = 8, alpha = 1/255, a
# depth tie) are excluded and counted (ambiguous_pixels); the near/far cull is bit-identical
# (splat_view_depth). Measured on llvmpipe: max abs 3.3e-5 (normals), 1e-5 elsewhere.
PARITY_ATOL = 1e-3


def random_scene(n: int, seed: int, sh_degree: int = 3) -> Splats:
    """A random cloud in [-1, 1]^3 (some splats behind the near plane of :func:`parity_camera`,
    some off-screen), SH of ``sh_degree``, random materials, half with stored normals."""
    rng = np.random.default_rng(seed)
    means = rng.uniform(-1.0, 1.0, (n, 3)) * np.array([1.4, 1.2, 1.0])
    means[: n // 50, 2] = 2.98  # right in front of / behind the near plane of a camera at z = 3
    scales = np.exp(rng.uniform(np.log(0.005), np.log(0.12), (n, 3)))
    rot = rng.normal(size=(n, 4))
    opac = rng.uniform(0.02, 1.0, n)
    k = (sh_degree + 1) ** 2
    sh = rng.normal(0.0, 0.25, (n, k, 3))
    sh[:, 0] += rng.uniform(-1.5, 1.5, (n, 3))
    normals = rng.normal(size=(n, 3))
    normals[: n // 2] = 0.0
    return make_splats(means, scales, rot, opac, sh=sh, albedo=rng.uniform(0, 1, (n, 3)),
                       roughness=rng.uniform(0, 1, n), metallic=rng.uniform(0, 1, n),
                       normals=normals)


def parity_camera(size=(96, 80)) -> Camera:
    return Camera(position=(0.3, 0.2, 3.0), target=(0.0, 0.0, 0.0), fov_y=50.0, size=size,
                  near=0.05)


def render_gl(programs, splats: Splats, camera: Camera, meshes=(), sort: str = "cpu",
              depth: str = "expected"):
    """(before, after): G-buffer channel dicts read back before and after the splat pass."""

    layout = GBufferLayout(with_color=True)
    targets = GBufferTargets.create(programs.ctx, layout, camera.size)
    gpass, spass = GBufferPass(programs, layout), SplatPass(programs, layout)
    try:
        targets.clear()
        if meshes:
            gpass.draw_meshes(targets, camera, list(meshes))
        before = targets.read()
        spass.draw(targets, camera, splats, sort=sort, depth=depth)
        after = targets.read()
    finally:
        gpass.release()
        spass.release()
        targets.release()
    return before, after


def ambiguous_pixels(t: dict[str, torch.Tensor], camera: Camera,
                     under_depth: torch.Tensor | None = None, band: float = 3e-4,
                     band_d2: float = 2e-3) -> torch.Tensor:
    """[H, W] bool: pixels where some splat sits within a relative band of a discontinuity
    (``band_d2`` around the d^2 = 8 cut-off, ``band`` around the alpha = 1/255 skip and depth ties
    with ``under_depth``). There a rounding difference between GLSL and torch switches a fragment
    on or off (a jump of up to 0.99 exp(-4) = 0.018), so parity excludes these pixels and reports
    how many. d^2 gets the wider band: for needle-like splats (2D eigenvalues 0.3 and ~1e4 px^2)
    the conic's determinant a c - b^2 cancels, and float32 d^2 differs by up to ~1e-3 relative."""
    p = project(t, camera)
    pix = _pixel_centres(camera)
    amb = torch.zeros(pix.shape[0], dtype=torch.bool)
    idx_all = torch.nonzero(p["valid"])[:, 0]
    with torch.no_grad():
        for s in range(0, len(idx_all), 256):
            idx = idx_all[s:s + 256]
            d2 = splat_mahalanobis2(pix[None] - p["centre"][idx][:, None], p["conic"][idx][:, None])
            raw = torch.clamp(t["opacities"][idx][:, None] * torch.exp(-0.5 * d2), max=0.99)
            near = ((d2 - 8.0).abs() < 8.0 * band_d2) | ((raw * 255.0 - 1.0).abs() < band)
            if under_depth is not None:
                dep = p["depth"][idx][:, None]
                near |= (under_depth[None] > 0) & ((dep - under_depth[None]).abs() < band * dep) \
                    & (d2 <= 8.0)
            amb |= near.any(0)
    return amb.reshape(camera.height, camera.width)


def median_ambiguous_pixels(t: dict[str, torch.Tensor], camera: Camera, coverage: torch.Tensor,
                            under_alpha: torch.Tensor, under_depth: torch.Tensor | None = None,
                            band: float = 2e-5) -> torch.Tensor:
    """[H, W] bool: pixels where the median's choice can flip on rounding - the accumulated
    opacity after some splat (front to back), or the coverage itself, lies within ``band`` of the
    target (GL multiplies the transmittances back to front, the twin in chunks: ~100 factors x
    1 ulp apart, ~6e-6)."""
    target = splat_median_target(coverage, under_alpha)
    amb = (coverage - target).abs() < band
    trans = torch.ones_like(coverage)
    with torch.no_grad():
        for _, alpha in alpha_chunks(t, camera, under_depth=under_depth):
            after = trans[None] * torch.cumprod(1.0 - alpha, 0)
            amb |= (((1.0 - after) - target[None]).abs() < band).any(0)
            trans = after[-1]
    return amb.reshape(camera.height, camera.width)


def parity_check(programs, seeds=(0, 1), n: int = 1500):
    """ParityResults per G-buffer channel: random scenes without and with a mesh plane cutting
    through the cloud (depth test + compositing over the mesh G-buffer). Pixels on a
    discontinuity (:func:`ambiguous_pixels`, typically < 0.5%) are excluded and counted."""
    results = []
    camera = parity_camera()
    for seed in seeds:
        splats = random_scene(n, seed)
        meshes = () if seed % 2 == 0 else (
            primitives.plane(center=(0.0, -0.2, 0.0), size=(3.0, 3.0), normal=(0.0, 1.0, 0.3),
                             material=Material(albedo=(0.2, 0.6, 0.3), roughness=0.8)),)
        before, gl = render_gl(programs, splats, camera, meshes)
        under = {k: torch.from_numpy(v) for k, v in before.items()} if meshes else None
        tensors = splat_tensors(splats)
        with torch.no_grad():
            ref = rasterize(tensors, camera, under=under)
        under_depth = None
        if under is not None:
            under_depth = torch.where(under["alpha"] > 0, under["depth"], 0.0).reshape(-1)
        keep = ~ambiguous_pixels(tensors, camera, under_depth).numpy()
        tag = (f"splats:{n}{'+mesh' if meshes else ''}:seed{seed}"
               f"({int((~keep).sum())}/{keep.size}px excluded)")
        for name, arr in gl.items():
            results.append(compare(f"{tag}:{name}", arr[keep], ref[name].numpy()[keep],
                                   PARITY_ATOL, 0.0, kind="pass",
                                   envelope="~100 blended layers x 35 ulp, x 2 for the resolve "
                                            "(see PARITY_ATOL); discontinuities excluded"))
        # splat_depth = "median": the search picks one splat's depth, bit-identical in both
        # (splat_view_depth, splat_depth_threshold exact) unless a rounding flips the choice
        _, gl_med = render_gl(programs, splats, camera, meshes, depth="median")
        with torch.no_grad():
            ref_med = rasterize(tensors, camera, under=under, depth="median")
        ua = (torch.zeros(keep.size) if under is None else under["alpha"].reshape(-1))
        keep_med = keep & ~median_ambiguous_pixels(
            tensors, camera, ref["alpha"].reshape(-1) if under is None else
            _splat_coverage(tensors, camera, under_depth), ua, under_depth).numpy()
        results.append(compare(
            f"splats:{n}{'+mesh' if meshes else ''}:seed{seed}:median_depth"
            f"({int((~keep_med).sum())}/{keep.size}px excluded)", gl_med["depth"][keep_med],
            ref_med["depth"].numpy()[keep_med], MEDIAN_ATOL, 0.0, kind="pass",
            envelope="exact: the nearest splat depth in the searched range, the same float32 "
                      "value on both sides; pixels where an accumulated opacity is within 2e-5 "
                      "of the target (the transmittance products' rounding) are excluded"))
    return results


MEDIAN_ATOL = 0.0  # measured: 0 on llvmpipe (seeds 0, 1)


def _splat_coverage(t, camera, under_depth) -> torch.Tensor:
    """[H*W] the splats' coverage A = 1 - prod(1 - alpha) with the depth test."""
    trans = None
    for _, alpha in alpha_chunks(t, camera, under_depth=under_depth):
        prod = torch.prod(1.0 - alpha, 0)
        trans = prod if trans is None else trans * prod
    n = camera.width * camera.height
    return torch.zeros(n) if trans is None else 1.0 - trans
