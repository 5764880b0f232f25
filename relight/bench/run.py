"""``relight bench``: the speed-accuracy trade of every shading model, measured.

For every shading model and its knobs (samples, sampling strategy, multiscatter, G-buffer precision,
resolution) on a fixed set of scenes (a mesh scene, an image-space G-buffer stack, splats when the
splat renderer is present), the benchmark records the median time per frame and per pass (at least
10 frames after warm-up; fenced wall clock on llvmpipe, timer queries on GPUs — see
:mod:`viewer.gl.timing`) and the error against a converged Monte-Carlo ``ggx_mc`` reference of the
same scene (PSNR and SSIM on the display image, RMSE and HDR-FLIP on linear radiance).

Against truth (:mod:`relight.bench.truth`): on every reference scene with a stored path-traced
reference (``assets/scenes/reference``; ``--quick``: four of them), every mesh case is also timed
at the reference's size and scored against the path-traced reference (visibility and
inter-reflection included) and against a converged ``ggx_mc`` of the same scene (the same
integrand, no visibility): energy bias, median relative error, PSNR. These rows carry
``kind = "truth"``; the tables get their columns and ``pareto.png`` a panel for each reference.

Outputs in ``DIR``: ``bench.json`` (``{"machine", "results", "specialization"}``), ``bench.csv``,
``bench.md`` and ``pareto.png`` (error vs time). Rows are appended to ``rows.jsonl`` as they are
measured, so an interrupted run resumes where it stopped (``--fresh`` starts over).

Extra suites (Monte-Carlo convergence, splats, neural, clamps, held-out data, environment loading)
add their rows through :data:`relight.bench.suites.SUITES`; the reports are written by
:mod:`relight.bench.report`.
"""
from __future__ import annotations

import dataclasses
import json
import os
import platform
import sys
import time
from pathlib import Path

import numpy as np

from viewer.errors import RelightError
from viewer.geometry.imagespace import ImageGBuffer, save_stack_exr
from viewer.gl import gl_info
from viewer.imageio import read_image, write_exr
from viewer.models import MODELS
from viewer.renderer import Renderer
from viewer.scene.description import ObjectSpec, Scene
from viewer.splats.generate import sphere_splats
from viewer.splats.ply import write_ply

from . import metrics
from .config import BenchConfig  # noqa: F401 - re-exported
from .report import CSV_KEYS, RESULT_KEYS, pareto_front, write_reports  # noqa: F401 - re-exported
from .scenes import bench_scene, demo_scene, with_object
from .specialize import measure_specialization
from .suites import SUITES
from .timing import time_frames
from .truth import converged_mc, truth_cases, truth_row, truth_scenes


def _bench_scenes(cache: Path, quick: bool) -> dict[str, Scene]:
    scenes = {"mesh": demo_scene()}
    scenes["gbuffer"] = _stack_scene(cache)  # renders at the bench size: see _scene_at
    scenes["splats"] = _splat_scene(cache, quick)
    return scenes


def _stack_scene(cache: Path, size: tuple[int, int] = (512, 320)) -> Scene:
    """An image-space G-buffer stack made by the project: the G-buffer of
    ``assets/scenes/bench/stack_capture.toml`` (a material grid seen from the stack camera),
    saved as a 12-channel EXR (depth normalised, near 1, far 800). A stack renders at its own
    size, so there is one per bench size (:func:`_scene_at`)."""
    path = cache / f"stack_{size[0]}x{size[1]}.exr"
    capture = bench_scene("stack_capture")
    if not path.exists():
        r = Renderer()
        try:
            aovs = ("albedo", "normal", "roughness", "specular", "metallic", "depth", "ao", "alpha")
            frame = r.render(capture.with_camera(size=tuple(size)), aovs=aovs)
        finally:
            r.release()
        save_stack_exr(path, ImageGBuffer(channels=dict(frame.aovs), fov_y=capture.camera.fov_y))
    return dataclasses.replace(capture, objects=(ObjectSpec("gbuffer", path=str(path)),))


def _scene_at(scenes: dict, name: str, size, cache: Path) -> tuple[Scene, tuple | None]:
    """The scene and the ``size`` argument to render it at ``size`` (stacks carry their own)."""
    if name == "gbuffer":
        return _stack_scene(cache, tuple(size)), None
    return scenes[name], size


def _splat_scene(cache: Path, quick: bool) -> Scene:
    """``assets/scenes/bench/splats.toml`` with a generated cloud of flat Gaussians on a sphere."""
    n = 20_000 if quick else 100_000
    path = cache / f"splats_{n}.ply"
    if not path.exists():
        write_ply(path, sphere_splats(n=n, radius=0.8))
    return with_object(bench_scene("splats"), ObjectSpec("splats", path=str(path)))


def _cases(config: BenchConfig) -> list[tuple[str, str, dict]]:
    """(model, variant, render-setting changes) for every model in the registry."""

    cases: list[tuple[str, str, dict]] = []
    for name in MODELS:
        if name == "ggx_split_sum":
            cases.append((name, "multiscatter", {"multiscatter": True}))
            cases.append((name, "single-scatter", {"multiscatter": False}))
            # the environment's sun in the prefiltered chain instead of an analytic light
            cases.append((name, "single-scatter, no sun light", {"multiscatter": False,
                                                                  "sun": False}))
            cases.append((name, "multiscatter fp16", {"multiscatter": True, "precision": "fp16"}))
            # the real-time tier: ray-traced visibility and one bounce ([render] raytrace)
            cases.append((name, "multiscatter +rays", {"multiscatter": True, "raytrace": True}))
            if not config.quick:
                cases.append((name, "multiscatter +rays x4", {"multiscatter": True,
                                                              "raytrace": True,
                                                              "raytrace_rays": 4}))
                cases.append((name, "multiscatter +rays undenoised",
                              {"multiscatter": True, "raytrace": True,
                               "ray_denoise": False}))
                # rays for one pixel in 2 x 2, upsampled (ray_scale)
                cases.append((name, "multiscatter +rays 1/2 scale",
                              {"multiscatter": True, "raytrace": True, "ray_scale": 2}))
        elif name == "ggx_mc":
            # every strategy's convergence is its own table (the mc_convergence suite)
            spps = (1, 4, 16, 64) if config.quick else (1, 4, 16, 64, 256)
            strategies = ("uniform", "mis") if config.quick else ("uniform", "cosine", "brdf",
                                                                  "env", "mis")
            for sampling in strategies:
                for spp in spps:
                    cases.append((name, f"{sampling} {spp}spp",
                                  {"sampling": sampling, "samples": spp}))
        elif name == "path":  # --quick too reaches 64 spp: the front's converging end
            for spp in ((4, 16, 64) if config.quick else (4, 16, 64, 256)):
                cases.append((name, f"{spp}spp", {"samples": spp}))
        elif name == "neural_teacher":
            for spp in (8, 32, 128):
                cases.append((name, f"{spp}spp", {"samples": spp}))
        else:
            cases.append((name, "default", {}))
    return cases


# ---------------------------------------------------------------------------------------------

def _reference(renderer, scene: Scene, size, cache: Path, config: BenchConfig, name: str):
    """Converged ggx_mc radiance and display image of ``scene`` (cached on disk)."""

    if "ggx_mc" not in MODELS:
        return None
    path = cache / f"reference_{name}_{config.reference_spp}spp.exr"
    disp_path = path.with_suffix(".display.npy")
    if path.exists() and disp_path.exists():
        return read_image(path)[0], np.load(disp_path)
    ref_scene = scene.with_render(model="ggx_mc", samples=config.reference_spp, sampling="mis")
    frame = renderer.render(ref_scene, size=size)
    write_exr(path, frame.radiance)
    np.save(disp_path, frame.display)
    return frame.radiance, frame.display


def _errors(frame, ref) -> dict:
    if ref is None:
        return {"psnr": float("nan"), "ssim": float("nan"), "flip": float("nan"),
                "rmse": float("nan")}
    ref_rad, ref_disp = ref
    disp = frame.display[..., :3].astype(np.float64) / 255.0
    rdisp = ref_disp[..., :3].astype(np.float64) / 255.0
    return {"psnr": metrics.psnr(rdisp, disp), "ssim": metrics.ssim(rdisp, disp),
            "flip": metrics.hdr_flip(ref_rad[..., :3], frame.radiance[..., :3]),
            "rmse": metrics.rmse(ref_rad[..., :3], frame.radiance[..., :3])}


def _row_key(row: dict) -> tuple:
    return (row["scene"], row["model"], row["variant"], row["samples"], tuple(row["size"]))


def machine_info(renderer) -> dict:
    info = gl_info(renderer.ctx)
    info.pop("extensions", None)

    return {"gl": info, "python": sys.version.split()[0], "platform": platform.platform(),
            "cpu": platform.processor() or platform.machine(), "cpus": os.cpu_count(),
            "numpy": np.__version__, "date": time.strftime("%Y-%m-%d %H:%M:%S")}



def run_bench(out_dir: str | Path, config: BenchConfig = BenchConfig(), fresh: bool = False,
              progress: bool = True) -> dict:
    """Measure, write ``bench.json``/``bench.csv``/``bench.md``/``pareto.png`` and return the
    report dict."""
    from tqdm import tqdm


    out = Path(out_dir)
    if not out.parent.exists():
        raise RelightError("output folder's parent does not exist", where=out)
    out.mkdir(exist_ok=True)
    cache = out / "cache"
    cache.mkdir(exist_ok=True)
    rows_path = out / "rows.jsonl"
    if fresh and rows_path.exists():
        rows_path.unlink()
    if fresh:  # the converged ggx_mc of the reference scenes too (cheap; other caches persist)
        for p in cache.glob("truth_*"):
            p.unlink()
    done: dict[tuple, dict] = {}
    if rows_path.exists():
        for line in rows_path.read_text().splitlines():
            if line.strip():
                row = json.loads(line)
                done[_row_key(row)] = row

    renderer = Renderer()
    renderer.reuse_passes = False  # every row times whole frames; relight frames say so
    try:
        scenes = _bench_scenes(cache, config.quick)
        cases = _cases(config)
        jobs = [(sname, size, c) for sname in scenes for size in config.sizes for c in cases]
        rows = []
        with open(rows_path, "a") as log:
            bar = tqdm(jobs, desc="bench", unit="case", disable=not progress)
            for sname, size, (model, variant, changes) in bar:
                samples = int(changes.get("samples", 1))
                key = (sname, model, variant, samples, tuple(size))
                if key in done:
                    rows.append(done[key])
                    continue
                bar.set_postfix_str(f"{sname} {model} {variant} {size[0]}x{size[1]}")
                scene, render_size = _scene_at(scenes, sname, size, cache)
                case_scene = scene.with_render(model=model, **changes)
                try:
                    ref = _reference(renderer, scene, render_size, cache, config,
                                     f"{sname}_{size[0]}x{size[1]}")
                    ms, per_pass = time_frames(renderer, case_scene, render_size, config)
                    frame = renderer.render(case_scene, size=render_size)
                except RelightError as exc:  # a model that cannot run this scene: recorded
                    ms, per_pass, frame, ref = float("nan"), {}, None, None
                    note = str(exc)
                else:
                    note = ""
                err = _errors(frame, ref) if frame is not None else _errors(None, None)
                row = {"scene": sname, "model": model, "variant": variant, "samples": samples,
                       "size": list(size), "ms": ms, **err, "passes": per_pass}
                if note:
                    row["note"] = note
                rows.append(row)
                log.write(json.dumps(row) + "\n")
                log.flush()
            rows += _truth_rows(renderer, cases, config, cache, done, log, progress)
        sections = {}
        for name, suite in SUITES.items():
            path = out / f"{name}.json"
            if path.exists() and not fresh:  # resumable: a finished suite is not measured again
                sections[name] = json.loads(path.read_text())
                if name != "heldout" or _same_heldout(sections[name], config):
                    continue
            if progress:
                print(f"bench: {name} ...", file=sys.stderr, flush=True)
            sections[name] = suite(renderer, scenes, config, cache)
            path.write_text(json.dumps(sections[name], indent=1, allow_nan=True))

        specialization = measure_specialization(renderer, config, cache)
        report = {"machine": machine_info(renderer), "results": rows,
                  "specialization": specialization, **sections}
    finally:
        renderer.release()
    write_reports(out, report)
    return report


def run_suites(out_dir: str | Path, names: list[str], config: BenchConfig = BenchConfig(),
               progress: bool = True) -> dict[str, list[dict]]:
    """Only the extra suites ``names`` (of :data:`relight.bench.suites.SUITES`): each measured
    afresh and written to ``<out>/<name>.json`` and ``<out>/<name>.md`` (its table)."""
    from .report import suite_table

    unknown = [n for n in names if n not in SUITES]
    if unknown:
        raise RelightError(f"unknown bench suite {unknown[0]!r} (known: {', '.join(SUITES)})",
                           where="--suite")
    out = Path(out_dir)
    if not out.parent.exists():
        raise RelightError("output folder's parent does not exist", where=out)
    out.mkdir(exist_ok=True)
    cache = out / "cache"
    cache.mkdir(exist_ok=True)
    renderer = Renderer()
    renderer.reuse_passes = False
    sections = {}
    try:
        scenes = {"mesh": demo_scene()}  # what the extra suites read (no stack, no splats)
        for name in names:
            if progress:
                print(f"bench: {name} ...", file=sys.stderr, flush=True)
            sections[name] = SUITES[name](renderer, scenes, config, cache)
            (out / f"{name}.json").write_text(json.dumps(sections[name], indent=1,
                                                         allow_nan=True))
            m = machine_info(renderer)
            header = (f"Measured by `relight bench --suite {name}` on {m['gl'].get('renderer')} "
                      f"({m['cpus']} CPUs), {m['date']}.\n\n")
            (out / f"{name}.md").write_text(header + "\n".join(suite_table(sections[name]))
                                            + "\n")
    finally:
        renderer.release()
    return sections


def _same_heldout(rows: list[dict], config: BenchConfig) -> bool:
    """Whether stored held-out rows are of the datasets asked for now (else measured again)."""
    return {r.get("dataset_path") for r in rows} == {str(Path(d)) for d in config.heldout} \
        or (not rows and not config.heldout)


def _truth_rows(renderer, cases, config: BenchConfig, cache: Path, done: dict, log,
                progress: bool) -> list[dict]:
    """Every mesh case on every reference scene (:mod:`relight.bench.truth`); rows already in
    ``done`` are reused, new ones appended to ``log``. The path-traced reference is read and the
    converged ``ggx_mc`` rendered (or read from ``cache``) only for a scene with rows to measure."""
    from tqdm import tqdm

    from relight.reference import read_reference

    if not config.truth:
        return []
    tcases = truth_cases(cases, quick=config.quick)
    rows = []
    for ts in tqdm(truth_scenes(config.quick), desc="bench vs truth", unit="scene",
                   disable=not progress):
        truth = mc = scene = None
        for model, variant, changes in tcases:
            if truth is None:
                truth = read_reference(ts.reference)
            h, w = truth.radiance.shape[:2]
            key = (ts.name, model, variant, int(changes.get("samples", 1)), (w, h))
            if key in done:
                rows.append(done[key])
                continue
            if mc is None:
                scene = ts.scene
                mc = converged_mc(renderer, ts, cache, config.truth_spp)
            row = truth_row(renderer, ts, (model, variant, changes), truth, mc, config, scene)
            rows.append(row)
            log.write(json.dumps(row) + "\n")
            log.flush()
    return rows


