"""Splat benchmarks (rows for ``relight bench``): GLSL splats per second including sorting, CPU vs
GPU sort, and the GLSL pass against the torch twin on the same scene.

Each function returns ``list[dict]`` rows: ``{"scene", "splats", "size", "sort", "ms",
"splats_per_s", ...}``. Times are wall-clock medians with ``ctx.finish()`` after each frame, and
every frame re-sorts (the camera orbits), so sorting is always included.
"""
from __future__ import annotations

import math
import time

import numpy as np

from viewer.gbuffer import GBufferLayout
from viewer.scene.camera import Camera


def _orbit(i: int, size: int) -> Camera:
    a = 0.15 * i
    return Camera(position=(3.0 * math.sin(a), 0.4, 3.0 * math.cos(a)), target=(0, 0, 0),
                  fov_y=45.0, size=(size, size))


def _scale_range(n: int) -> tuple[float, float]:
    # keep the covered area roughly constant: splat size ~ n^(-1/3)
    s = 0.05 * (10_000 / n) ** (1 / 3)
    return (0.1 * s, s)


def splat_throughput(programs, counts=(10_000, 100_000, 1_000_000), size: int = 512,
                     sorts=("cpu", "gpu"), frames: int = 3, sh_degree: int = 1) -> list[dict]:
    """GLSL splat pass (projection + sort + raster + resolve) at ``size``^2 per count and sort."""
    from viewer.passes.gbuffer import GBufferTargets
    from viewer.passes.splats import SplatPass
    from viewer.splats.generate import random_cloud

    layout = GBufferLayout(with_color=True)
    ctx = programs.ctx
    targets = GBufferTargets.create(ctx, layout, (size, size))
    spass = SplatPass(programs, layout)
    rows = []
    try:
        for n in counts:
            splats = random_cloud(n, sh_degree=sh_degree, scale_range=_scale_range(n))
            for sort in sorts:
                times, sort_times = [], []
                for i in range(frames + 1):  # first frame: upload and compile
                    cam = _orbit(i, size)
                    ctx.finish()
                    t0 = time.perf_counter()
                    spass.prepare(splats, cam, sort)
                    ctx.finish()
                    t1 = time.perf_counter()
                    targets.clear()
                    spass.draw(targets, cam, splats, sort)
                    ctx.finish()
                    t2 = time.perf_counter()
                    if i:
                        times.append(t2 - t0)
                        sort_times.append(t1 - t0)
                ms = 1e3 * float(np.median(times))
                rows.append({"scene": "random_cloud", "splats": n, "size": size, "sort": sort,
                             "ms": ms, "project_sort_ms": 1e3 * float(np.median(sort_times)),
                             "splats_per_s": n / (ms / 1e3)})
            spass._forget(splats)
    finally:
        spass.release()
        targets.release()
    return rows


def glsl_vs_torch(programs, n: int = 10_000, size: int = 128, frames: int = 2) -> list[dict]:
    """The same scene through the GLSL pass and the torch twin; ``speedup`` = torch / GLSL."""
    import torch

    from learned.splats.rasterize import rasterize, splat_tensors
    from viewer.passes.gbuffer import GBufferTargets
    from viewer.passes.splats import SplatPass
    from viewer.splats.generate import random_cloud

    splats = random_cloud(n, sh_degree=3, scale_range=_scale_range(n))
    layout = GBufferLayout(with_color=True)
    targets = GBufferTargets.create(programs.ctx, layout, (size, size))
    spass = SplatPass(programs, layout)
    gl_t, torch_t = [], []
    try:
        for i in range(frames + 1):
            cam = _orbit(i, size)
            programs.ctx.finish()
            t0 = time.perf_counter()
            targets.clear()
            spass.draw(targets, cam, splats)
            targets.read()
            t1 = time.perf_counter()
            if i:
                gl_t.append(t1 - t0)
        tensors = splat_tensors(splats)
        for i in range(1, frames + 1):
            t0 = time.perf_counter()
            with torch.no_grad():
                rasterize(tensors, _orbit(i, size))
            torch_t.append(time.perf_counter() - t0)
    finally:
        spass.release()
        targets.release()
    g, t = 1e3 * float(np.median(gl_t)), 1e3 * float(np.median(torch_t))
    return [{"scene": "random_cloud", "splats": n, "size": size, "sort": "cpu", "impl": "glsl",
             "ms": g, "splats_per_s": n / (g / 1e3)},
            {"scene": "random_cloud", "splats": n, "size": size, "sort": "cpu", "impl": "torch",
             "ms": t, "splats_per_s": n / (t / 1e3), "speedup": t / g}]
