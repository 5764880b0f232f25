"""``relight bench``'s shadow suite: what shadow maps cost per frame.

The bench's mesh scene at 512^2 with 1 and 4 shadowing directional lights and maps of 2048 (the
default) and 1024 texels a side, each frame timed with shadows on and off in the same run (whole frames: nothing reused), so a row's ``ratio`` is
the cost of the shadow passes and lookups relative to the same frame without them: a frame in
which a light or the geometry moved. ``ratio_maps_kept`` is the same shadowed frame without its
shadow passes (their fenced times taken out of the same frames): what a camera move or a material
or light-colour slider costs, since the frame graph keeps a map whose light and casters did not
change (a cascaded map follows the camera and is redrawn). Absolute milliseconds on a shared CPU
are noise; the ratios measured in one run are the numbers to quote. What the map size costs in
accuracy is the ``shadow_truth`` suite's ``psnr_map<n>`` (:mod:`relight.bench.shadow_truth`).
"""
from __future__ import annotations

import dataclasses
import math

from viewer.lights import Light

from .timing import time_frames

SIZE = (512, 512)
MAP_SIZES = (2048, 1024)


def _lights(n: int) -> tuple[Light, ...]:
    """``n`` directional lights spread around the sky, 45 degrees up."""
    out = []
    for i in range(n):
        a = 2.0 * math.pi * i / max(n, 1)
        out.append(Light(direction=(math.cos(a) * 0.7071, 0.7071, math.sin(a) * 0.7071),
                         intensity=2.0 / max(n, 1)))
    return tuple(out)


def shadow_rows(renderer, scene, config, counts=(1, 4), size=SIZE,
                map_sizes=MAP_SIZES) -> list[dict]:
    """One row per light count and map size: ms per frame with and without shadow maps, their
    ratio, the ratio with the maps kept (module doc), the shadow passes' own share and how many
    were drawn per frame."""
    rows = []
    for n, map_size in ((n, m) for n in counts for m in map_sizes):
        lit = dataclasses.replace(scene, lights=_lights(n)).with_camera(size=size)
        on_ms, on_pass = time_frames(renderer, lit.with_render(shadows=True, shadow_size=map_size),
                                     size, config)
        off_ms, _ = time_frames(renderer, lit.with_render(shadows=False), size, config)
        shadow_passes = [k for k in on_pass if k.startswith("shadow")]
        shadow_ms = sum(on_pass[k] for k in shadow_passes)
        rows.append({"kind": "shadows", "lights": n, "size": f"{size[0]}x{size[1]}",
                     "model": scene.render.model, "ms_shadows": on_ms, "ms_without": off_ms,
                     "ratio": on_ms / max(off_ms, 1e-9),
                     "ratio_maps_kept": (on_ms - shadow_ms) / max(off_ms, 1e-9),
                     "shadow_pass_ms": shadow_ms, "shadow_passes": len(shadow_passes),
                     "shadow_size": map_size})
    return rows
