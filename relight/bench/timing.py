"""Frame timing for the benchmarks: every pass fenced by :class:`viewer.gl.timing.PassTimer`."""
from __future__ import annotations

import math
import statistics

from viewer.gl.timing import PassTimer
from viewer.scene.description import Scene


def time_frames(renderer, scene: Scene, size, config) -> tuple[float, dict]:
    """Median ms per frame (sum of passes, precomputation excluded) and per pass, over
    ``config.frames`` frames after ``config.warmup`` (a :class:`relight.bench.run.BenchConfig`)."""
    totals, per_pass = _frames(renderer, scene, size, config.frames, config.warmup)
    return statistics.median(totals), {k: statistics.median(v) for k, v in per_pass.items()}


def time_pair(renderer, a: Scene, b: Scene, size, config, rounds: int = 3
              ) -> tuple[tuple[float, dict], tuple[float, dict]]:
    """:func:`time_frames` of ``a`` and of ``b`` measured in alternating blocks (a, b, a, b, ...:
    ``rounds`` blocks each, of ``config.frames / rounds`` frames after ``config.warmup``), so
    that a shared CPU's drift over the run falls on both alike and their ratio is the frames'
    own, not the minute's; each a median over all its blocks' frames. Blocks, not single
    frames: each scene keeps its targets and programs warm as a viewer would (switching every
    frame would time the reallocation of a shadowed frame's maps instead)."""
    n = max(1, math.ceil(config.frames / rounds))
    out = [([], {}), ([], {})]
    for _ in range(rounds):
        for (totals, per_pass), scene in zip(out, (a, b)):
            t, p = _frames(renderer, scene, size, n, config.warmup)
            totals.extend(t)
            for k, v in p.items():
                per_pass.setdefault(k, []).extend(v)
    return tuple((statistics.median(t), {k: statistics.median(v) for k, v in p.items()})
                 for t, p in out)


def _frames(renderer, scene: Scene, size, frames: int, warmup: int) -> tuple[list, dict]:
    """Per-frame totals (ms) and per-pass lists over ``frames`` frames after ``warmup``."""
    timer = renderer.profiler if isinstance(renderer.profiler, PassTimer) else PassTimer(renderer.ctx)
    renderer.profiler = timer
    per_pass: dict[str, list[float]] = {}
    totals = []
    with renderer.every_pass():  # whole frames: nothing reused from the frame before
        for i in range(warmup + frames):
            timer.enabled = True
            timer.reset()
            renderer.draw(scene, size)
            ms = {k: v for k, v in timer.milliseconds().items() if k != "ibl"}
            if i >= warmup:
                totals.append(sum(ms.values()))
                for k, v in ms.items():
                    per_pass.setdefault(k, []).append(v)
    timer.enabled = False
    return totals, per_pass
