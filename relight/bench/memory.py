"""``relight bench --memory``: resident memory under sweeps that used to grow without bound.

Three sweeps in one process each (a fresh renderer per sweep): the demo at 150 widths
(320..469 x 240, a window dragged wider), 20 distinct environments, 50 distinct meshes. Each row
records resident memory (RSS) after the 10th step and after the last, the renderer's cache bytes
(``Renderer.memory()``) and the live GL objects the renderer holds. The bound they demonstrate:
RSS after the last step at most :data:`RSS_GROWTH_BOUND` above that after the 10th.
"""
from __future__ import annotations

import dataclasses
import gc
import os
import time
from pathlib import Path

RSS_GROWTH_BOUND = 150 << 20  # bytes


def rss_bytes() -> int:
    """Resident set size of this process (Linux /proc; 0 where it is not available)."""
    try:
        with open(f"/proc/{os.getpid()}/statm") as f:
            return int(f.read().split()[1]) * os.sysconf("SC_PAGE_SIZE")
    except (OSError, ValueError, IndexError):
        return 0


def _row(name: str, steps: int, rss: list[int], renderer, seconds: float) -> dict:
    mem = renderer.memory()
    return {"kind": "memory", "sweep": name, "steps": steps,
            "rss_after_10_mb": rss[9] / 2**20, "rss_after_last_mb": rss[-1] / 2**20,
            "growth_mb": (rss[-1] - rss[9]) / 2**20,
            "bound_mb": RSS_GROWTH_BOUND / 2**20, "holds": rss[-1] - rss[9] <= RSS_GROWTH_BOUND,
            "cache_mb": {k: round(s.bytes / 2**20, 2) for k, s in mem.items()},
            "seconds": seconds}


def _sweep(name: str, make_renderer, steps: int, draw, progress=None) -> dict:
    """``steps`` frames of a fresh renderer, ``draw(renderer, i)`` each; RSS after each."""
    renderer = make_renderer()
    rss, t0 = [], time.perf_counter()
    try:
        for i in range(steps):
            draw(renderer, i)
            renderer.ctx.finish()
            gc.collect()
            rss.append(rss_bytes())
            if progress:
                progress(name, i + 1, steps)
        return _row(name, steps, rss, renderer, time.perf_counter() - t0)
    finally:
        renderer.release()


def sweep_widths(make_renderer, scene, steps: int = 150, progress=None) -> dict:
    """The demo at ``steps`` widths 320.. x 240."""
    return _sweep("widths", make_renderer, steps,
                  lambda r, i: r.draw(scene, size=(320 + i, 240)), progress)


def sweep_environments(make_renderer, scene, folder: Path, steps: int = 20, progress=None) -> dict:
    """``steps`` distinct 1k x 512 environment files (a sky with the sun moved each time)."""
    from viewer.environment.maps import EnvironmentSpec, sky_environment
    from viewer.imageio import write_exr

    def draw(renderer, i):
        path = Path(folder) / f"env{i:03d}.exr"
        if not path.exists():
            write_exr(path, sky_environment(1024, 15.0 + 3.0 * i, 17.0 * i), ["R", "G", "B"])
        renderer.draw(dataclasses.replace(scene, environment=EnvironmentSpec(path=str(path))),
                      size=(256, 192))
    return _sweep("environments", make_renderer, steps, draw, progress)


def sweep_meshes(make_renderer, scene, steps: int = 50, progress=None) -> dict:
    """``steps`` distinct meshes (in memory, 65k triangles each), one at a time."""
    from viewer.geometry.primitives import sphere
    from viewer.scene.description import ObjectSpec

    def draw(renderer, i):
        obj = ObjectSpec(type="mesh", path=f"in-memory-mesh-{i}")
        mesh = sphere(center=(0.0, 0.5, 0.0), radius=0.4 + 0.002 * i, segments=256, rings=128)
        renderer.add_geometry(obj, [mesh])
        renderer.draw(dataclasses.replace(scene, objects=scene.objects[:1] + (obj,)),
                      size=(256, 192))
    return _sweep("meshes", make_renderer, steps, draw, progress)


def memory_rows(make_renderer, scene, folder: Path, progress=None) -> list[dict]:
    """The three sweeps' rows."""
    Path(folder).mkdir(parents=True, exist_ok=True)
    return [sweep_widths(make_renderer, scene, progress=progress),
            sweep_environments(make_renderer, scene, folder, progress=progress),
            sweep_meshes(make_renderer, scene, progress=progress)]

