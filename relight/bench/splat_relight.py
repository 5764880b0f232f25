"""Rendering and truth for the ``splat_decomp`` suite (:mod:`relight.bench.splat_decomp`).

* :func:`environment_cubemap` - an environment as the ``[6, R, R, 3]`` cubemap the torch
  decomposition shades with, each texel the energy of the equirect texels that fall in it (the
  integral kept, a small sun is not missed).
* :func:`render_splats` - a cloud through the project's renderer (GLSL, the splat pass and the
  deferred ``ggx_split_sum`` shading; ``unlit`` shows the baked colour) under an environment.
* :func:`truth_render` - the path-traced reference of the mesh scene under an environment
  (Mitsuba 3, our BSDF, analytic spheres: :func:`relight.reference.render_reference`), cached
  in a folder (resumable through its checkpoint).
* :func:`score_relit` - PSNR etc. against the reference over pixels fully covered in both.
"""
from __future__ import annotations

import dataclasses
import hashlib
import json
import math
from pathlib import Path

import numpy as np

from viewer.environment.maps import EnvironmentSpec, load_environment, texel_directions
from viewer.environment.sun import texel_solid_angles
from viewer.scene.description import ObjectSpec, Scene
from viewer.splats.data import Splats
from viewer.splats.generate import cube_solid_angles
from viewer.splats.ply import write_ply


def environment_cubemap(spec: EnvironmentSpec, res: int = 16) -> np.ndarray:
    """``[6, res, res, 3]`` float32 radiance of ``spec`` (intensity and rotation applied) in the
    face layout of :func:`viewer.splats.generate.cube_directions`: each texel holds the energy
    (radiance x solid angle) of the equirect texels whose centres fall in it over its own solid
    angle, so the integral over the sphere is kept exactly (the equirect map needs a few texels
    per cube texel: width >= 16 ``res``)."""
    env = load_environment(spec).astype(np.float64) * spec.intensity
    h, w = env.shape[:2]
    d = texel_directions(w).reshape(-1, 3)
    if spec.rotation_deg:  # the map turned counter-clockwise about +Y: rotate its directions
        a = math.radians(spec.rotation_deg)
        c, s = math.cos(a), math.sin(a)
        d = d @ np.array([[c, 0.0, -s], [0.0, 1.0, 0.0], [s, 0.0, c]])
    dw = np.repeat(texel_solid_angles(h, w), w)
    ax = np.abs(d)
    major = ax.argmax(1)
    face = np.empty(len(d), np.int64)
    u = np.empty(len(d))
    v = np.empty(len(d))
    x, y, z = d.T
    for axis, pos, neg in ((0, 0, 1), (1, 2, 3), (2, 4, 5)):
        m = major == axis
        m_pos = m & (d[:, axis] > 0)
        m_neg = m & (d[:, axis] <= 0)
        ma = ax[:, axis]
        # inverse of cube_directions: face (u across, v up)
        if axis == 0:
            u[m_pos], v[m_pos] = -z[m_pos] / ma[m_pos], y[m_pos] / ma[m_pos]
            u[m_neg], v[m_neg] = z[m_neg] / ma[m_neg], y[m_neg] / ma[m_neg]
        elif axis == 1:
            u[m_pos], v[m_pos] = x[m_pos] / ma[m_pos], -z[m_pos] / ma[m_pos]
            u[m_neg], v[m_neg] = x[m_neg] / ma[m_neg], z[m_neg] / ma[m_neg]
        else:
            u[m_pos], v[m_pos] = x[m_pos] / ma[m_pos], y[m_pos] / ma[m_pos]
            u[m_neg], v[m_neg] = -x[m_neg] / ma[m_neg], y[m_neg] / ma[m_neg]
        face[m_pos], face[m_neg] = pos, neg
    col = np.clip(((u + 1) / 2 * res).astype(np.int64), 0, res - 1)
    row = np.clip(((1 - v) / 2 * res).astype(np.int64), 0, res - 1)  # rows top to bottom
    idx = (face * res + row) * res + col
    acc = np.zeros((6 * res * res, 3))
    np.add.at(acc, idx, env.reshape(-1, 3) * dw[:, None])
    out = acc.reshape(6, res, res, 3) / cube_solid_angles(res)[..., None]
    return out.astype(np.float32)


def render_splats(renderer, scene: Scene, splats: Splats, environment: EnvironmentSpec,
                  folder: Path, name: str, model: str = "ggx_split_sum") -> np.ndarray:
    """``[H, W, 4]`` linear radiance (alpha = coverage) of ``splats`` alone, seen by ``scene``'s
    camera under ``environment``, through the renderer's splat pass; the cloud is written to
    ``folder/<name>_<content hash>.ply`` for it (the renderer caches a cloud by its path, so a
    path is never reused for other content)."""
    h = hashlib.sha256()
    for a in (splats.means, splats.sh, splats.albedo, splats.roughness, splats.metallic,
              splats.normals, splats.scales, splats.opacities):
        h.update(np.ascontiguousarray(a).tobytes())
    path = Path(folder) / f"{name}_{h.hexdigest()[:12]}.ply"
    if not path.is_file():
        write_ply(path, splats)
    s = dataclasses.replace(scene, environment=environment,
                            objects=(ObjectSpec("splats", path=str(path)),))
    return renderer.render(s.with_render(model=model)).radiance


def truth_key(scene: Scene, environment: EnvironmentSpec, spp: int, max_depth: int) -> str:
    blob = repr((scene.camera, scene.objects, environment, spp, max_depth, "analytic"))
    if environment.sun_strength != 1.0:  # not in the spec's repr at its default
        blob += repr(("sun_strength", environment.sun_strength))
    return hashlib.sha256(blob.encode()).hexdigest()[:16]


def truth_render(scene: Scene, environment: EnvironmentSpec, folder: Path, name: str,
                 spp: int = 256, max_depth: int = 4, progress: bool = True):
    """The path-traced :class:`~relight.reference.Reference` of ``scene`` under ``environment``,
    read from ``folder/<name>_<key>.exr`` when already made there (key: a hash of the camera,
    objects, environment and options)."""
    from relight.reference import (
        ReferenceOptions,
        read_reference,
        render_reference,
        write_reference,
    )

    key = truth_key(scene, environment, spp, max_depth)
    out = Path(folder) / f"{name}_{key}.exr"
    if out.is_file():
        return read_reference(out)
    s = dataclasses.replace(scene, environment=environment, source=f"{name} ({key})")
    ref = render_reference(s, ReferenceOptions(spp=spp, max_depth=max_depth, geometry="analytic"),
                           checkpoint=out.with_suffix(".ckpt.npz"), progress=progress)
    write_reference(ref, out)
    return ref


def coverage(image: np.ndarray, ref, threshold: float = 0.99) -> np.ndarray:
    """Pixels covered (alpha > ``threshold``) by both the splat render and the reference."""
    return (image[..., 3] > threshold) & (ref.radiance[..., 3] > threshold)


def score_relit(image: np.ndarray, ref, mask: np.ndarray) -> dict:
    """PSNR of the linear radiance (peak: the reference's 99.9th percentile), median relative
    error and energy bias of ``image`` against ``ref`` over ``mask``
    (:func:`relight.reference.compare.score`), and the display images' PSNR (:func:`psnr_ldr`)."""
    from relight.reference.compare import score

    s = score(image, ref, mask)
    return {"psnr": s.psnr, "psnr_ldr": psnr_ldr(image, ref.radiance, mask),
            "median_rel_%": 100 * s.median_rel, "bias_%": 100 * s.bias, "pixels": s.pixels}


def psnr_ldr(image: np.ndarray, truth: np.ndarray, mask: np.ndarray) -> float:
    """PSNR (peak 1) of the display images - linear radiance clipped to [0, 1], sRGB-encoded -
    over ``mask``: the papers' relighting metric (what a viewer sees, highlights saturated)."""
    def srgb(x):
        x = np.clip(np.asarray(x[..., :3], np.float64)[mask], 0.0, 1.0)
        return np.where(x <= 0.0031308, 12.92 * x, 1.055 * x ** (1 / 2.4) - 0.055)

    mse = float(((srgb(image) - srgb(truth)) ** 2).mean()) if mask.any() else 0.0
    return 10.0 * math.log10(1.0 / mse) if mse > 0 else math.inf


def save_json(path: Path, data) -> None:
    tmp = Path(str(path) + ".tmp")
    tmp.write_text(json.dumps(data, indent=1))
    tmp.replace(path)


def shaded_truth(scene: Scene, splats: Splats, environment: EnvironmentSpec, light_res: int = 8):
    """A stand-in reference without a path tracer (tests): ``splats`` (true materials) through
    the torch twin rasteriser at ``scene``'s camera, shaded by the decomposition's own model
    (:func:`learned.splats.decompose.shade`) under ``environment`` as a cubemap. No visibility,
    no inter-reflection; stderr 0."""
    import torch

    from learned.splats.decompose import shade
    from learned.splats.rasterize import rasterize, splat_tensors
    from relight.reference import Reference

    cam = scene.camera
    with torch.no_grad():
        g = rasterize(splat_tensors(splats), cam)
        v = -torch.from_numpy(cam.view_rays_ws().astype(np.float32))
        light = torch.from_numpy(environment_cubemap(environment, light_res))
        rad = shade(g["albedo"], g["normal"], g["roughness"][..., 0], g["metallic"][..., 0], v,
                    light) * g["alpha"]
    radiance = torch.cat([rad, g["alpha"]], -1).numpy().astype(np.float32)
    return Reference(radiance=radiance, stderr=np.zeros_like(radiance[..., :3]),
                     meta={"spp": None, "truth": "torch shade, no visibility"})
