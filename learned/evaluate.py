"""``relight eval``: every shading model against the Monte-Carlo targets of held-out samples.

For each sample of a split (FFHQ256-PBR layout with ``rgb`` targets), every model renders the
sample's own G-buffer under its own environment in GL; metrics are over the whole image with the
background set to 0 in both (foreground only):

* PSNR (dB) and SSIM (``pytorch_msssim``, 7x7 Gaussian window for small images) on Reinhard-mapped
  radiance x / (1 + x) in [0, 1];
* HDR-FLIP (``flip_evaluator``, mean over pixels) on linear radiance.

Rows: ``{"model", "variant", "samples", "size", "ms", "psnr", "ssim", "flip", "bias", "count"}``
(``bias``: total foreground radiance of the model over the target's, minus 1).

Given a shadow UNet (``shadow_weights``, ``relight eval --shadow-weights RUN/shadow_final.pt``),
one more row is the thesis's two-stage teacher, which has no GLSL pass: the torch teacher's
estimate at ``teacher_samples`` environment-importance samples times the UNet's shadow map (eq.
4.3), ``neural_teacher`` "<N> spp x shadow (torch)" (``ms``: torch on the CPU).
"""
from __future__ import annotations

import math
import time
from pathlib import Path

import numpy as np
import torch
from tqdm import tqdm

from viewer.models import MODELS
from viewer.renderer import Renderer

from .data.reader import list_samples, load_sample
from .data.scene import sample_scene
from .export import load_model
from .parity.checks.neural import student_inputs


def models_to_evaluate(teacher_samples: int, students: dict | None = None,
                       teacher_weights=None) -> list[tuple[str, str, dict]]:
    """(model, variant, render settings) of every row: the classical models alone and with the
    screen-space passes (SSAO; SSAO + one-bounce indirect light, also at half scale), Monte Carlo,
    the shipped student (also with its screen-space passes at half scale; and ``students``: variant name -> weights file), the teacher (the shipped one, or
    the file ``teacher_weights``)."""
    out = [("blinn_phong", "", {}), ("ggx_split_sum", "", {}),
           ("ggx_split_sum", "+ SSAO", {"ssao": True}),
           ("ggx_split_sum", "+ SSAO + indirect", {"ssao": True, "indirect": True}),
           # the screen-space passes at half scale (render.ssao_scale = 2): ~4x fewer rays
           ("ggx_split_sum", "+ SSAO + indirect, 1/2 scale",
            {"ssao": True, "indirect": True, "ssao_scale": 2})]
    if "ggx_mc" in MODELS:
        out += [("ggx_mc", "16 spp", {"samples": 16, "sampling": "mis"}),
                ("ggx_mc", "256 spp + SSAO + indirect",
                 {"samples": 256, "sampling": "mis", "ssao": True, "indirect": True})]
    out.append(("neural", "student", {}))
    out.append(("neural", "student, SSAO 1/2 scale", {"ssao_scale": 2}))
    for name, path in (students or {}).items():
        out.append(("neural", name, {"weights": str(path)}))
    teacher = {"teacher_weights": str(teacher_weights)} if teacher_weights else {}
    out.append(("neural_teacher", f"{teacher_samples} spp env",
                {"samples": int(teacher_samples), "sampling": "env"} | teacher))
    return out


SHADOW_VARIANT = "{} spp x shadow (torch)"  # the variant of the teacher x shadow map row


@torch.no_grad()
def teacher_shadow_image(teacher, shadow, sample, lighting, samples: int, seed: int = 0
                         ) -> np.ndarray:
    """The two-stage teacher of eq. 4.3 on ``sample`` (``learned.data.reader.Sample``), torch:
    the ``teacher``'s estimate at ``samples`` environment-importance samples per foreground pixel
    (uniform pairs from a generator seeded ``seed``, as ``learned.train.teacher_images``) times
    the ``shadow`` UNet's map of it, the sample's normals and AO -> ``[H, W, 3]`` linear radiance,
    0 on the background, in the sample's row order (comparable with ``sample.target``)."""
    fg = torch.from_numpy(sample.foreground())
    ch = {k: torch.from_numpy(np.ascontiguousarray(v)) for k, v in sample.channels.items()}
    gb = {k: t[fg] for k, t in ch.items()}
    v = -torch.from_numpy(sample.view_dirs())[fg]
    gen = torch.Generator().manual_seed(seed)
    vals = []
    for chunk in torch.split(torch.arange(v.shape[0]), 1024):
        u = torch.rand(len(chunk), samples, 2, generator=gen)
        vals.append(teacher({k: t[chunk] for k, t in gb.items()}, v[chunk], lighting, u, "env"))
    unshadowed = torch.zeros(*fg.shape, 3)
    unshadowed[fg] = torch.cat(vals) if vals else torch.zeros(0, 3)
    out = shadow(unshadowed.permute(2, 0, 1)[None], ch["normal"].permute(2, 0, 1)[None],
                 ch["ao"].permute(2, 0, 1)[None])[0]
    return out.permute(1, 2, 0).numpy()


def tonemapped_psnr(pred: np.ndarray, ref: np.ndarray) -> float:
    """PSNR (dB) of linear radiances after ``x / (1 + x)`` (negative values clipped to 0), over
    every element given: :func:`metrics`' PSNR of the foreground pixels."""
    p, r = np.clip(pred, 0.0, None), np.clip(ref, 0.0, None)
    mse = float(((p / (1.0 + p) - r / (1.0 + r)) ** 2).mean())
    return 10.0 * math.log10(1.0 / max(mse, 1e-12))


def metrics(pred: np.ndarray, ref: np.ndarray, fg: np.ndarray) -> dict:
    """pred, ref ``[H, W, 3]`` linear; fg ``[H, W]`` bool."""
    from pytorch_msssim import ssim  # the `bench` extra: only the metrics need it

    m = fg[..., None].astype(np.float32)
    p = np.clip(pred, 0.0, None) * m
    r = np.clip(ref, 0.0, None) * m
    pt, rt = p / (1.0 + p), r / (1.0 + r)
    psnr = tonemapped_psnr(pred[fg], ref[fg])
    win = 7 if min(fg.shape) >= 7 else 1
    s = float(ssim(torch.from_numpy(pt).permute(2, 0, 1)[None],
                   torch.from_numpy(rt).permute(2, 0, 1)[None], data_range=1.0, win_size=win))
    out = {"psnr": psnr, "ssim": s}
    try:
        import flip_evaluator

        out["flip"] = float(flip_evaluator.evaluate(np.ascontiguousarray(r), np.ascontiguousarray(p),
                                                    "HDR", applyMagma=False)[1])
    except ImportError:  # optional [bench] extra
        out["flip"] = float("nan")
    return out


CHROMA_EPS = 1e-3  # radiance sums below this have no meaningful hue (chromaticity -> 0)


def chromaticity(rgb: np.ndarray) -> np.ndarray:
    """``rgb [..., 3]`` linear -> ``rgb / max(r + g + b, CHROMA_EPS)``: hue and saturation
    without intensity (sums to 1; near-black pixels go to 0 instead of amplifying noise)."""
    rgb = np.clip(rgb, 0.0, None)
    return rgb / np.maximum(rgb.sum(-1, keepdims=True), CHROMA_EPS)


def chroma_error(pred: np.ndarray, ref: np.ndarray, fg: np.ndarray) -> float:
    """Colour fidelity: mean over foreground pixels of the half-L1 distance between the linear
    chromaticities, 0.5 sum_c |chromaticity(pred)_c - chromaticity(ref)_c| in [0, 1] (0: same
    hue and saturation at any intensity), in percent: 1 % is e.g. chromaticity (0.343, 0.333,
    0.323) against a grey reference, red 3 % above and blue 3 % below the channel mean.
    pred, ref ``[H, W, 3]``."""
    d = 0.5 * np.abs(chromaticity(pred) - chromaticity(ref)).sum(-1)
    return 100.0 * float(d[fg].mean())


def achromatic_error(rgb: np.ndarray, fg: np.ndarray) -> float:
    """How far from grey: max over foreground pixels of (max(r, g, b) - min(r, g, b)) / Y
    (Rec. 709 luminance, floored at CHROMA_EPS), in percent; covers |R - G|, |G - B| and |B - R|.
    rgb ``[H, W, 3]`` linear."""
    rgb = np.clip(rgb, 0.0, None)
    y = np.maximum(rgb @ np.array([0.2126, 0.7152, 0.0722]), CHROMA_EPS)
    spread = (rgb.max(-1) - rgb.min(-1)) / y
    return 100.0 * float(spread[fg].max())


GROUPS = ("kind", "environment")  # what ``evaluate(by=...)`` can break the means down by


def sample_group(sample, by: str | None) -> str:
    """The group of ``sample`` for ``evaluate(by=...)``: its scene kind (``meta.json``
    geometry.kind) or its environment file's stem (environment.source), "unrecorded" for samples
    without one (both read by ``learned.data.reader.load_sample``)."""
    if by is None:
        return ""
    if by == "kind":
        return sample.kind or "unrecorded"
    if by == "environment":
        source = sample.environment_source
        return Path(source).stem if source else "unrecorded"
    raise ValueError(f"by={by!r}: expected one of {GROUPS}")


def evaluate(root: str, split: str = "test", teacher_samples: int = 128, limit: int | None = None,
             renderer=None, students: dict | None = None, by: str | None = None,
             teacher_weights=None, shadow_weights=None) -> list[dict]:
    """Every model of :func:`models_to_evaluate` on every sample of ``split`` (at most ``limit``):
    one row per (model, variant) with the means over samples. ``split = "all"``: every split (a
    held-out dataset, no sample of which was trained on). ``students``: more student weights
    files to score (variant name -> path). ``by`` ("kind" or "environment", :data:`GROUPS`):
    one row per (group, model, variant) instead, each row's ``group`` naming it, plus the rows of
    every sample together (``group`` "all"). ``teacher_weights``: the teacher's weights file
    (default: the shipped one); ``shadow_weights``: a shadow UNet state dict, which adds the row
    teacher x shadow map (module docstring)."""
    if by is not None and by not in GROUPS:
        raise ValueError(f"by={by!r}: expected one of {GROUPS}")
    splits = (split,) if split != "all" else tuple(
        s for s in ("train", "val", "test") if (Path(root) / s).is_dir()) or ("test",)
    folders = [f for s in splits for f in list_samples(root, s)][:limit]
    own = renderer is None
    renderer = renderer or Renderer()
    acc: dict[tuple, list] = {}
    two_stage = None
    if shadow_weights is not None:
        from viewer.neural import default_weights

        from .neural.shadow import load_shadow

        two_stage = (load_model(teacher_weights or default_weights("teacher"), "teacher"),
                     load_shadow(shadow_weights))
    try:
        for folder in tqdm(folders, desc="eval", unit="sample"):
            sample = load_sample(folder)
            group = sample_group(sample, by)
            fg = sample.foreground()

            def score(key, pred, ms):
                bias = float(np.clip(pred, 0, None)[fg].sum() / max(sample.target[fg].sum(), 1e-12)
                             - 1.0)
                row = metrics(pred, sample.target, fg) | {"ms": ms, "bias": bias}
                acc.setdefault(("all",) + key, []).append(row)
                if by is not None:
                    acc.setdefault((group,) + key, []).append(row)

            for model, variant, render in models_to_evaluate(teacher_samples, students,
                                                             teacher_weights):
                scene = sample_scene(sample, model=model, **render)
                renderer.render(scene)  # warm: programs, IBL
                with renderer.every_pass():  # a whole frame, nothing reused from the warm one
                    t0 = time.perf_counter()
                    frame = renderer.render(scene)
                    ms = 1e3 * (time.perf_counter() - t0)
                score((model, variant, render.get("samples", 1)), frame.radiance[..., :3], ms)
            if two_stage is not None:
                from viewer.environment.maps import EnvironmentSpec

                from .neural.lighting import lighting_from_gl

                lighting = lighting_from_gl(renderer, EnvironmentSpec(path=str(sample.environment)))
                t0 = time.perf_counter()
                pred = teacher_shadow_image(*two_stage, sample, lighting, teacher_samples)
                ms = 1e3 * (time.perf_counter() - t0)
                score(("neural_teacher", SHADOW_VARIANT.format(teacher_samples),
                       teacher_samples), pred, ms)
    finally:
        if own:
            renderer.release()
    size = f"{load_sample(folders[0]).size[0]}x{load_sample(folders[0]).size[1]}" if folders else ""
    rows = []
    for (group, model, variant, samples), rs in sorted(
            acc.items(), key=lambda item: (by is not None and item[0][0] == "all", item[0][0])):
        extra = {"group": group} if by is not None else {}
        rows.append({**extra, "model": model, "variant": variant, "samples": samples, "size": size,
                     "count": len(rs), **{k: float(np.mean([r[k] for r in rs]))
                                          for k in ("ms", "psnr", "ssim", "flip", "bias")}})
    return rows


def format_table(rows: list[dict]) -> str:
    grouped = any("group" in r for r in rows)
    head = f"{'group':<18} " if grouped else ""
    lines = [head + f"{'model':<16} {'variant':<26} {'spp':>5} {'ms':>9} {'PSNR dB':>8} {'SSIM':>7} "
             f"{'HDR-FLIP':>9} {'bias %':>7}  n"]
    for r in rows:
        group = f"{r.get('group', ''):<18} " if grouped else ""
        lines.append(group + f"{r['model']:<16} {r['variant']:<26} {r['samples']:>5} {r['ms']:>9.2f} "
                     f"{r['psnr']:>8.2f} {r['ssim']:>7.4f} {r['flip']:>9.4f} "
                     f"{100 * r.get('bias', float('nan')):>7.1f}  {r['count']}")
    return "\n".join(lines)


@torch.no_grad()
def _run_times(fn, repeats: int) -> list[float]:
    """Seconds of each of ``repeats`` calls of ``fn`` after one warm-up call."""
    with torch.no_grad():
        fn()
        times = []
        for _ in range(repeats):
            t0 = time.perf_counter()
            fn()
            times.append(time.perf_counter() - t0)
    return times


def torch_mlp_times(layers, x: np.ndarray, repeats: int = 7) -> list[float]:
    """Seconds of each of ``repeats`` evaluations (after a warm-up) in torch (CPU, float32) of the
    bare MLP ``layers`` ``[(weight [out, in], bias [out], "relu" | "sigmoid" | "softplus")]`` on
    ``x [n, in]``: the torch reference of ``relight.bench.neural.weight_storage_rows``."""
    acts = {"relu": torch.relu, "sigmoid": torch.sigmoid,
            "softplus": torch.nn.functional.softplus}
    params = [(torch.from_numpy(w), torch.from_numpy(b), acts[a]) for w, b, a in layers]
    xt = torch.from_numpy(np.ascontiguousarray(x, np.float32))

    def run():
        h = xt
        for w, b, act in params:
            h = act(torch.nn.functional.linear(h, w, b))
        return h

    return _run_times(run, repeats)


def torch_student_times(weights, x: np.ndarray, repeats: int = 7) -> list[float]:
    """Seconds of each of ``repeats`` ``Student.weights`` evaluations (after a warm-up) of the
    exported student ``weights`` on ``x [n, 11]`` (torch, CPU, float32)."""
    model = load_model(weights, "student")
    xt = torch.from_numpy(np.ascontiguousarray(x, np.float32))
    return _run_times(lambda: model.weights(xt), repeats)


def torch_student_throughput(weights, pixels: int = 65536, repeats: int = 5) -> dict:
    """Pixels per second of the exported student's MLP in torch (CPU, float32) on ``pixels``
    random inputs: the reference the GLSL student throughput is compared with."""
    model = load_model(weights, "student")
    x = torch.from_numpy(student_inputs(pixels)[:pixels])
    model.weights(x)
    best = float("inf")
    for _ in range(repeats):
        t0 = time.perf_counter()
        model.weights(x)
        best = min(best, time.perf_counter() - t0)
    return {"pixels": pixels, "seconds": best, "pixels_per_s": pixels / best,
            "macs_per_pixel": model.macs_per_pixel()}
