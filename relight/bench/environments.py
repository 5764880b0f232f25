"""``relight bench``'s environment-loading suite: what a new environment costs before its first
frame, by the current method (the GGX prefilter by convolution, one chain for both IBLs, the disk
cache: :mod:`viewer.environment.store`) and by the method before it (two chains by importance sampling
with 1024-65536 samples per texel, no disk cache: ``IBLOptions.legacy()``), in the same run.

Rows (``case``):

* ``warm process, new file, first frame``: a renderer that has drawn a frame under another
  environment draws the demo scene (256x256, ``ggx_split_sum`` with its sun light) under an EXR it
  has never seen, a 2048x1024 sky with a sun (:func:`viewer.environment.maps.sky_environment`, each run
  a new file: another sun azimuth); ``ms`` is that first frame, ``env_ms`` the part spent in the
  environment store. The current method writes the disk cache (an empty one) as it goes.
* ``new process, same file, environment part``: a new Python process (context, shaders and all)
  asks its store for the same file's IBLs; ``env_ms`` counts from the store's creation to both
  IBLs on the GPU: by the method before, by the current one without the disk cache, and with it.

``relight bench`` runs it as its ``environments`` suite (a table in ``bench.md``), with the rows of
:mod:`relight.bench.env_diffuse` (the diffuse term against the exact convolution); alone:
``python -m relight.bench.environments --out DIR`` (``--width``, ``--runs``, ``--legacy-runs``).
It is a benchmark: tests check the rows' correctness (every case measured, the disk cache hit where
it should be), never the times.
"""
from __future__ import annotations

import dataclasses
import json
import os
import statistics
import subprocess
import sys
import time
from pathlib import Path

from viewer.environment.disk_cache import EnvCache
from viewer.environment.ibl import IBLOptions
from viewer.environment.maps import EnvironmentSpec, sky_environment
from viewer.environment.store import EnvironmentStore
from viewer.imageio import write_exr

SIZE = (256, 256)
METHODS = {"fis": "importance sampling, 2 chains (before)",
           "convolution": "convolution, 1 chain + sun",
           "convolution+disk": "convolution + disk cache"}


class TimedStore(EnvironmentStore):
    """An :class:`EnvironmentStore` that adds up the wall time of every request (environment
    work happens only inside them), GPU work included (each request ends with glFinish)."""

    elapsed = 0.0

    def _timed(self, fn, *args, **kw):
        t0 = time.perf_counter()
        try:
            return fn(*args, **kw)
        finally:
            self.programs.ctx.finish()
            self.elapsed += time.perf_counter() - t0

    def ibl(self, spec, sun=False):
        return self._timed(super().ibl, spec, sun)

    def sun(self, spec):
        return self._timed(super().sun, spec)

    def lights(self, spec):
        return self._timed(super().lights, spec)

    def env_sampling(self, spec):
        return self._timed(super().env_sampling, spec)

    def power_directions(self, spec):
        return self._timed(super().power_directions, spec)


def install(renderer, store: EnvironmentStore) -> None:
    """Make ``renderer`` take its environments from ``store`` instead of its own store (released
    here; ``store`` is released with the renderer)."""
    res = renderer.resources
    res.env.release()
    res.env = store


def _options(method: str) -> IBLOptions:
    return IBLOptions.legacy() if method == "fis" else IBLOptions()


def sky_files(folder: Path, width: int, count: int, tag: str) -> list[Path]:
    """``count`` distinct ``width``-wide sky EXRs with a sun (the azimuth differs per file)."""
    folder.mkdir(parents=True, exist_ok=True)
    out = []
    for i in range(count):
        path = folder / f"env_{tag}_{width}_{i}.exr"
        if not path.exists():
            write_exr(path, sky_environment(width, sun_azimuth_deg=30.0 + 11.0 * i))
        out.append(path)
    return out


def warm_first_frame(ctx, path: Path, method: str, disk_dir: Path | None,
                     size=SIZE) -> dict:
    """One first frame under ``path`` in a warm renderer (see the module doc)."""
    from relight.bench.scenes import demo_scene
    from viewer.renderer import Renderer

    r = Renderer(ctx=ctx)
    r.reuse_passes = False
    disk = EnvCache(disk_dir) if disk_dir is not None else None
    store = TimedStore(r.programs, options=_options(method), disk=disk)
    try:
        install(r, store)
        scene = demo_scene().with_camera(size=tuple(size))
        r.render(scene)  # warm: programs compiled, another environment loaded
        store.elapsed = 0.0
        new = dataclasses.replace(scene, environment=EnvironmentSpec(path=str(path)))
        ctx.finish()
        t0 = time.perf_counter()
        r.render(new)
        ctx.finish()
        ms = 1000.0 * (time.perf_counter() - t0)
        return {"ms": ms, "env_ms": 1000.0 * store.elapsed,
                "disk_hits": disk.hits if disk is not None else 0}
    finally:
        r.release()  # and the store installed in it


def _child(args: dict) -> dict:
    """In a new process: the environment part of ``args["path"]`` (store created, both IBLs)."""
    t0 = time.perf_counter()
    from viewer.gl import Programs, create_context

    ctx = create_context()
    programs = Programs(ctx)
    t1 = time.perf_counter()
    disk = EnvCache(args["disk"]) if args.get("disk") else None
    store = EnvironmentStore(programs, options=_options(args["method"]), disk=disk)
    spec = EnvironmentSpec(path=args["path"])
    store.ibl(spec, sun=True)
    store.ibl(spec)
    ctx.finish()
    t2 = time.perf_counter()
    out = {"env_ms": 1000.0 * (t2 - t1), "context_ms": 1000.0 * (t1 - t0),
           "disk_hits": disk.hits if disk is not None else 0}
    store.release()
    return out


def new_process(path: Path, method: str, disk_dir: Path | None) -> dict:
    """:func:`_child` in a new Python process."""
    args = {"path": str(path), "method": method, "disk": str(disk_dir) if disk_dir else None}
    env = dict(os.environ, RELIGHT_ENV_CACHE="0")  # only the cache named in args
    proc = subprocess.run([sys.executable, "-m", "relight.bench.environments", "--child",
                           json.dumps(args)], capture_output=True, text=True, env=env,
                          timeout=3600)
    if proc.returncode != 0:
        tail = " ".join(proc.stderr.strip().splitlines()[-1:])
        raise RuntimeError(f"environment bench child failed ({tail})")
    return json.loads(proc.stdout.strip().splitlines()[-1])


def environment_rows(ctx, cache: Path, width: int = 2048, runs: int = 3, legacy_runs: int = 1,
                     size=SIZE, progress: bool = False) -> list[dict]:
    """The suite's rows (module doc): ``runs`` files per method (``legacy_runs`` for the method
    before, which takes minutes at 2048 on llvmpipe), median and range over them."""
    folder = cache / "environments"
    files = sky_files(folder, width, max(runs, legacy_runs), "sky")
    label = f"sky {width}x{width // 2} EXR (sun)"
    rows = []

    def row(case, method, results):
        ms = [r.get("ms", r["env_ms"]) for r in results]
        env = [r["env_ms"] for r in results]
        return {"case": case, "map": label, "method": METHODS[method], "runs": len(results),
                "ms": statistics.median(ms), "min_ms": min(ms), "max_ms": max(ms),
                "env_ms": statistics.median(env),
                "disk_hits": min(r["disk_hits"] for r in results)}

    def say(text):
        if progress:
            print(f"bench: environments: {text}", file=sys.stderr, flush=True)

    disks = {}
    for method in ("fis", "convolution+disk"):
        n = legacy_runs if method == "fis" else runs
        results = []
        for i, path in enumerate(files[:n]):
            disk = None
            if method.endswith("+disk"):  # an empty cache per file: a miss, then written
                disk = folder / f"disk_{width}_{i}"
                _empty(disk)
                disks[path] = disk
            say(f"{METHODS[method]}, first frame under {path.name}")
            results.append(warm_first_frame(ctx, path, method, disk, size))
        rows.append(row("warm process, new file, first frame", method, results))
    for method in ("fis", "convolution", "convolution+disk"):
        n = legacy_runs if method == "fis" else runs
        results = []
        for path in files[:n]:
            say(f"{METHODS[method]}, new process, {path.name}")
            results.append(new_process(path, method.split("+")[0],
                                       disks.get(path) if method.endswith("+disk") else None))
        rows.append(row("new process, same file, environment part", method, results))
    for r in rows:  # speed-up against the method before, per case
        base = next(b for b in rows if b["case"] == r["case"] and b["method"] == METHODS["fis"])
        key = "ms" if r["case"].endswith("first frame") else "env_ms"
        r["speedup"] = base[key] / r[key] if r[key] > 0 else float("nan")
    return rows


def _empty(folder: Path) -> None:
    if folder.exists():
        for p in folder.iterdir():
            p.unlink()
    folder.mkdir(parents=True, exist_ok=True)


def suite(renderer, scenes, config, cache) -> list[dict]:
    """``relight bench``'s ``environments`` suite (``--quick``: one run of each method), then
    the diffuse rows (:mod:`relight.bench.env_diffuse`)."""
    from .env_diffuse import diffuse_rows

    return environment_rows(renderer.ctx, Path(cache), width=2048,
                            runs=1 if config.quick else 3, legacy_runs=1,
                            progress=True) + diffuse_rows()


def table(rows: list[dict]) -> str:
    """The rows as a markdown table (what bench.md's section shows)."""
    keys = ("case", "map", "method", "runs", "ms", "min_ms", "max_ms", "env_ms", "speedup",
            "disk_hits")
    lines = ["| " + " | ".join(keys) + " |", "|" + "---|" * len(keys)]
    for r in rows:
        lines.append("| " + " | ".join(f"{r[k]:.4g}" if isinstance(r[k], float) else str(r[k])
                                       for k in keys) + " |")
    return "\n".join(lines)


def main(argv=None) -> int:
    """``python -m relight.bench.environments --out DIR``: this suite alone (``environments.json``
    and a table on stdout); ``--child`` is the new-process rows' own entry point."""
    import argparse

    p = argparse.ArgumentParser(prog="python -m relight.bench.environments",
                                description="environment loading: first frame and new-process "
                                            "times, convolution + disk cache vs the method before")
    p.add_argument("--out", help="folder for environments.json and the generated EXRs")
    p.add_argument("--width", type=int, default=2048, help="EXR width (default 2048)")
    p.add_argument("--runs", type=int, default=3, help="files per current-method row")
    p.add_argument("--legacy-runs", type=int, default=1,
                   help="files per row of the method before (minutes each at 2048)")
    p.add_argument("--child", help=argparse.SUPPRESS)
    args = p.parse_args(argv)
    if args.child:
        print(json.dumps(_child(json.loads(args.child))))
        return 0
    if not args.out:
        p.error("--out is required")
    from viewer.gl import create_context

    out = Path(args.out)
    if not out.parent.exists():
        p.error(f"{out}: its parent folder does not exist")
    out.mkdir(exist_ok=True)
    rows = environment_rows(create_context(), out, width=args.width, runs=args.runs,
                            legacy_runs=args.legacy_runs, progress=True)
    (out / "environments.json").write_text(json.dumps(rows, indent=1))
    print(table(rows))
    return 0


if __name__ == "__main__":
    sys.exit(main())
