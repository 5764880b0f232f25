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

Extra suites (Monte-Carlo convergence, splats, neural) add their rows through :data:`SUITES`.
"""
from __future__ import annotations

import csv
import dataclasses
import json
import math
import os
import platform
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from viewer.errors import RelightError
from viewer.geometry.imagespace import ImageGBuffer, save_stack_exr
from viewer.gl import gl_info
from viewer.imageio import read_image, write_exr
from viewer.models import MODELS
from viewer.renderer import Renderer
from viewer.scene import ObjectSpec, Scene
from viewer.splats.generate import sphere_splats
from viewer.splats.ply import write_ply

from . import metrics
from .clamps import clamp_costs
from .mc import mc_convergence
from .scenes import bench_scene, demo_scene, with_object
from .specialize import measure_specialization
from .timing import time_frames
from .truth import (
    TRUTH_KEYS,
    converged_mc,
    truth_cases,
    truth_front,
    truth_row,
    truth_scenes,
    truth_summary,
)

RESULT_KEYS = ("scene", "model", "variant", "samples", "size", "ms", "psnr", "ssim", "flip")
CSV_KEYS = RESULT_KEYS + ("kind", "group") + TRUTH_KEYS


@dataclass(frozen=True)
class BenchConfig:
    quick: bool = False
    frames: int = 10  # timed frames per case (after warm-up)
    warmup: int = 2
    reference_spp: int = 1024  # samples per pixel of the converged ggx_mc reference
    truth_spp: int = 4096  # samples per pixel of the converged ggx_mc on the reference scenes
    truth: bool = True  # measure against the path-traced references (relight.bench.truth)
    # held-out datasets with path-traced targets (relight.bench.heldout): every model's scores and
    # Pareto front on each
    heldout: tuple[str, ...] = ()

    @property
    def sizes(self) -> list[tuple[int, int]]:
        return [(160, 100)] if self.quick else [(256, 160), (512, 320)]


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
        elif name == "ggx_mc":
            # every strategy's convergence is its own table (the mc_convergence suite)
            spps = (1, 4, 16, 64) if config.quick else (1, 4, 16, 64, 256)
            strategies = ("uniform", "mis") if config.quick else ("uniform", "cosine", "brdf",
                                                                  "env", "mis")
            for sampling in strategies:
                for spp in spps:
                    cases.append((name, f"{sampling} {spp}spp",
                                  {"sampling": sampling, "samples": spp}))
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


def _suite_mc(renderer, scenes, config, cache) -> list[dict]:
    """Error vs samples per pixel for every sampling strategy (thesis ch. 5: uniform vs importance
    sampling, measured), and time per sample, on the mesh scene."""

    if "ggx_mc" not in MODELS:
        return []
    scene = scenes["mesh"].with_camera(size=config.sizes[0])
    spps = (1, 4, 16, 64) if config.quick else (1, 4, 16, 64, 256)
    return mc_convergence(renderer, scene, spp_list=spps, reference_spp=config.reference_spp)


def _suite_splats(renderer, scenes, config, cache) -> list[dict]:
    """Splats per second including sorting (CPU and GPU sort) and GLSL vs the torch twin."""
    try:
        from .splats import glsl_vs_torch, splat_throughput
    except ImportError:
        return []
    counts = (10_000, 100_000) if config.quick else (10_000, 100_000, 1_000_000)
    rows = splat_throughput(renderer.programs, counts=counts, size=512,
                            frames=2 if config.quick else 3)
    try:
        rows += glsl_vs_torch(renderer.programs)
    except ImportError:  # no torch: the GLSL rows only
        pass
    return rows


def _suite_neural(renderer, scenes, config, cache) -> list[dict]:
    """Student vs teacher (128 samples): frame-time ratio and PSNR; GLSL vs torch MLP throughput."""

    if "neural" not in MODELS:
        return []
    from .neural import neural_rows

    return neural_rows(renderer, quick=config.quick)


def _suite_heldout(renderer, scenes, config, cache) -> list[dict]:
    """Every model against path-traced truth on the held-out datasets of ``config.heldout``
    (:mod:`relight.bench.heldout`), with each dataset's Pareto front marked."""
    if not config.heldout:
        return []
    from .heldout import heldout_rows

    return heldout_rows(renderer, config.heldout)


def _suite_clamps(renderer, scenes, config, cache) -> list[dict]:
    """What each shading clamp (roughness, n.v, ACES input, dfg.y) costs against an unclamped
    reference (:mod:`relight.bench.clamps`)."""

    return clamp_costs(renderer, config)


# Extra suites, each a section of bench.json and a table of bench.md:
# name -> callable(renderer, scenes, config, cache) -> list[row dict]
SUITES: dict[str, Callable] = {"mc_convergence": _suite_mc, "splats": _suite_splats,
                               "neural": _suite_neural, "clamps": _suite_clamps,
                               "heldout": _suite_heldout}


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


# ---- reports ------------------------------------------------------------------------------

def pareto_front(rows: list[dict]) -> list[dict]:
    """Rows not dominated in (lower ms, higher PSNR), per scene and size, sorted by time."""
    front = []
    groups: dict[tuple, list[dict]] = {}
    for r in rows:
        if r.get("kind") == "truth":  # their fronts: relight.bench.truth.truth_front
            continue
        if math.isfinite(r.get("ms", float("nan"))) and math.isfinite(r.get("psnr", float("nan"))):
            groups.setdefault((r["scene"], tuple(r["size"])), []).append(r)
    for group in groups.values():
        best = -math.inf
        for r in sorted(group, key=lambda r: (r["ms"], -r["psnr"])):
            if r["psnr"] > best:
                front.append(r)
                best = r["psnr"]
    return front


def _fmt(v) -> str:
    if isinstance(v, float):
        if math.isnan(v):
            return "–"
        if math.isinf(v):
            return "∞"
        return f"{v:.4g}"
    if isinstance(v, (list, tuple)):
        return "x".join(str(x) for x in v)
    return str(v)


def _pct(v, signed: bool = False) -> str:
    if not isinstance(v, (int, float)) or not math.isfinite(v):
        return "–"
    return f"{100 * v:+.1f}" if signed else f"{100 * v:.1f}"


def _truth_tables(rows: list[dict]) -> list[str]:
    """bench.md's section against truth: per-case summaries (all reference scenes, then each
    group) with the Pareto fronts marked, then every row."""
    truth = [r for r in rows if r.get("kind") == "truth"]
    if not truth:
        return []
    intro = ("Every mesh case on the reference scenes (`assets/scenes/reference`, at the "
             "references' size), scored with `relight.reference.compare.score` against the "
             "path-traced reference (**truth**: Mitsuba 3, our BSDF, visibility and "
             "inter-reflection) and against a converged `ggx_mc` of the same scene (**mc**: the "
             "same integrand, no visibility). Median relative error and |bias| in %, means over "
             "scenes; worst bias signed; PSNR in dB (peak = the reference's 99.9th percentile); "
             "time ratio = median over scenes of ms / `ggx_split_sum` single-scatter's ms. "
             "★ / ☆: Pareto front in (time, median error) against truth / against mc.")
    lines = ["", "### against truth", "", intro]
    groups = [("all reference scenes", None)] + [
        (f"{g} scenes", g) for g in sorted({r.get("group") for r in truth if r.get("group")})]
    for title, group in groups:
        summary = truth_summary(rows, group)
        scenes = sorted({r["scene"] for r in truth if group is None or r.get("group") == group})
        ft = {(e["model"], e["variant"]) for e in truth_front(summary, "truth")}
        fm = {(e["model"], e["variant"]) for e in truth_front(summary, "mc")}
        head = ("| model | variant | ms | time ratio | truth: median rel % | truth: abs bias % "
                "| truth: worst bias % | truth: PSNR | mc: median rel % | mc: abs bias % "
                "| mc: PSNR | pareto |")
        lines += ["", f"**{title}** ({', '.join(scenes)})", "", head, "|" + "---|" * 12]
        for e in summary:
            k = (e["model"], e["variant"])
            lines.append(
                f"| {e['model']} | {e['variant']} | {_fmt(e['ms'])} | {_fmt(e['ms_ratio'])} "
                f"| {_pct(e['median_rel_truth'])} | {_pct(e['abs_bias_truth'])} "
                f"| {_pct(e['worst_bias_truth'], True)} | {_fmt(e['psnr_truth'])} "
                f"| {_pct(e['median_rel_mc'])} | {_pct(e['abs_bias_mc'])} | {_fmt(e['psnr_mc'])} "
                f"| {'★' if k in ft else ''}{'☆' if k in fm else ''} |")
    head = ("| scene | model | variant | samples | size | ms | truth: median rel % "
            "| truth: bias % | truth: PSNR | mc: median rel % | mc: bias % | mc: PSNR |")
    lines += ["", "Every row:", "", head, "|" + "---|" * 12]
    for r in truth:
        lines.append(
            f"| {r['scene']} | {r['model']} | {r['variant']} | {r['samples']} | {_fmt(r['size'])} "
            f"| {_fmt(r.get('ms', math.nan))} | {_pct(r.get('median_rel_truth'))} "
            f"| {_pct(r.get('bias_truth'), True)} | {_fmt(r.get('psnr_truth', math.nan))} "
            f"| {_pct(r.get('median_rel_mc'))} | {_pct(r.get('bias_mc'), True)} "
            f"| {_fmt(r.get('psnr_mc', math.nan))} |")
    return lines


def write_reports(out: Path, report: dict) -> None:
    rows = report["results"]
    if any(r.get("kind") == "truth" for r in rows):
        groups = sorted({r.get("group") for r in rows if r.get("kind") == "truth"} - {None})
        report = {**report, "truth_summary": {g or "all": truth_summary(rows, g)
                                              for g in [None, *groups]}}
    (out / "bench.json").write_text(json.dumps(report, indent=1, allow_nan=True))
    with open(out / "bench.csv", "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(CSV_KEYS)
        for r in rows:
            w.writerow([_fmt(r.get(k, "")) for k in CSV_KEYS])
    front = {id(r) for r in pareto_front(rows)}
    lines = ["| " + " | ".join(RESULT_KEYS) + " | pareto |",
             "|" + "---|" * (len(RESULT_KEYS) + 1)]
    for r in rows:
        if r.get("kind") == "truth":
            continue
        lines.append("| " + " | ".join(_fmt(r.get(k, float("nan"))) for k in RESULT_KEYS)
                     + f" | {'★' if id(r) in front else ''} |")
    lines += _truth_tables(rows)
    if report.get("specialization"):
        lines += ["", "| scene | ms general | ms specialized | speed-up | max abs diff |",
                  "|---|---|---|---|---|"]
        for s in report["specialization"]:
            lines.append(f"| {s['scene']} | {_fmt(s['ms_general'])} | {_fmt(s['ms_specialized'])} "
                         f"| {_fmt(s['ms_general'] / s['ms_specialized'])}× "
                         f"| {_fmt(s['max_abs_diff'])} |")
    for name in SUITES:
        section = report.get(name) or []
        if not section:
            continue
        keys = list(dict.fromkeys(k for r in section for k in r if not isinstance(r[k], dict)))
        lines += ["", f"### {name}", "", "| " + " | ".join(keys) + " |",
                  "|" + "---|" * len(keys)]
        for r in section:
            lines.append("| " + " | ".join(_fmt(r.get(k, "")) for k in keys) + " |")
    m = report["machine"]
    header = (f"Measured on {m['gl'].get('renderer')} ({m['cpus']} CPUs, {m['platform']}), "
              f"{m['date']}. Times: median ms per frame; PSNR/SSIM on the display image and "
              f"HDR-FLIP on linear radiance against a converged `ggx_mc` reference.\n\n")
    (out / "bench.md").write_text(header + "\n".join(lines) + "\n")
    _plot(out / "pareto.png", rows)


def _plot(path: Path, rows: list[dict]) -> None:
    """pareto.png: a panel per bench scene (PSNR vs converged ``ggx_mc`` against time) and, with
    truth rows, a second row of two panels over the reference scenes: mean median relative error
    against the path-traced reference and against converged ``ggx_mc``, against time."""
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:  # the bench extra is not installed: tables only
        return
    pts = [r for r in rows if r.get("kind") != "truth" and math.isfinite(r.get("ms", math.nan))
           and math.isfinite(r.get("psnr", math.nan))]
    summary = [e for e in truth_summary(rows) if math.isfinite(e["ms"])]
    if not pts and not summary:
        return
    scenes = sorted({(r["scene"], tuple(r["size"])) for r in pts})
    ncols = max(len(scenes), 2 if summary else 1)
    nrows = int(bool(scenes)) + int(bool(summary))
    fig, axes = plt.subplots(nrows, ncols, figsize=(5.5 * ncols, 4.5 * nrows), squeeze=False)
    models = sorted({r["model"] for r in pts} | {e["model"] for e in summary})
    colours = {m: plt.cm.tab10(i % 10) for i, m in enumerate(models)}
    front = {id(r) for r in pareto_front(rows)}
    for ax, (sname, size) in zip(axes[0], scenes):
        group = [r for r in pts if r["scene"] == sname and tuple(r["size"]) == size]
        for m in models:
            g = [r for r in group if r["model"] == m]
            if g:
                ax.scatter([r["ms"] for r in g], [r["psnr"] for r in g], color=colours[m],
                           label=m, s=22)
        f = sorted((r for r in group if id(r) in front), key=lambda r: r["ms"])
        ax.plot([r["ms"] for r in f], [r["psnr"] for r in f], "k--", lw=0.8, label="Pareto front")
        ax.set_xscale("log")
        ax.set_xlabel("ms per frame (log)")
        ax.set_ylabel("PSNR vs converged ggx_mc (dB)")
        ax.set_title(f"{sname} {size[0]}x{size[1]}")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7)
    if summary:
        n = len({r["scene"] for r in rows if r.get("kind") == "truth"})
        titles = {"truth": f"vs path-traced reference (visibility), mean of {n} scenes",
                  "mc": f"vs converged ggx_mc (same integrand), mean of {n} scenes"}
        for ax, ref in zip(axes[-1], ("truth", "mc")):
            good = [e for e in summary if math.isfinite(e[f"median_rel_{ref}"])
                    and e[f"median_rel_{ref}"] > 0]
            for m in models:
                g = [e for e in good if e["model"] == m]
                if g:
                    ax.scatter([e["ms"] for e in g], [100 * e[f"median_rel_{ref}"] for e in g],
                               color=colours[m], label=m, s=22)
            f = [e for e in truth_front(good, ref)]
            ax.plot([e["ms"] for e in f], [100 * e[f"median_rel_{ref}"] for e in f], "k--",
                    lw=0.8, label="Pareto front")
            for e in f:
                label = e["model"] + ("" if e["variant"] == "default" else f" {e['variant']}")
                ax.annotate(label,
                            (e["ms"], 100 * e[f"median_rel_{ref}"]), fontsize=6,
                            xytext=(3, 3), textcoords="offset points")
            ax.set_xscale("log")
            ax.set_yscale("log")
            ax.set_xlabel("ms per frame (log), median over scenes")
            ax.set_ylabel("median relative error (%, log)")
            ax.set_title(titles[ref], fontsize=10)
            ax.grid(alpha=0.3)
            ax.legend(fontsize=7)
        for ax in axes[-1][2:]:
            ax.axis("off")
    for ax in axes[0][len(scenes):] if scenes else []:
        ax.axis("off")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
