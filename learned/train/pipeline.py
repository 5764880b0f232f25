"""The whole run: :func:`train` (teacher, shadow estimator, student; export) and :func:`pipeline`
(what ``relight train`` runs: the quick synthetic dataset when no data is given, the stages, and
the optional install of the weights)."""
from __future__ import annotations

import json
import os
import shutil
import sys
from dataclasses import asdict
from pathlib import Path

import torch

from viewer.neural import checkpoint_hash, default_weights
from viewer.renderer import Renderer

from ..data.generator import GeneratorConfig, generate
from ..data.reader import summary as data_summary
from ..export import export, network_tensors
from ..protocol.data import dataset_hash
from .config import QUICK_DATA, STUDENT_TARGETS, TrainConfig
from .runner import Run, _close_dist, _dist
from .stages import (distill_student, distillation_targets, load_images, teacher_images,
                     train_shadow, train_teacher)

# every stage, the teacher alone, the teacher and the shadow UNet (eq. 4.3's two phases, no
# student), or the student alone (on the dataset's own targets: student_target "target")
STAGES = ("all", "teacher", "shadow", "student")


def train(cfg: TrainConfig, stages: str = "all", quiet: bool = False) -> dict:
    """Run the stages (``stages``: one of :data:`STAGES`); returns a summary (losses, exported
    files, sizes)."""
    if stages not in STAGES:
        raise ValueError(f"unknown stages {stages!r} ({' | '.join(STAGES)})")
    if cfg.student_target not in STUDENT_TARGETS:
        raise ValueError(f"unknown student target {cfg.student_target!r} "
                         f"({' | '.join(STUDENT_TARGETS)})")
    if stages == "student" and cfg.student_target != "target":
        raise ValueError("the student stage alone learns from the dataset's targets: it needs "
                         "student_target 'target' (a distilled student needs the teacher)")
    rank, world = _dist()
    run = Run(cfg, rank, quiet)
    run.log(f"config {json.dumps(asdict(cfg))} world {world}")
    renderer = Renderer()
    try:
        images = load_images(cfg.data, "train", renderer, sun=cfg.student_sun,
                             multiscatter=cfg.student_multiscatter,
                             visibility=cfg.student_visibility)
    finally:
        renderer.release()
    run.log(f"{len(images)} training images, {sum(i.v.shape[0] for i in images)} foreground pixels")
    result: dict = {"world": world}
    training = {"data": data_summary(cfg.data), "config": asdict(cfg), "world": world,
                "command": " ".join(sys.argv) if rank == 0 else None, "seed": cfg.seed,
                # what the weights were trained on (learned.protocol.data.dataset_hash)
                "dataset_hash": dataset_hash(cfg.data, ("train",)) if rank == 0 else None}
    if stages == "student":
        return result | _student(run, cfg, images, [img.target for img in images], training,
                                 "the dataset's targets")
    teacher, tl = train_teacher(run, images)
    result["teacher_loss"] = tl
    if rank == 0:
        result["teacher"] = str(run.out / "neural_teacher.safetensors")
        result["teacher_checkpoint"] = export(
            teacher, result["teacher"], training | {"stage": "teacher", "final_loss": tl[-1]})
    if stages == "teacher":
        return result
    unshadowed = teacher_images(teacher, images, cfg.distill_samples, cfg.strategy, cfg.seed)
    shadow, sl = train_shadow(run, images, unshadowed)
    result["shadow_loss"] = sl
    if rank == 0:  # the UNet is torch only (README "Teacher"): its state dict, width from it
        result["shadow"] = str(run.out / "shadow_final.pt")
        torch.save(shadow.state_dict(), result["shadow"])
    if stages == "shadow":
        return result
    if cfg.student_target == "target":  # the dataset's own targets (truth, for traced data)
        targets = [img.target for img in images]
    else:
        targets = distillation_targets(images, unshadowed, shadow)
    result |= _student(run, cfg, images, targets, training,
                       result.get("teacher_checkpoint") if cfg.student_target == "teacher"
                       else "the dataset's targets")
    if rank == 0:
        run.log(f"teacher: {teacher.parameter_count()} parameters, "
                f"{teacher.macs_per_sample()} multiply-adds per light sample")
    return result


def _student(run: Run, cfg: TrainConfig, images, targets, training: dict, source) -> dict:
    """Train the student on ``targets`` and export it (rank 0): its entries of the summary."""
    student, stl = distill_student(run, images, targets)
    result = {"student_loss": stl}
    if run.rank == 0:
        result["student"] = str(run.out / "neural_student.safetensors")
        result["student_checkpoint"] = export(
            student, result["student"],
            training | {"stage": "student", "final_loss": stl[-1], "distilled_from": source})
        run.log(f"student: {student.parameter_count()} parameters, {student.macs_per_pixel()} "
                f"multiply-adds per pixel")
    return result


def pipeline(out: str, data: str | None = None, quick: bool = True, install: bool = False,
             quiet: bool = False, stages: str = "all", **overrides) -> dict:
    """What ``relight train`` runs: generate the synthetic dataset when ``data`` is None
    (``OUT/data``, :data:`QUICK_DATA`), train ``stages`` (:func:`train`; ``overrides``: fields
    of :class:`TrainConfig`), export, and with ``install`` copy the weights to
    ``assets/weights`` (temporary file + rename each). Under torchrun every process calls it;
    rank 0 generates the data and writes the files, and the process group is closed at the end."""
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
    res = train(cfg, stages, quiet=quiet)
    if install and res.get("student"):
        for kind in ("student", "teacher"):  # the student stage alone installs the student
            if not res.get(kind):
                continue
            dst = default_weights(kind)
            tmp = dst.with_suffix(".tmp")
            shutil.copyfile(res[kind], tmp)
            os.replace(tmp, dst)
            res[f"installed_{kind}"] = str(dst)
    _close_dist()
    return res


def checkpoint_of(model) -> str:
    """The checkpoint sha256 of a torch network, as its exported weights file records it."""
    return checkpoint_hash(network_tensors(model))
