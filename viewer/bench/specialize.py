"""Measure what specialisation buys: the same scene on the all-features path and specialised.

A diffuse-only, splat-free scene (no surface with a specular lobe, no ambient occlusion) and the
demo scene are rendered with ``specialize = false`` (every G-buffer channel, every lobe) and
``specialize = true``; the rows record both times and the largest difference in linear radiance.
"""
from __future__ import annotations

import numpy as np

from ..scene import scene_from_dict

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


def measure_specialization(renderer, config) -> list[dict]:
    from .run import _time_frames
    from assets import ASSET_ROOT
    from ..scene import load_scene

    scenes = {"diffuse_only": scene_from_dict(DIFFUSE_ONLY),
              "demo": load_scene(ASSET_ROOT / "scenes" / "demo.toml")}
    rows = []
    size = config.sizes[-1]
    for name, scene in scenes.items():
        general = scene.with_render(specialize=False)
        special = scene.with_render(specialize=True)
        ms_g, _ = _time_frames(renderer, general, size, config)
        ms_s, _ = _time_frames(renderer, special, size, config)
        a = renderer.render(general, size=size).radiance
        b = renderer.render(special, size=size).radiance
        rows.append({"scene": name, "size": list(size), "ms_general": ms_g, "ms_specialized": ms_s,
                     "max_abs_diff": float(np.abs(a - b).max())})
    return rows
