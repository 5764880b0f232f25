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
        {"type": "material_grid", "rows": 2, "cols": 4, "spacing": 2.0, "radius": 0.8,
         "center": [0, 0.9, 0], "material": {"albedo": [0.7, 0.5, 0.3], "specular": 0.0}},
        {"type": "plane", "center": [0, -0.6, 0], "size": [14, 10],
         "material": {"albedo": [0.5, 0.5, 0.5], "specular": 0.0}},
    ],
    "render": {"model": "ggx_split_sum"},
}


def _diffuse_grid_fix(scene):
    # the material grid sweeps metallic down its rows; a diffuse-only scene keeps metallic at 0
    import dataclasses

    objs = tuple(dataclasses.replace(o, rows=1) if o.type == "material_grid" else o
                 for o in scene.objects)
    return dataclasses.replace(scene, objects=objs)


def measure_specialization(renderer, config) -> list[dict]:
    from .run import _time_frames
    from assets import ASSET_ROOT
    from ..scene import load_scene

    scenes = {"diffuse_only": _diffuse_grid_fix(scene_from_dict(DIFFUSE_ONLY)),
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
