"""Training: teacher (phase 1), shadow estimator (phase 2, shader frozen), student distillation.

    python -m learned.train --data DATA --out RUN [--quick] [--stage all|teacher|shadow|student]
    torchrun --nproc_per_node 2 -m learned.train ...      # DistributedDataParallel (gloo / NCCL)

Phase 1 (thesis sec. 4.3.3-4.3.4): L1 over random foreground pixels (``batch_pixels``, 8192 in
the thesis) of one random training image per step, ``light_samples`` light directions per pixel
(``strategy`` uniform or env importance sampling), Adam. Phase 2: the UNet of eq. 4.3 on whole
images, L1 over all foreground pixels (eq. 4.6), the teacher frozen. Distillation: the student matches the
frozen two-stage teacher (teacher x shadow map, ``distill_samples`` light samples) per pixel,
L1 on log(1 + radiance) (``distill_loss``; plain L1 on radiance is dominated by the brightest
pixels, the metrics compare tone-mapped x / (1 + x)).

Every stage checkpoints ``RUN/<stage>.pt`` (model, optimiser, step, RNG) every
``checkpoint_every`` steps through a temporary file + rename and resumes from it; a finished stage
is loaded, not retrained. Logs are plain lines on stdout and in ``RUN/train.log`` (rank 0 only).
The exported weights are ``RUN/neural_student.safetensors`` and ``RUN/neural_teacher.safetensors``.
"""
from __future__ import annotations

import argparse
import json
import math
import os
import sys
import time
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np
import torch

from .neural.lighting import Lighting, lighting_from_gl, student_features
from .neural.shadow import ShadowUNet
from .neural.student import Student
from .neural.teacher import Teacher


@dataclass(frozen=True)
class TrainConfig:
    data: str
    out: str
    teacher_steps: int = 2000
    shadow_steps: int = 500
    student_steps: int = 3000
    batch_pixels: int = 8192
    light_samples: int = 32
    strategy: str = "env"  # "uniform" | "cosine" | "env"
    lr: float = 1e-3
    teacher_hidden: int = 64
    teacher_freqs: int = 4
    # the shipped design, learned.neural.student.SHIPPED_DESIGN (chosen by compare_students)
    student_hidden: tuple[int, ...] = (16, 16)
    student_freqs: int = 0
    student_features: str = "base"  # "base" | "dfg" (learned.neural.student.FEATURE_INPUTS)
    student_output: str = "pbr3"  # "free6" | "pbr3" (learned.neural.student.OUTPUTS)
    distill_loss: str = "log_l1"  # "l1" on radiance | "log_l1" on log(1 + radiance)
    shadow_width: int = 16
    distill_samples: int = 128
    seed: int = 0
    checkpoint_every: int = 100
    log_every: int = 50

    @classmethod
    def quick(cls, data: str, out: str, **kw) -> "TrainConfig":
        """Minutes on two CPU cores: smaller networks, fewer steps and samples."""
        base = dict(teacher_steps=3000, shadow_steps=150, student_steps=3000, batch_pixels=2048,
                    light_samples=16, teacher_hidden=32, teacher_freqs=2, shadow_width=8,
                    distill_samples=64, log_every=100)
        return cls(data=data, out=out, **(base | kw))


# ---- distributed ---------------------------------------------------------------------------------

def _dist() -> tuple[int, int]:
    """(rank, world size); initialises the process group under torchrun."""
    world = int(os.environ.get("WORLD_SIZE", "1"))
    if world > 1 and not torch.distributed.is_initialized():
        backend = "nccl" if torch.cuda.is_available() else "gloo"
        torch.distributed.init_process_group(backend=backend)
    if world > 1:
        return torch.distributed.get_rank(), world
    return 0, 1


def _wrap(model):
    if torch.distributed.is_available() and torch.distributed.is_initialized():
        return torch.nn.parallel.DistributedDataParallel(model)
    return model


# ---- data ----------------------------------------------------------------------------------------

@dataclass
class TrainImage:
    name: str
    size: tuple[int, int]  # (W, H)
    fg: torch.Tensor  # [H, W] bool
    gb: dict  # channel -> [P, C] foreground pixels
    v: torch.Tensor  # [P, 3] towards the viewer
    target: torch.Tensor  # [P, 3]
    target_image: torch.Tensor  # [3, H, W]
    normal_image: torch.Tensor  # [3, H, W]
    ao_image: torch.Tensor  # [1, H, W]
    lighting: Lighting


def load_images(root: str, split: str, renderer) -> list[TrainImage]:
    from viewer.environment import EnvironmentSpec

    from .data.reader import DatasetError, list_samples, load_sample

    out = []
    for folder in list_samples(root, split):
        s = load_sample(folder)
        fg = torch.from_numpy(s.foreground())
        if not fg.any():
            continue
        ch = {k: torch.from_numpy(np.ascontiguousarray(v)) for k, v in s.channels.items()}
        v = -torch.from_numpy(s.view_dirs())
        lighting = lighting_from_gl(renderer, EnvironmentSpec(path=str(s.environment)))
        target = torch.from_numpy(np.ascontiguousarray(s.target))
        out.append(TrainImage(
            name=s.name, size=s.size, fg=fg, gb={k: t[fg] for k, t in ch.items()}, v=v[fg],
            target=target[fg], target_image=target.permute(2, 0, 1),
            normal_image=ch["normal"].permute(2, 0, 1), ao_image=ch["ao"].permute(2, 0, 1),
            lighting=lighting))
    if not out:
        raise DatasetError(f"no usable samples in the {split!r} split", where=root)
    return out


# ---- checkpoints and logs ------------------------------------------------------------------------

class Run:
    def __init__(self, cfg: TrainConfig, rank: int, quiet: bool = False):
        self.cfg = cfg
        self.rank = rank
        self.quiet = quiet
        self.out = Path(cfg.out)
        if rank == 0:
            self.out.mkdir(parents=True, exist_ok=True)

    def log(self, msg: str) -> None:
        if self.rank != 0:
            return
        line = f"[{time.strftime('%H:%M:%S')}] {msg}"
        if not self.quiet:
            print(line, flush=True)
        with open(self.out / "train.log", "a") as f:
            f.write(line + "\n")

    def save(self, stage: str, model, opt, step: int, losses: list) -> None:
        if self.rank != 0:
            return
        path = self.out / f"{stage}.pt"
        tmp = path.with_suffix(".pt.tmp")
        torch.save({"model": model.state_dict(), "opt": opt.state_dict(), "step": step,
                    "losses": losses, "config": asdict(self.cfg),
                    "rng": torch.get_rng_state()}, tmp)
        os.replace(tmp, path)

    def load(self, stage: str, model, opt) -> tuple[int, list]:
        path = self.out / f"{stage}.pt"
        if not path.is_file():
            return 0, []
        try:
            ck = torch.load(path, map_location="cpu", weights_only=False)
            model.load_state_dict(ck["model"])
            if opt is not None:
                opt.load_state_dict(ck["opt"])
            torch.set_rng_state(ck["rng"])
        except Exception as exc:  # noqa: BLE001 - any unreadable checkpoint is a user error
            from viewer.errors import InputError

            raise InputError(f"cannot resume from this checkpoint ({type(exc).__name__}: "
                             f"{str(exc).splitlines()[0] if str(exc) else ''}); delete it to "
                             f"restart the stage", where=path) from None
        return int(ck["step"]), list(ck["losses"])


def _loop(run: Run, stage: str, model, steps: int, lr: float, step_fn) -> list[float]:
    """Adam over ``steps`` steps of ``step_fn(ddp_model, step) -> loss``, with resume."""
    from tqdm import tqdm

    opt = torch.optim.Adam(model.parameters(), lr=lr, betas=(0.9, 0.999))
    start, losses = run.load(stage, model, opt)
    if start >= steps:
        run.log(f"{stage}: finished checkpoint ({start} steps), loaded")
        return losses
    if start:
        run.log(f"{stage}: resuming at step {start}/{steps}")
    ddp = _wrap(model)
    sched_lr = lambda s: lr * 0.5 * (1.0 + math.cos(math.pi * s / steps))  # noqa: E731
    t0 = time.time()
    bar = tqdm(range(start, steps), desc=stage, unit="step", disable=run.rank != 0 or run.quiet,
               file=sys.stderr)
    for step in bar:
        for g in opt.param_groups:
            g["lr"] = sched_lr(step)
        loss = step_fn(ddp, step)
        opt.zero_grad(set_to_none=True)
        loss.backward()
        opt.step()
        losses.append(loss.item())
        if (step + 1) % run.cfg.log_every == 0 or step + 1 == steps:
            recent = float(np.mean(losses[-run.cfg.log_every:]))
            run.log(f"{stage} step {step + 1}/{steps} loss {recent:.5f} ({time.time() - t0:.1f} s)")
        if (step + 1) % run.cfg.checkpoint_every == 0 or step + 1 == steps:
            run.save(stage, model, opt, step + 1, losses)
    return losses


def _pick(images: list[TrainImage], rng: np.random.Generator, count: int):
    img = images[int(rng.integers(0, len(images)))]
    p = img.v.shape[0]
    idx = torch.from_numpy(rng.choice(p, size=min(count, p), replace=p < count))
    return img, idx


# ---- stages ----------------------------------------------------------------------------------------

def train_teacher(run: Run, images: list[TrainImage]) -> tuple[Teacher, list[float]]:
    cfg = run.cfg
    torch.manual_seed(cfg.seed)
    model = Teacher(hidden=cfg.teacher_hidden, num_freqs=cfg.teacher_freqs)
    rng = np.random.default_rng([cfg.seed, run.rank, 1])

    def step(ddp, _):
        img, idx = _pick(images, rng, cfg.batch_pixels)
        gb = {k: t[idx] for k, t in img.gb.items()}
        u = torch.rand(len(idx), cfg.light_samples, 2)
        pred = ddp(gb, img.v[idx], img.lighting, u, cfg.strategy)
        return (pred - img.target[idx]).abs().mean()

    losses = _loop(run, "teacher", model, cfg.teacher_steps, cfg.lr, step)
    return model.eval(), losses


@torch.no_grad()
def teacher_images(teacher: Teacher, images: list[TrainImage], samples: int, strategy: str,
                   seed: int = 0) -> list[torch.Tensor]:
    """The frozen teacher's unshadowed render of every image ``[3, H, W]`` (background 0)."""
    gen = torch.Generator().manual_seed(seed)
    out = []
    for img in images:
        w, h = img.size
        full = torch.zeros(h, w, 3)
        vals = []
        for chunk in torch.split(torch.arange(img.v.shape[0]), 1024):
            gb = {k: t[chunk] for k, t in img.gb.items()}
            u = torch.rand(len(chunk), samples, 2, generator=gen)
            vals.append(teacher(gb, img.v[chunk], img.lighting, u, strategy))
        full[img.fg] = torch.cat(vals)
        out.append(full.permute(2, 0, 1))
    return out


def train_shadow(run: Run, images: list[TrainImage], unshadowed: list[torch.Tensor]
                 ) -> tuple[ShadowUNet, list[float]]:
    cfg = run.cfg
    torch.manual_seed(cfg.seed + 2)
    model = ShadowUNet(width=cfg.shadow_width)
    rng = np.random.default_rng([cfg.seed, run.rank, 2])

    def step(ddp, _):
        k = int(rng.integers(0, len(images)))
        img = images[k]
        pred = ddp(unshadowed[k][None], img.normal_image[None], img.ao_image[None])
        # eq. 4.6 over the image's pixels with a surface (the background is the environment)
        return (pred - img.target_image[None]).abs()[..., img.fg].mean()

    losses = _loop(run, "shadow", model, cfg.shadow_steps, cfg.lr, step)
    return model.eval(), losses


@torch.no_grad()
def distillation_targets(images, unshadowed, shadow: ShadowUNet | None) -> list[torch.Tensor]:
    """Per image, the frozen two-stage teacher at its foreground pixels ``[P, 3]``."""
    out = []
    for img, un in zip(images, unshadowed):
        full = un if shadow is None else shadow(un[None], img.normal_image[None],
                                                img.ao_image[None])[0]
        out.append(full.permute(1, 2, 0)[img.fg])
    return out


def distill_loss(pred: torch.Tensor, target: torch.Tensor, kind: str) -> torch.Tensor:
    """Distillation loss of ``pred`` against ``target`` (radiance ``[N, 3]``): ``l1`` on radiance,
    or ``log_l1`` on log(1 + radiance), which weighs dark and bright pixels alike, like the
    tone-mapped metrics. Measured on the quick data (teacher 3000 steps, students 3000 steps,
    held-out PSNR vs MC): log_l1 w16x2-pbr 25.41 dB / w16x2-dfg-pbr 25.31 against l1 24.59 / 25.04;
    the free6 w16x2-dfg is indifferent (25.22 / 25.27)."""
    if kind == "l1":
        return (pred - target).abs().mean()
    if kind == "log_l1":
        return (torch.log1p(pred.clamp_min(0.0)) - torch.log1p(target.clamp_min(0.0))).abs().mean()
    raise ValueError(f"unknown distillation loss {kind!r} (l1 | log_l1)")


def distill_student(run: Run, images: list[TrainImage], targets: list[torch.Tensor],
                    design: dict | None = None, stage: str = "student", feats=None
                    ) -> tuple[Student, list[float]]:
    """Distil a :class:`Student` (``design``: its keyword arguments, default the config's) from
    the per-pixel ``targets``; every design starts from the same seed and draws the same batches.
    ``feats``: :func:`student_features` per image, when the caller already has them."""
    cfg = run.cfg
    torch.manual_seed(cfg.seed + 3)
    design = design if design is not None else {
        "hidden": cfg.student_hidden, "num_freqs": cfg.student_freqs,
        "features": cfg.student_features, "output": cfg.student_output}
    model = Student(**design)
    rng = np.random.default_rng([cfg.seed, run.rank, 3])
    if feats is None:
        with torch.no_grad():
            feats = [student_features(img.gb, img.v, img.lighting, img.gb["ao"][:, 0])
                     for img in images]

    def step(ddp, _):
        k = int(rng.integers(0, len(images)))
        p = targets[k].shape[0]
        idx = torch.from_numpy(rng.choice(p, size=min(cfg.batch_pixels, p), replace=False))
        x, irr, pre = (t[idx] for t in feats[k])
        return distill_loss(ddp(x, irr, pre), targets[k][idx], cfg.distill_loss)

    losses = _loop(run, stage, model, cfg.student_steps, cfg.lr, step)
    return model.eval(), losses


def train(cfg: TrainConfig, stages: str = "all", quiet: bool = False) -> dict:
    """Run the stages; returns a summary (losses, exported files, sizes)."""
    from viewer.renderer import Renderer

    from .data.reader import summary as data_summary
    from .export import export

    rank, world = _dist()
    run = Run(cfg, rank, quiet)
    run.log(f"config {json.dumps(asdict(cfg))} world {world}")
    renderer = Renderer()
    try:
        images = load_images(cfg.data, "train", renderer)
    finally:
        renderer.release()
    run.log(f"{len(images)} training images, {sum(i.v.shape[0] for i in images)} foreground pixels")
    result: dict = {"world": world}
    teacher, tl = train_teacher(run, images)
    result["teacher_loss"] = tl
    training = {"data": data_summary(cfg.data), "config": asdict(cfg), "world": world}
    if rank == 0:
        result["teacher"] = str(run.out / "neural_teacher.safetensors")
        result["teacher_checkpoint"] = export(
            teacher, result["teacher"], training | {"stage": "teacher", "final_loss": tl[-1]})
    if stages == "teacher":
        return result
    unshadowed = teacher_images(teacher, images, cfg.distill_samples, cfg.strategy, cfg.seed)
    shadow, sl = train_shadow(run, images, unshadowed)
    result["shadow_loss"] = sl
    targets = distillation_targets(images, unshadowed, shadow)
    student, stl = distill_student(run, images, targets)
    result["student_loss"] = stl
    if rank == 0:
        result["student"] = str(run.out / "neural_student.safetensors")
        result["student_checkpoint"] = export(
            student, result["student"],
            training | {"stage": "student", "distilled_from": result["teacher_checkpoint"],
                        "final_loss": stl[-1]})
        torch.save(shadow.state_dict(), run.out / "shadow_final.pt")
        run.log(f"student: {student.parameter_count()} parameters, {student.macs_per_pixel()} "
                f"multiply-adds per pixel; teacher: {teacher.parameter_count()} parameters, "
                f"{teacher.macs_per_sample()} per light sample")
    return result


QUICK_DATA = {"count": 40, "size": 64, "samples": 256, "seed": 0, "gbuffer_fraction": 0.25}


def pipeline(out: str, data: str | None = None, quick: bool = True, install: bool = False,
             quiet: bool = False, **overrides) -> dict:
    """What ``relight train`` runs: generate the synthetic dataset when ``data`` is None
    (``OUT/data``, :data:`QUICK_DATA`), train all stages, export, and with ``install`` copy the
    weights to ``assets/weights`` (temporary file + rename each)."""
    import shutil

    from .data.generator import GeneratorConfig, generate

    out_path = Path(out)
    if data is None:
        data = str(out_path / "data")
        if int(os.environ.get("RANK", "0")) == 0:
            generate(data, GeneratorConfig(**QUICK_DATA), progress=not quiet)
        if int(os.environ.get("WORLD_SIZE", "1")) > 1:
            _dist()
            torch.distributed.barrier()
    cfg = (TrainConfig.quick(data, out, **overrides) if quick
           else TrainConfig(data=data, out=out, **overrides))
    res = train(cfg, quiet=quiet)
    if install and res.get("student"):
        from viewer.neural import default_weights

        for kind in ("student", "teacher"):
            dst = default_weights(kind)
            tmp = dst.with_suffix(".tmp")
            shutil.copyfile(res[kind], tmp)
            os.replace(tmp, dst)
            res[f"installed_{kind}"] = str(dst)
    return res


# ---- measured comparison of student designs ---------------------------------------------------

COMPARE_SPLITS = ("val", "test")  # held out: never seen by the teacher, shadow or students


def _held_out(root: str, renderer, splits) -> list[tuple[TrainImage, object]]:
    from .data.reader import list_samples, load_sample

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
    ``relight.bench.neural.GREY_SCENE`` under the white environment, where every physically
    based model renders grey), and GLSL ms per frame (whole frame and the ``shade`` pass) at
    256x256 on the bench scene.

    ``data`` None: the quick synthetic dataset under ``OUT/data`` (:data:`QUICK_DATA`). The quick
    teacher and shadow stages are trained (or loaded: the run folder is resumable, so ``OUT``
    may be the ``relight train --quick`` run folder), each design is a stage
    ``student_<design>``. Writes ``OUT/students/<design>.safetensors``, ``OUT/students/
    compare.json`` and ``compare.md``; ``install`` copies them to ``assets/weights/students``
    (what ``relight bench`` reads). Returns the JSON dict.
    """
    import shutil

    from relight.bench.neural import BENCH_SCENE, GREY_SCENE, time_frame
    from viewer.renderer import Renderer
    from viewer.scene import scene_from_dict

    from .data.generator import GeneratorConfig, generate
    from .evaluate import achromatic_error, chroma_error, metrics, sample_scene
    from .export import export
    from .neural.student import DESIGNS, SHIPPED_DESIGN

    designs = designs or DESIGNS
    out_path = Path(out)
    if data is None:
        data = str(out_path / "data")
        generate(data, GeneratorConfig(**QUICK_DATA), progress=not quiet)
    cfg = TrainConfig.quick(data, out, **overrides)
    run = Run(cfg, 0, quiet)
    run.log(f"compare students {sorted(designs)} config {json.dumps(asdict(cfg))}")
    renderer = Renderer()
    try:
        images = load_images(cfg.data, "train", renderer)
        teacher, _ = train_teacher(run, images)
        unshadowed = teacher_images(teacher, images, cfg.distill_samples, cfg.strategy, cfg.seed)
        shadow, _ = train_shadow(run, images, unshadowed)
        targets = distillation_targets(images, unshadowed, shadow)
        with torch.no_grad():
            feats = [student_features(img.gb, img.v, img.lighting, img.gb["ao"][:, 0])
                     for img in images]
        held = _held_out(cfg.data, renderer, splits)
        h_images = [img for img, _ in held]
        with torch.no_grad():  # teacher x shadow map, whole images [H, W, 3]
            h_teacher = [shadow(un[None], img.normal_image[None], img.ao_image[None])[0]
                         .permute(1, 2, 0).numpy()
                         for img, un in zip(h_images, teacher_images(
                             teacher, h_images, cfg.distill_samples, cfg.strategy, cfg.seed))]
        folder = out_path / "students"
        folder.mkdir(parents=True, exist_ok=True)
        bench = scene_from_dict(BENCH_SCENE).with_camera(size=(256, 256))
        grey = scene_from_dict(GREY_SCENE | {"environment": GREY_SCENE["environment"]
                                              | {"procedural": "white"}})
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
                                              stage=f"student_{name}", feats=feats)
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
                                        "(relight.bench.neural.GREY_SCENE)"},
              "timing": "llvmpipe; GLSL ms at 256x256 on the bench scene (relight/bench/neural.py)",
              "teacher_checkpoint": training["teacher"], "rows": rows, "context": context}
    _write_atomic(folder / "compare.json", json.dumps(result, indent=1))
    _write_atomic(folder / "compare.md", compare_table(result))
    if install:
        from relight.bench.neural import students_dir

        dst = students_dir()
        dst.mkdir(parents=True, exist_ok=True)
        for f in sorted(folder.glob("*.safetensors")) + [folder / "compare.json",
                                                          folder / "compare.md"]:
            tmp = dst / (f.name + ".tmp")
            shutil.copyfile(f, tmp)
            os.replace(tmp, dst / f.name)
        result["installed"] = str(dst)
    return result


def checkpoint_of(model) -> str:
    from viewer.neural import checkpoint_hash

    from .export import network_tensors

    return checkpoint_hash(network_tensors(model))


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


def main(argv=None) -> int:
    p = argparse.ArgumentParser(prog="python -m learned.train", description=__doc__.split("\n")[0])
    p.add_argument("--data", help="dataset root (required unless --compare-students)")
    p.add_argument("--out", required=True)
    p.add_argument("--quick", action="store_true")
    p.add_argument("--stage", default="all", choices=("all", "teacher"))
    p.add_argument("--teacher-steps", type=int)
    p.add_argument("--student-steps", type=int)
    p.add_argument("--shadow-steps", type=int)
    p.add_argument("--batch-pixels", type=int)
    p.add_argument("--light-samples", type=int)
    p.add_argument("--strategy", choices=("uniform", "cosine", "env"))
    p.add_argument("--compare-students", action="store_true",
                   help="distil and measure every candidate student design (compare_students)")
    p.add_argument("--install", action="store_true",
                   help="with --compare-students: copy the candidates and table to assets")
    p.add_argument("--quiet", action="store_true")
    a = p.parse_args(argv)
    if a.data is None and not a.compare_students:
        p.error("--data is required")
    over = {k: v for k, v in {"teacher_steps": a.teacher_steps, "student_steps": a.student_steps,
                              "shadow_steps": a.shadow_steps, "batch_pixels": a.batch_pixels,
                              "light_samples": a.light_samples, "strategy": a.strategy}.items()
            if v is not None}
    if a.compare_students:
        res = compare_students(a.out, a.data, install=a.install, quiet=a.quiet, **over)
        print(compare_table(res))
        return 0
    cfg = (TrainConfig.quick(a.data, a.out, **over) if a.quick
           else TrainConfig(data=a.data, out=a.out, **over))
    res = train(cfg, a.stage, quiet=a.quiet)
    rank = int(os.environ.get("RANK", "0"))
    if rank == 0:
        print(json.dumps({k: (v[-1] if isinstance(v, list) and v else v) for k, v in res.items()}))
    if torch.distributed.is_available() and torch.distributed.is_initialized():
        torch.distributed.destroy_process_group()
    return 0


if __name__ == "__main__":
    sys.exit(main())
