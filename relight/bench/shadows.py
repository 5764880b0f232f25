"""``relight bench``'s shadow suite: what shadow maps cost per frame.

The bench's mesh scene at 512^2 with 0, 1 and 4 shadowing directional lights, each frame timed
with shadows on and off in the same run (whole frames: nothing reused), so a row's ``ratio`` is
the cost of the shadow passes and lookups relative to the same frame without them. Absolute
milliseconds on a shared CPU are noise; the ratio measured in one run is the number to quote.
"""
from __future__ import annotations

import dataclasses
import math

from viewer.lights import Light

from .timing import time_frames

SIZE = (512, 512)


def _lights(n: int) -> tuple[Light, ...]:
    """``n`` directional lights spread around the sky, 45 degrees up."""
    out = []
    for i in range(n):
        a = 2.0 * math.pi * i / max(n, 1)
        out.append(Light(direction=(math.cos(a) * 0.7071, 0.7071, math.sin(a) * 0.7071),
                         intensity=2.0 / max(n, 1)))
    return tuple(out)


def shadow_rows(renderer, scene, config, counts=(1, 4)) -> list[dict]:
    """One row per light count: ms per frame with and without shadow maps, their ratio, and
    the shadow passes' own share."""
    rows = []
    for n in counts:
        lit = dataclasses.replace(scene, lights=_lights(n)).with_camera(size=SIZE)
        on_ms, on_pass = time_frames(renderer, lit.with_render(shadows=True), SIZE, config)
        off_ms, _ = time_frames(renderer, lit.with_render(shadows=False), SIZE, config)
        shadow_ms = sum(v for k, v in on_pass.items() if k.startswith("shadow"))
        rows.append({"kind": "shadows", "lights": n, "size": f"{SIZE[0]}x{SIZE[1]}",
                     "model": scene.render.model, "ms_shadows": on_ms, "ms_without": off_ms,
                     "ratio": on_ms / max(off_ms, 1e-9), "shadow_pass_ms": shadow_ms,
                     "shadow_size": scene.render.shadow.size})
    return rows
