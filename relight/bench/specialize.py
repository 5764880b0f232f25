"""Measure what specialisation buys: the same scene on the all-features path and specialised.

A diffuse-only, splat-free scene (no surface with a specular lobe, no ambient occlusion) and the
demo scene are rendered with ``specialize = false`` (every G-buffer channel, every lobe) and
``specialize = true``; the rows record both times and the largest difference in linear radiance.
"""
from __future__ import annotations

import dataclasses

import numpy as np

from viewer.geometry.imagespace import ImageGBuffer, save_stack_exr
from viewer.scene.description import ObjectSpec

from .scenes import bench_scene, demo_scene
from .timing import time_frames

SPECIALIZATION_SIZE = (1024, 640)


def _diffuse_stack(renderer, cache):
    """``assets/scenes/bench/diffuse_stack_capture.toml`` (the diffuse-only scene in front of a
    stack camera) saved as a 12-channel image-space G-buffer (the thesis's main input:
    inverse-rendered G-buffers, no geometry to rasterise)."""
    path = cache / "diffuse_stack.exr"
    capture = bench_scene("diffuse_stack_capture")
    if not path.exists():
        aovs = ("albedo", "normal", "roughness", "specular", "metallic", "depth", "ao", "alpha")
        frame = renderer.render(capture.with_camera(size=SPECIALIZATION_SIZE), aovs=aovs)
        save_stack_exr(path, ImageGBuffer(channels=dict(frame.aovs), fov_y=capture.camera.fov_y))
    return dataclasses.replace(capture, objects=(ObjectSpec("gbuffer", path=str(path)),))


def measure_specialization(renderer, config, cache) -> list[dict]:
    """``{"scene", "size", "ms_general", "ms_specialized", "max_abs_diff"}`` per scene: a
    diffuse-only image-space stack, the same scene as meshes, and the demo."""
    scenes = {"diffuse_stack": (_diffuse_stack(renderer, cache), None),
              "diffuse_meshes": (bench_scene("diffuse_only"), SPECIALIZATION_SIZE),
              "demo": (demo_scene(), SPECIALIZATION_SIZE)}
    rows = []
    for name, (scene, size) in scenes.items():
        general = scene.with_render(specialize=False)
        special = scene.with_render(specialize=True)
        ms_g, _ = time_frames(renderer, general, size, config)
        ms_s, _ = time_frames(renderer, special, size, config)
        a = renderer.render(general, size=size)
        b = renderer.render(special, size=size)
        rows.append({"scene": name, "size": list(a.camera.size), "ms_general": ms_g,
                     "ms_specialized": ms_s,
                     "max_abs_diff": float(np.abs(a.radiance - b.radiance).max())})
    return rows
