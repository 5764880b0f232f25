"""``relight bench``'s anti-aliasing suite: what FXAA and supersampling cost per frame.

The bench's mesh scene at 512^2, whole frames (nothing reused) with ``aa = "none"``, ``"fxaa"``
and ``ssaa`` 2, all timed in the same run, so a row's ``ratio`` is the frame time relative to the
same frame without anti-aliasing (absolute milliseconds on a shared CPU are noise; the ratio is
the number to quote). The edge error each removes is measured by ``tests/viewer/test_antialias.py``.
"""
from __future__ import annotations

from .timing import time_frames

SIZE = (512, 512)


def antialias_rows(renderer, scene, config) -> list[dict]:
    """One row per setting: ms per frame, its ratio to no anti-aliasing, and the AA passes' own
    milliseconds (``fxaa``, ``ssaa_resolve``)."""
    scene = scene.with_camera(size=SIZE)
    base_ms, _ = time_frames(renderer, scene.with_render(aa="none"), SIZE, config)
    rows = []
    for label, render in (("fxaa", {"aa": "fxaa"}), ("ssaa 2", {"aa": "none", "ssaa": 2})):
        ms, per_pass = time_frames(renderer, scene.with_render(**render), SIZE, config)
        rows.append({"kind": "antialias", "setting": label, "size": f"{SIZE[0]}x{SIZE[1]}",
                     "model": scene.render.model, "ms": ms, "ms_without": base_ms,
                     "ratio": ms / max(base_ms, 1e-9),
                     "aa_pass_ms": per_pass.get("fxaa", 0.0) + per_pass.get("ssaa_resolve", 0.0)})
    return rows
