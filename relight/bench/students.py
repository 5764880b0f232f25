"""The measured comparison of student designs (``relight train --compare-students``): every
candidate of :data:`learned.neural.student.DESIGNS` distilled from one teacher x shadow map and
measured through the real GLSL ``neural`` pass on held-out samples and on the bench scenes of
:mod:`relight.bench.neural`. Its table, ``assets/weights/students/compare.md``, chose the shipped
design; :func:`relight.bench.neural.student_designs` renders the installed candidates as bench
rows. Needs the ``learned`` extra (torch)."""
from __future__ import annotations

import json
import os
import shutil
from dataclasses import asdict
from pathlib import Path

import numpy as np
import torch

from learned.data.generator import GeneratorConfig, generate
from learned.data.reader import list_samples, load_sample
from learned.evaluate import achromatic_error, chroma_error, metrics, sample_scene
from learned.export import export
from learned.neural.student import DESIGNS, SHIPPED_DESIGN
from learned.train import (COMPARE_SPLITS, QUICK_DATA, Run, TrainConfig, TrainImage,
                           checkpoint_of, distill_student, distillation_targets, load_images,
                           teacher_images, train_shadow, train_teacher)
from viewer.renderer import Renderer

from .neural import students_dir, time_frame
from .scenes import bench_scene


def _held_out(root: str, renderer, splits) -> list[tuple[TrainImage, object]]:
    out = []
    for split in splits:
        images = {img.name: img for img in load_images(root, split, renderer)}
        for folder in list_samples(root, split):
            if folder.name in images:
                out.append((images[folder.name], load_sample(folder)))
    return out


def compare_students(out: str, data: str | None = None, designs: dict | None = None,
                     splits=COMPARE_SPLITS, install: bool = False, quiet: bool = False,
                     repeats: int = 15, **overrides) -> dict:
    """Distil every design of ``designs`` (default :data:`learned.neural.student.DESIGNS`) from one
    teacher (x shadow) on one dataset and measure each: parameters, multiply-adds per pixel, PSNR
    against the teacher and against the Monte-Carlo targets on the held-out ``splits`` (the GL
    ``neural`` pass on each sample's own G-buffer and environment, as ``relight eval``), colour
    fidelity (:func:`learned.evaluate.chroma_error` against the Monte-Carlo targets on the same
    samples, and :func:`learned.evaluate.achromatic_error` of the grey probe
    ``assets/scenes/bench/grey_probe.toml`` under the white environment, where every physically
    based model renders grey), and GLSL ms per frame (whole frame and the ``shade`` pass) at
    256x256 on the bench scene.

    ``data`` None: the quick synthetic dataset under ``OUT/data``
    (:data:`learned.train.QUICK_DATA`). The quick teacher and shadow stages are trained (or
    loaded: the run folder is resumable, so ``OUT`` may be the ``relight train --quick`` run
    folder), each design is a stage ``student_<design>``; ``overrides``: fields of
    :class:`learned.train.TrainConfig`. Writes ``OUT/students/<design>.safetensors``,
    ``OUT/students/compare.json`` and ``compare.md``; ``install`` copies them to
    ``assets/weights/students`` (what ``relight bench`` reads). Returns the JSON dict.
    """
    designs = designs or DESIGNS
    out_path = Path(out)
    if data is None:
        data = str(out_path / "data")
        generate(data, GeneratorConfig(**QUICK_DATA), progress=not quiet)
    # the comparison's recipe, as its stored table was made: a teacher with the light input and
    # no gain or direct penalty (TrainConfig's defaults are now the shipped student's and
    # teacher's)
    recipe = {"teacher_light_input": True, "student_gain_penalty": 0.0,
              "student_direct_penalty": 0.0}
    cfg = TrainConfig.quick(data, out, **(recipe | overrides))
    run = Run(cfg, 0, quiet)
    run.log(f"compare students {sorted(designs)} config {json.dumps(asdict(cfg))}")
    renderer = Renderer()
    try:
        images = load_images(cfg.data, "train", renderer)
        teacher, _ = train_teacher(run, images)
        unshadowed = teacher_images(teacher, images, cfg.distill_samples, cfg.strategy, cfg.seed)
        shadow, _ = train_shadow(run, images, unshadowed)
        targets = distillation_targets(images, unshadowed, shadow)
        held = _held_out(cfg.data, renderer, splits)
        h_images = [img for img, _ in held]
        with torch.no_grad():  # teacher x shadow map, whole images [H, W, 3]
            h_teacher = [shadow(un[None], img.normal_image[None], img.ao_image[None])[0]
                         .permute(1, 2, 0).numpy()
                         for img, un in zip(h_images, teacher_images(
                             teacher, h_images, cfg.distill_samples, cfg.strategy, cfg.seed))]
        folder = out_path / "students"
        folder.mkdir(parents=True, exist_ok=True)
        bench = bench_scene("neural").with_camera(size=(256, 256))
        grey = bench_scene("grey_probe").with_environment(procedural="white")
        training = {"data": cfg.data, "config": asdict(cfg), "teacher": checkpoint_of(teacher)}

        def held_out(render) -> dict:
            vs_t, vs_mc, chroma = [], [], []
            for (img, sample), t_img in zip(held, h_teacher):
                pred = renderer.render(sample_scene(sample, **render)).radiance[..., :3]
                fg = img.fg.numpy()
                vs_t.append(metrics(pred, t_img, fg)["psnr"])
                vs_mc.append(metrics(pred, sample.target, fg)["psnr"])
                chroma.append(chroma_error(pred, sample.target, fg))
            g = renderer.render(grey.with_render(**render)).radiance
            return {"psnr_vs_teacher": float(np.mean(vs_t)), "psnr_vs_mc": float(np.mean(vs_mc)),
                    "chroma_vs_mc": float(np.mean(chroma)),
                    "grey_tint": achromatic_error(g[..., :3], g[..., 3] > 0)}

        rows = []
        for name in sorted(designs):
            student, losses = distill_student(run, images, targets, designs[name],
                                              stage=f"student_{name}")
            path = folder / f"{name}.safetensors"
            export(student, path, training | {"stage": "student", "design": name,
                                              "final_loss": losses[-1]})
            measured = held_out({"model": "neural", "weights": str(path)})
            ms, shade_ms, _ = time_frame(renderer, bench.with_render(model="neural",
                                                                     weights=str(path)), repeats)
            rows.append({"design": name, **{k: (list(v) if isinstance(v, tuple) else v)
                                            for k, v in designs[name].items()},
                         "params": student.parameter_count(),
                         "macs_per_pixel": student.macs_per_pixel(),
                         "final_loss": float(np.mean(losses[-100:])), **measured,
                         "ms_256": ms, "shade_ms_256": shade_ms, "shipped": name == SHIPPED_DESIGN})
            run.log(f"student {name}: {rows[-1]}")
        context = []
        for model, render in (("ggx_split_sum", {"model": "ggx_split_sum"}),):
            measured = held_out(render)
            ms, shade_ms, _ = time_frame(renderer, bench.with_render(**render), repeats)
            context.append({"model": model, **measured, "ms_256": ms, "shade_ms_256": shade_ms})
        t_mc = [metrics(t, s.target, img.fg.numpy())["psnr"]
                for (img, s), t in zip(held, h_teacher)]
        t_chroma = [chroma_error(t, s.target, img.fg.numpy())
                    for (img, s), t in zip(held, h_teacher)]
        context.append({"model": "teacher x shadow (torch)",
                        "samples": cfg.distill_samples, "psnr_vs_mc": float(np.mean(t_mc)),
                        "chroma_vs_mc": float(np.mean(t_chroma))})
    finally:
        renderer.release()
    result = {"held_out": {"splits": list(splits), "samples": len(held),
                           "metric": "PSNR dB, Reinhard x/(1+x), foreground",
                           "chroma": "chroma error % vs MC: mean over foreground of "
                                     "0.5 |chromaticity(student) - chromaticity(MC)|_1, "
                                     "chromaticity = rgb / (r + g + b) (learned.evaluate."
                                     "chroma_error)",
                           "grey_tint": "max over foreground of (max - min of rgb) / luminance, "
                                        "%, grey probe under the white environment "
                                        "(assets/scenes/bench/grey_probe.toml)"},
              "timing": "llvmpipe; GLSL ms at 256x256 on the bench scene (relight/bench/neural.py)",
              "teacher_checkpoint": training["teacher"], "rows": rows, "context": context}
    _write_atomic(folder / "compare.json", json.dumps(result, indent=1))
    _write_atomic(folder / "compare.md", compare_table(result))
    if install:
        dst = students_dir()
        dst.mkdir(parents=True, exist_ok=True)
        for f in sorted(folder.glob("*.safetensors")) + [folder / "compare.json",
                                                          folder / "compare.md"]:
            tmp = dst / (f.name + ".tmp")
            shutil.copyfile(f, tmp)
            os.replace(tmp, dst / f.name)
        result["installed"] = str(dst)
    return result


def _write_atomic(path: Path, text: str) -> None:
    tmp = path.with_name(path.name + ".tmp")
    tmp.write_text(text)
    os.replace(tmp, path)


def compare_table(result: dict) -> str:
    """The Markdown table of :func:`compare_students`."""
    h = result["held_out"]
    lines = [f"Student designs distilled from one teacher "
             f"(sha256 {result['teacher_checkpoint'][:12]}); held-out {'+'.join(h['splits'])} "
             f"({h['samples']} samples), {h['metric']}; {h.get('chroma', '')}; grey tint: "
             f"{h.get('grey_tint', '')}; {result['timing']}.", "",
             "| design | hidden | PE freqs | features | output | params | MACs/px | "
             "PSNR vs teacher | PSNR vs MC | chroma err vs MC % | grey tint % | frame ms | "
             "shade ms | |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    f = lambda v, fmt: "" if v is None else format(v, fmt)  # noqa: E731
    for r in result["rows"]:
        lines.append(f"| {r['design']} | {'-'.join(map(str, r['hidden']))} | "
                     f"{r.get('num_freqs', 0)} | {r.get('features', 'base')} | "
                     f"{r.get('output', 'free6')} | {r['params']:,} | "
                     f"{r['macs_per_pixel']:,} | {r['psnr_vs_teacher']:.2f} | "
                     f"{r['psnr_vs_mc']:.2f} | {f(r.get('chroma_vs_mc'), '.2f')} | "
                     f"{f(r.get('grey_tint'), '.2f')} | {r['ms_256']:.1f} | "
                     f"{r['shade_ms_256']:.1f} | {'shipped' if r['shipped'] else ''} |")
    for c in result["context"]:
        lines.append(f"| *{c['model']}* | | | | | | | {f(c.get('psnr_vs_teacher'), '.2f')} | "
                     f"{c['psnr_vs_mc']:.2f} | {f(c.get('chroma_vs_mc'), '.2f')} | "
                     f"{f(c.get('grey_tint'), '.2f')} | {f(c.get('ms_256'), '.1f')} | "
                     f"{f(c.get('shade_ms_256'), '.1f')} | |")
    return "\n".join(lines) + "\n"
