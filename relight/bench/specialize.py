"""Measure what specialisation buys: the same scene on the all-features path and specialised.

A diffuse-only, splat-free scene (no surface with a specular lobe, no ambient occlusion) and the
demo scene are rendered with ``specialize = false`` (every G-buffer channel, every lobe) and
``specialize = true``; the rows record both times and the largest difference in linear radiance.
"""
from __future__ import annotations

import numpy as np

from viewer.scene import scene_from_dict

from .timing import time_frames

DIFFUSE_ONLY = {
    "camera": {"position": [0, 2.2, 7.5], "target": [0, 0.4, 0], "fov_y": 40},
    "environment": {"procedural": "sky"},
    "objects": [
        {"type": "sphere", "center": [x, y, 0], "radius": 0.8,
         "material": {"albedo": [0.2 + 0.1 * i, 0.5, 0.9 - 0.1 * i], "roughness": round(i / 7, 3),
                      "specular": 0.0, "metallic": 0.0}}
        for i, (x, y) in enumerate((x, y) for y in (0.1, 1.8) for x in (-3, -1, 1, 3))
    ] + [
        {"type": "plane", "center": [0, -0.8, 0], "size": [14, 10],
         "material": {"albedo": [0.5, 0.5, 0.5], "specular": 0.0}},
    ],
    "render": {"model": "ggx_split_sum"},
}


SPECIALIZATION_SIZE = (1024, 640)


def _diffuse_stack(renderer, cache):
    """The diffuse-only scene seen from a stack camera, saved as a 12-channel image-space
    G-buffer (the thesis's main input: inverse-rendered G-buffers, no geometry to rasterise)."""
    import copy

    from viewer.geometry.imagespace import ImageGBuffer, save_stack_exr

    path = cache / "diffuse_stack.exr"
    if not path.exists():
        d = copy.deepcopy(DIFFUSE_ONLY)
        d["camera"] = {"position": [0, 0, 0], "target": [0, 0, -1], "fov_y": 40,
                       "size": list(SPECIALIZATION_SIZE)}
        for o in d["objects"]:
            x, y, z = o["center"]
            o["center"] = [x, y - 0.8, z - 8.0]
        aovs = ("albedo", "normal", "roughness", "specular", "metallic", "depth", "ao", "alpha")
        frame = renderer.render(scene_from_dict(d), aovs=aovs)
        save_stack_exr(path, ImageGBuffer(channels=dict(frame.aovs), fov_y=40.0))
    return scene_from_dict({"environment": {"procedural": "sky"},
                            "objects": [{"type": "gbuffer", "path": str(path)}]})


def measure_specialization(renderer, config, cache) -> list[dict]:
    """``{"scene", "size", "ms_general", "ms_specialized", "max_abs_diff"}`` per scene: a
    diffuse-only image-space stack, the same scene as meshes, and the demo."""
    from assets import ASSET_ROOT

    from viewer.scene import load_scene

    scenes = {"diffuse_stack": (_diffuse_stack(renderer, cache), None),
              "diffuse_meshes": (scene_from_dict(DIFFUSE_ONLY), SPECIALIZATION_SIZE),
              "demo": (load_scene(ASSET_ROOT / "scenes" / "demo.toml"), SPECIALIZATION_SIZE)}
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
