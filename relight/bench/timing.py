"""Frame timing for the benchmarks: every pass fenced by :class:`viewer.gl.timing.PassTimer`."""
from __future__ import annotations

import statistics

from viewer.gl.timing import PassTimer
from viewer.scene import Scene


def time_frames(renderer, scene: Scene, size, config) -> tuple[float, dict]:
    """Median ms per frame (sum of passes, precomputation excluded) and per pass, over
    ``config.frames`` frames after ``config.warmup`` (a :class:`relight.bench.run.BenchConfig`)."""
    timer = renderer.profiler if isinstance(renderer.profiler, PassTimer) else PassTimer(renderer.ctx)
    renderer.profiler = timer
    per_pass: dict[str, list[float]] = {}
    totals = []
    with renderer.every_pass():  # whole frames: nothing reused from the frame before
        for i in range(config.warmup + config.frames):
            timer.enabled = True
            timer.reset()
            renderer.draw(scene, size)
            ms = {k: v for k, v in timer.milliseconds().items() if k != "ibl"}
            if i >= config.warmup:
                totals.append(sum(ms.values()))
                for k, v in ms.items():
                    per_pass.setdefault(k, []).append(v)
    timer.enabled = False
    return statistics.median(totals), {k: statistics.median(v) for k, v in per_pass.items()}
