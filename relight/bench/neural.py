"""Benchmarks of the neural shaders (rows for ``relight bench``; not timed tests).

* :func:`student_vs_teacher`: frame time, lighting-pass time (the renderer's per-pass profiler,
  pass ``shade``) and PSNR against a Monte-Carlo reference (``ggx_mc``, many samples) of the
  student (``neural``), the GLSL teacher at ``teacher_samples`` samples (``neural_teacher``) and
  ``ggx_split_sum`` on one scene, at each size of ``sizes``. The teacher is no reference of
  accuracy: against path-traced truth it is 70 % too dark on the rough conductor of the
  reference scenes (bench "against truth": worst bias -70 % at 8, 32 and 128 spp), so the
  ratios teacher / student are timings of two models, not a speed-up at equal accuracy; a
  speed claim is made against truth at equal accuracy (the "against truth" table, where the
  split-sum model with SSAO and indirect light is both faster and closer to the truth than
  either network). Both ratios are reported: whole
  frames (G-buffer, SSAO, tone map included, which the two models share) and the lighting pass
  alone; the student also with its screen-space passes at reduced scale (``scales``:
  ``render.ssao_scale``), with its PSNR against its own full-scale image. ``relight_ms``: a frame
  after a light slider moved, when the renderer reuses the G-buffer and SSAO targets
  (:func:`time_relight_frame`): what an interactive relighting session pays per frame.
* :func:`student_designs`: the candidate student designs of the measured comparison
  (``assets/weights/students``, written by ``relight train --compare-students``), each through the
  real ``neural`` pass at 256x256: the MLP-size knob of the bench.
* :func:`student_throughput`: the student MLP alone, GLSL (compute kernel over ``pixels`` inputs,
  generated code) against torch on the same weights and inputs (goal: GLSL >= torch).
* :func:`weight_storage_rows`: each weight storage of the generated GLSL (baked constants, uniform
  / storage block, texture; ``viewer.neural.WEIGHT_STORAGES``) on the shipped student and on the
  issue's probe, a random 32-64-64-1 MLP, with torch on the same MLP and inputs: what chose the
  default storage.

Rows: ``{"model", "variant", "samples", "size", "ms", "psnr"}`` (+ extras, ``shade_ms`` the
lighting pass alone). Torch is imported only for the torch throughput row (``learned`` extra);
without it that row is left out.
"""
from __future__ import annotations

import dataclasses
import json
import statistics
import time
from pathlib import Path

import numpy as np

from assets import ASSET_ROOT
from viewer.gl.timing import PassTimer
from viewer.models import MODELS
from viewer.neural import (STUDENT_KERNEL_ENTRY, STUDENT_KERNEL_GROUP, WEIGHT_STORAGES,
                           NeuralWeights, default_weights, load_network, mlp_kernel)

from .metrics import psnr
from .scenes import bench_scene

def students_dir() -> Path:
    """Where the candidate student designs and their comparison table are shipped."""
    return ASSET_ROOT / "weights" / "students"


def time_frame(renderer, scene, repeats: int = 3) -> tuple[float, float, np.ndarray]:
    """(best wall ms of a whole frame, median ms of the ``shade`` pass, radiance ``[H, W, 3]``) of
    ``scene``; one warm-up render first (programs, IBL, sampling tables). Whole frames: every
    pass is drawn (``Renderer.every_pass``)."""
    frame = renderer.render(scene)
    best = float("inf")
    saved = renderer.profiler
    timer = saved if isinstance(saved, PassTimer) else PassTimer(renderer.ctx)
    shade = []
    with renderer.every_pass():
        for _ in range(repeats):
            renderer.ctx.finish()
            t0 = time.perf_counter()
            frame = renderer.render(scene)
            best = min(best, time.perf_counter() - t0)
        renderer.profiler = timer
        try:
            for _ in range(repeats):
                timer.enabled = True
                timer.reset()
                renderer.draw(scene)
                shade.append(timer.milliseconds().get("shade", float("nan")))
        finally:
            timer.enabled = False
            renderer.profiler = saved
    return 1e3 * best, statistics.median(shade), frame.radiance[..., :3]


def time_relight_frame(renderer, scene, repeats: int = 3) -> float:
    """Best wall ms of a frame after a light slider moved (the environment's intensity, 1 and
    1.001 in turn, so the lighting passes run every time) with everything else unchanged: the
    G-buffer and SSAO targets of the frame before are reused (``Renderer.reuse_passes``)."""
    saved, renderer.reuse_passes = renderer.reuse_passes, True
    env = scene.environment
    scenes = [dataclasses.replace(scene, environment=dataclasses.replace(
        env, intensity=env.intensity * f)) for f in (1.0, 1.001)]
    best = float("inf")
    try:
        renderer.render(scenes[1])  # warm: the targets and programs exist
        for i in range(repeats):
            renderer.ctx.finish()
            t0 = time.perf_counter()
            renderer.render(scenes[i % 2])
            best = min(best, time.perf_counter() - t0)
    finally:
        renderer.reuse_passes = saved
    return 1e3 * best


def _tm(x: np.ndarray) -> np.ndarray:
    x = np.clip(x, 0.0, None)
    return x / (1.0 + x)


def _reference(renderer, scene, samples: int) -> tuple[str, np.ndarray]:
    model = "ggx_mc" if "ggx_mc" in MODELS else "ggx_split_sum"
    img = renderer.render(scene.with_render(model=model, samples=samples,
                                            sampling="mis")).radiance[..., :3]
    return f"{model} {samples} spp", img


def student_vs_teacher(renderer, teacher_samples: int = 128, reference_samples: int = 1024,
                       repeats: int = 3, scene=None, sizes=(128,), scales=(2, 4)) -> list[dict]:
    base = scene or bench_scene("neural")
    rows = []
    for side in sizes:
        scene = base.with_camera(size=(int(side), int(side)))
        size = f"{side}x{side}"
        ref_name, ref = _reference(renderer, scene, reference_samples)
        part = []
        images = []
        cases = [("neural", "student", {}),
                 ("neural_teacher", "env", {"samples": teacher_samples, "sampling": "env"}),
                 ("ggx_split_sum", "", {})]
        # the student's screen-space passes at reduced scale (render.ssao_scale): its frame is
        # dominated by them
        cases += [("neural", f"student, SSAO 1/{k}", {"ssao_scale": k}) for k in scales]
        for model, variant, kw in cases:
            reps = 1 if model == "neural_teacher" and side > 256 else repeats
            case = scene.with_render(model=model, **kw)
            ms, shade_ms, img = time_frame(renderer, case, reps)
            images.append(img)
            part.append({"model": model, "variant": variant, "samples": kw.get("samples", 1),
                         "size": size, "ms": ms, "shade_ms": shade_ms,
                         "relight_ms": time_relight_frame(renderer, case, reps),
                         "psnr": psnr(_tm(ref), _tm(img)), "reference": ref_name,
                         "ssao_scale": kw.get("ssao_scale", 1)})
        t = part[1]
        for s, img in zip(part, images):
            if s["model"] != "neural":
                continue
            s["frame_time_ratio_teacher_over_student"] = t["ms"] / s["ms"]
            s["relight_time_ratio_teacher_over_student"] = t["relight_ms"] / s["relight_ms"]
            s["shade_time_ratio_teacher_over_student"] = t["shade_ms"] / s["shade_ms"]
            s["psnr_minus_teacher"] = s["psnr"] - t["psnr"]
            # what the reduced scale changes in the student's own image
            s["psnr_vs_full_scale_student"] = psnr(_tm(images[0]), _tm(img))
        rows += part
    return rows


def student_designs(renderer, size: int = 256, reference_samples: int = 1024, repeats: int = 3,
                    folder=None, scene=None) -> list[dict]:
    """One row per candidate student in ``folder`` (default :func:`students_dir`), rendered through
    the real ``neural`` pass; the held-out metrics of the comparison (``compare.json``) ride along
    as ``psnr_test_vs_teacher`` / ``psnr_test_vs_mc``."""
    folder = Path(folder) if folder else students_dir()
    files = sorted(folder.glob("*.safetensors")) if folder.is_dir() else []
    if not files:
        return []
    table = {}
    if (folder / "compare.json").is_file():
        table = {r["design"]: r for r in json.loads((folder / "compare.json").read_text())["rows"]}
    scene = (scene or bench_scene("neural")).with_camera(size=(size, size))
    ref_name, ref = _reference(renderer, scene, reference_samples)
    rows = []
    for path in files:
        net = load_network(path, "student")
        ms, shade_ms, img = time_frame(renderer, scene.with_render(model="neural",
                                                                   weights=str(path)), repeats)
        t = table.get(path.stem, {})
        rows.append({"model": "neural", "variant": path.stem, "samples": 1,
                     "size": f"{size}x{size}", "ms": ms, "shade_ms": shade_ms,
                     "psnr": psnr(_tm(ref), _tm(img)), "reference": ref_name,
                     "params": net.parameter_count(), "macs_per_pixel": net.macs(),
                     "psnr_test_vs_teacher": t.get("psnr_vs_teacher"),
                     "psnr_test_vs_mc": t.get("psnr_vs_mc"), "shipped": t.get("shipped", False)})
    return rows


def time_student_kernel(programs, net, x: np.ndarray, repeats: int = 5) -> float:
    """Best seconds of the generated student MLP (``viewer.neural.STUDENT_KERNEL_ENTRY``) over
    the inputs ``x [n, 12]`` (planar upload outside the timing)."""
    ctx = programs.ctx
    prog = programs.compute(STUDENT_KERNEL_ENTRY, virtual={net.include_name: net.glsl})
    n = x.shape[0]
    src = ctx.buffer(np.ascontiguousarray(x.T, dtype=np.float32).tobytes())
    dst = ctx.buffer(reserve=4 * 6 * n)
    try:
        src.bind_to_storage_buffer(0)
        dst.bind_to_storage_buffer(1)
        prog["u_count"].value = n
        best = float("inf")
        for i in range(repeats + 1):
            ctx.finish()
            t0 = time.perf_counter()
            prog.run((n + STUDENT_KERNEL_GROUP - 1) // STUDENT_KERNEL_GROUP)
            ctx.finish()
            if i:
                best = min(best, time.perf_counter() - t0)
    finally:
        src.release()
        dst.release()
    return best


def student_throughput(programs, weights=None, pixels: int = 65536, repeats: int = 5,
                       rounds: int = 3) -> list[dict]:
    """GLSL vs torch evaluation of the student MLP on the same ``pixels`` random inputs: the best
    time of each over ``rounds`` interleaved rounds of ``repeats`` runs (both swing by 2x from
    run to run on a 2-core llvmpipe machine; interleaving gives both the same quiet moments)."""
    try:
        from learned.evaluate import torch_student_throughput
    except ImportError:
        torch_student_throughput = None
    path = weights or default_weights("student")
    net = load_network(path, "student")
    x = np.random.default_rng(0).uniform(0, 1, (pixels, 12)).astype(np.float32)
    best = t_best = float("inf")
    for _ in range(rounds):
        best = min(best, time_student_kernel(programs, net, x, repeats))
        if torch_student_throughput is not None:
            t_best = min(t_best, torch_student_throughput(path, pixels, repeats)["seconds"])
    size = f"{pixels} px"
    rows = [{"model": "neural", "variant": "mlp glsl (baked constants)", "samples": 1,
             "size": size, "ms": 1e3 * best, "psnr": None, "macs_per_pixel": net.macs(),
             "gflops": 2e-9 * net.macs() * pixels / best}]
    if torch_student_throughput is None:
        return rows
    rows.append({"model": "neural", "variant": "mlp torch (cpu)", "samples": 1, "size": size,
                 "ms": 1e3 * t_best, "psnr": None, "macs_per_pixel": net.macs(),
                 "gflops": 2e-9 * net.macs() * pixels / t_best})
    rows[0]["speedup_over_torch"] = t_best / best
    return rows


PROBE_SIZES = (32, 64, 64, 1)  # the weight-storage probe: a 32-64-64-1 MLP


def probe_layers(sizes=PROBE_SIZES, seed: int = 0) -> list[tuple[np.ndarray, np.ndarray, str]]:
    """A random MLP ``[(weight [out, in], bias [out], activation)]`` (ReLU hidden layers, sigmoid
    output; torch's default U(+-1/sqrt(in)) initialisation)."""
    rng = np.random.default_rng(seed)
    layers = []
    for i, (n_in, n_out) in enumerate(zip(sizes[:-1], sizes[1:])):
        bound = 1.0 / np.sqrt(n_in)
        layers.append((rng.uniform(-bound, bound, (n_out, n_in)).astype(np.float32),
                       rng.uniform(-bound, bound, n_out).astype(np.float32),
                       "sigmoid" if i == len(sizes) - 2 else "relu"))
    return layers


def _kernel_times(programs, entry: str, virtual: dict, code, x: np.ndarray, outputs: int,
                  repeats: int) -> tuple[list[float], np.ndarray]:
    """Seconds of the warm-up dispatch (first: includes llvmpipe's JIT compilation unless
    Mesa's shader cache has the program) and of each of ``repeats`` more (fenced with
    ``finish``) of the compute program ``entry`` (a file under ``shaders/`` or a key of
    ``virtual``) over the planar inputs ``x [n, in]`` with ``code``'s weight data bound, and the
    outputs ``[n, outputs]`` of the last one."""
    ctx = programs.ctx
    prog = programs.compute(entry, virtual=virtual)
    n = x.shape[0]
    src = ctx.buffer(np.ascontiguousarray(x.T, dtype=np.float32).tobytes())
    dst = ctx.buffer(reserve=4 * outputs * n)
    weights = NeuralWeights(ctx, code)
    times = []
    try:
        src.bind_to_storage_buffer(0)
        dst.bind_to_storage_buffer(1)
        weights.bind(prog, 0)
        prog["u_count"].value = n
        for i in range(repeats + 1):
            ctx.finish()
            t0 = time.perf_counter()
            prog.run((n + STUDENT_KERNEL_GROUP - 1) // STUDENT_KERNEL_GROUP)
            ctx.finish()
            times.append(time.perf_counter() - t0)
        out = np.frombuffer(dst.read(), np.float32).reshape(outputs, n).T.copy()
    finally:
        src.release()
        dst.release()
        weights.release()
    return times, out


def weight_storage_rows(programs, pixels: int = 65536, repeats: int = 7, rounds: int = 3,
                        weights=None, probe: bool = True) -> list[dict]:
    """Each weight storage (``viewer.neural.WEIGHT_STORAGES``) of the generated GLSL, timed on
    (a) the student ``weights`` (default: shipped) in ``STUDENT_KERNEL_ENTRY`` and (b) the probe
    MLP :data:`PROBE_SIZES` (:func:`probe_layers`) in ``viewer.neural.mlp_kernel``, over the same
    ``pixels`` random inputs; torch on the same networks and inputs for reference (left out
    without torch). Median ms of ``rounds`` x ``repeats`` runs, each after a warm-up, the rounds
    interleaving the storages so that all see the same quiet and busy moments of a shared
    machine; GFLOP/s = 2 MACs pixels / median time. ``first_ms``: the first dispatch, with
    llvmpipe's JIT compilation unless Mesa's shader cache has the program (a cold cache costs
    minutes for the probe's storage block). ``max_abs_vs_const``: the outputs'
    largest difference from the baked-constants kernel (a sanity check; the tests check parity)."""
    include_probe = probe

    try:
        from learned.evaluate import torch_mlp_times, torch_student_times
    except ImportError:
        torch_mlp_times = torch_student_times = None
    path = weights or default_weights("student")
    net = load_network(path, "student")
    rng = np.random.default_rng(0)
    x_student = rng.uniform(0, 1, (pixels, 12)).astype(np.float32)
    layers = probe_layers()
    x_probe = rng.uniform(-1, 1, (pixels, PROBE_SIZES[0])).astype(np.float32)
    sizes = "-".join(str(s) for s in net.architecture["networks"]["mlp"]["sizes"])
    probe_macs = int(sum(w.size for w, _, _ in layers))

    def student(storage):
        code = net.code(storage)
        return lambda: _kernel_times(programs, STUDENT_KERNEL_ENTRY, {net.include_name: code.glsl},
                                     code, x_student, 6, repeats), code

    def probe(storage):
        code = mlp_kernel(layers, storage)
        name = f"<bench:mlp_probe:{storage}>"
        return lambda: _kernel_times(programs, name, {name: code.glsl}, code, x_probe,
                                     PROBE_SIZES[-1], repeats), code

    cases = [(f"student {sizes}", net.macs(), s, *student(s)) for s in WEIGHT_STORAGES]
    if include_probe:  # ``probe=False``: the student only (a cold shader cache compiles the
        # probe's storage-buffer kernel for minutes on llvmpipe; `relight bench --quick` skips it)
        cases += [(f"mlp {'-'.join(map(str, PROBE_SIZES))}", probe_macs, s, *probe(s))
                  for s in WEIGHT_STORAGES]
    times = {i: [] for i in range(len(cases))}
    first = {}
    outputs = {}
    torch_times = {"student": [], "probe": []}
    for _ in range(rounds):
        for i, (_, _, _, run, _) in enumerate(cases):
            t, outputs[i] = run()
            first.setdefault(i, t[0])
            times[i] += t[1:]
        if torch_mlp_times is not None:
            torch_times["student"] += torch_student_times(path, x_student, repeats)
            if include_probe:
                torch_times["probe"] += torch_mlp_times(layers, x_probe, repeats)
    rows = []
    size = f"{pixels} px"
    for i, (network, macs, storage, _, code) in enumerate(cases):
        ms = 1e3 * statistics.median(times[i])
        const = next(j for j, c in enumerate(cases) if c[0] == network and c[2] == "const")
        rows.append({"model": "neural", "variant": f"weights {storage} ({code.binding})",
                     "samples": 1, "size": size, "ms": ms, "psnr": None, "network": network,
                     "storage": storage, "binding": code.binding, "macs_per_pixel": macs,
                     "gflops": 2e-6 * macs * pixels / ms, "first_ms": 1e3 * first[i],
                     "max_abs_vs_const": float(np.abs(outputs[i] - outputs[const]).max())})
    if torch_mlp_times is not None:
        torch_rows = [(cases[0][0], net.macs(), "student")]
        if include_probe:
            torch_rows.append((cases[-1][0], probe_macs, "probe"))
        for network, macs, key in torch_rows:
            ms = 1e3 * statistics.median(torch_times[key])
            rows.append({"model": "neural", "variant": "weights torch (cpu)", "samples": 1,
                         "size": size, "ms": ms, "psnr": None, "network": network,
                         "storage": "torch", "binding": "", "macs_per_pixel": macs,
                         "gflops": 2e-6 * macs * pixels / ms})
    return rows


def neural_rows(renderer, quick: bool = False) -> list[dict]:
    """Everything above, for ``relight bench``."""
    rows = student_vs_teacher(renderer, teacher_samples=128,
                              reference_samples=256 if quick else 1024,
                              repeats=1 if quick else 3, sizes=(128, 512))
    rows += student_designs(renderer, size=256, reference_samples=256 if quick else 1024,
                            repeats=1 if quick else 3)
    rows += student_throughput(renderer.programs, pixels=16384 if quick else 65536)
    rows += weight_storage_rows(renderer.programs, pixels=16384 if quick else 65536,
                                rounds=1 if quick else 3, probe=not quick)
    return rows
