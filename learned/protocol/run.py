"""The protocol's measurement: students of several training seeds against the strongest
classical model given the same evidence, on a protocol dataset (:mod:`learned.protocol.data`)
at one degradation level (:mod:`learned.protocol.degrade`).

    report = run_protocol(ProtocolConfig(data="runs/protocol", seeds=(0, 1, 2), level=0.5))
    print(format_report(report))

Steps (each cached under ``OUT/level-<L>-steps-<N>-<design>/``, so an interrupted run resumes
where it stopped; ``<design>`` is :func:`design_key`, the hash of the student's design and inputs
and of the classical variants' names, so a run after either changes trains and scores afresh
instead of loading the students and val scores of another design):

1. the inputs of every split at the level (the degraded copy of the dataset; the targets are the
   true scene's), with the renderer's screen-space inputs (SSAO, S(x), L_ind) computed on them;
2. per training seed, a student of the shipped design (:data:`SHIPPED_STUDENT`) trained on the
   train split's inputs and targets (``seed-<s>/student.pt`` checkpoints and resumes;
   ``seed-<s>/neural_student.safetensors`` records the command, seed, dataset hash and its
   validation score); its per-sample validation PSNR in ``seed-<s>/val.json``. The steps are
   fixed in advance: nothing about a student is chosen by any score;
3. every classical variant (:func:`learned.protocol.classical.variants`) scored on the
   validation split (``classical-val.json``); the best one is the baseline;
4. the test split scored once per call: every seed's student, the baseline, the classical
   default and (``shipped``) a given weights file, each through the same torch inputs. The
   paired difference student - baseline per test sample, with its 95 % paired-bootstrap
   interval over the samples and over the seeds and samples. The scoring is appended to the
   dataset's ledger (:mod:`learned.protocol.scores`) and the report says how many times the
   test split has been scored.

Everything is evaluated in torch on the same per-pixel inputs the student trains on (its GLSL
twin is held to it by the parity checks); PSNR as ``relight eval`` computes it.
"""
from __future__ import annotations

import hashlib
import json
import os
import shlex
import sys
import time
from dataclasses import asdict, dataclass, replace
from pathlib import Path

import numpy as np
import torch

from ..export import export, load_model
from ..train.config import SHIPPED_STUDENT, TrainConfig
from ..train.runner import Run
from ..train.stages import design_features, distill_student, load_images
from .classical import DEFAULT, Classical, classical_radiance, variants
from .data import dataset_hash, load_protocol
from .degrade import degraded_dataset
from .scores import paired_bootstrap, psnr, record_test


@dataclass(frozen=True)
class ProtocolConfig:
    data: str  # a protocol dataset (relight data OUT --protocol)
    out: str | None = None  # default DATA/_protocol
    seeds: tuple[int, ...] = (0, 1, 2)
    level: float = 0.0  # G-buffer degradation (learned.protocol.degrade)
    student_steps: int = SHIPPED_STUDENT["student_steps"]
    shipped: str | None = None  # a weights file scored beside the students (e.g. the shipped one)
    resamples: int = 10000  # bootstrap resamples


def design_key() -> str:
    """Ten hex digits of the sha256 of what the cached steps depend on besides the data, the
    level and the steps: the shipped student's design and training (:data:`SHIPPED_STUDENT`),
    every input :func:`~learned.neural.lighting.student_features` forms (``ALL_INPUTS``) and the
    classical variants' names (which name every switch, specular occlusion's included)."""
    from ..neural.student import ALL_INPUTS

    text = json.dumps({"student": SHIPPED_STUDENT, "inputs": list(ALL_INPUTS),
                       "classical": [m.name for m in variants()]}, sort_keys=True, default=list)
    return hashlib.sha256(text.encode()).hexdigest()[:10]


def _run_root(cfg: ProtocolConfig) -> Path:
    return (Path(cfg.out or Path(cfg.data) / "_protocol")
            / f"level-{cfg.level:g}-steps-{cfg.student_steps}-{design_key()}")


def _write_json(path: Path, data) -> None:
    tmp = path.with_suffix(".tmp")
    tmp.write_text(json.dumps(data, indent=1))
    os.replace(tmp, path)


def _features(model, images):
    return design_features(model, images)


@torch.no_grad()
def student_scores(model, images) -> list[float]:
    """Per-image PSNR of a :class:`~learned.neural.student.Student` on ``images``."""
    out = []
    for img, f in zip(images, _features(model, images)):
        x, irr, pre, *sun = f
        ind = img.indirect
        pred = model(x, irr, pre, ind, *sun) if (model.learns_indirect or sun) else \
            model(x, irr, pre) + (ind if ind is not None else 0.0)
        out.append(psnr(pred, img.target))
    return out


def classical_scores(model: Classical, images) -> list[float]:
    return [psnr(classical_radiance(model, img), img.target) for img in images]


def _log(msg: str, quiet: bool) -> None:
    if not quiet:
        print(f"[{time.strftime('%H:%M:%S')}] {msg}", file=sys.stderr, flush=True)


class _Run(Run):
    """A training run whose log lines go to ``train.log`` only (stdout carries the report; the
    step loop's progress bar stays on stderr)."""

    def log(self, msg: str) -> None:
        with open(self.out / "train.log", "a") as f:
            f.write(f"[{time.strftime('%H:%M:%S')}] {msg}\n")


def _train_config(cfg: ProtocolConfig, seed: int, root: str) -> TrainConfig:
    return replace(TrainConfig.quick(root, str(_run_root(cfg) / f"seed-{seed}"), **SHIPPED_STUDENT),
                   student_steps=int(cfg.student_steps), seed=int(seed))


def _finished(cfg: ProtocolConfig, seed: int) -> bool:
    return all((_run_root(cfg) / f"seed-{seed}" / f).is_file()
               for f in ("neural_student.safetensors", "val.json"))


def train_seed(cfg: ProtocolConfig, seed: int, root: str, train: list, val_images, digest: str,
               quiet: bool = False) -> dict:
    """The student of ``seed`` (trained on the ``train`` images, or loaded when finished) and its
    validation scores (``val_images()``: the val split's images, loaded when first needed);
    ``digest``: the hash of the train split it learns from."""
    run_dir = _run_root(cfg) / f"seed-{seed}"
    weights = run_dir / "neural_student.safetensors"
    val_path = run_dir / "val.json"
    if weights.is_file() and val_path.is_file():
        _log(f"seed {seed}: finished, loaded ({weights})", quiet)
        return {"weights": str(weights), "val": json.loads(val_path.read_text())["psnr"]}
    tcfg = _train_config(cfg, seed, root)
    student, losses = distill_student(_Run(tcfg, 0, quiet), train, [i.target for i in train])
    val = student_scores(student, val_images())
    command = (f"relight eval {cfg.data} --protocol --seeds {','.join(map(str, cfg.seeds))} "
               f"--degrade {cfg.level:g} --student-steps {cfg.student_steps}")
    export(student, weights, {
        "command": command, "seed": int(seed), "dataset": str(cfg.data),
        "dataset_hash": digest, "dataset_hash_of": "the train split",
        "degrade": float(cfg.level), "config": asdict(tcfg), "stage": "student",
        "final_loss": losses[-1], "distilled_from": "the dataset's targets",
        "scores": {"val_psnr": float(np.mean(val)), "val_samples": len(val)}})
    _write_json(val_path, {"psnr": val})
    return {"weights": str(weights), "val": val}


def _split_images(cfg, protocol, images: dict, split: str, renderer, quiet: bool):
    """The inputs of ``split`` at the level, loaded once into ``images`` (the split complete,
    its degraded copy written)."""
    if split not in images:
        _check_complete(cfg, protocol, split)
        root = str(degraded_dataset(cfg.data, cfg.level, splits=(split,), progress=not quiet))
        _log(f"loading {split} inputs (level {cfg.level:g})", quiet)
        images[split] = load_images(root, split, renderer, sun=True, multiscatter=True)
    return images[split]


def pick_classical(cfg: ProtocolConfig, images: dict, quiet: bool = False) -> dict:
    """Every classical variant's validation scores (cached) and the best one's name."""
    path = _run_root(cfg) / "classical-val.json"
    if path.is_file():
        data = json.loads(path.read_text())
    else:
        _log(f"scoring {len(variants())} classical variants on val", quiet)
        data = {"variants": [{"model": asdict(m), "name": m.name,
                              "psnr": classical_scores(m, images["val"])} for m in variants()]}
        _write_json(path, data)
    best = max(data["variants"], key=lambda v: float(np.mean(v["psnr"])))
    data["best"] = best
    return data


def _check_complete(cfg: ProtocolConfig, protocol: dict, split: str) -> None:
    """A one-line :class:`DatasetError` when ``split`` has fewer samples than its configuration
    (a protocol dataset still being generated)."""
    from ..data.reader import DatasetError, list_samples

    want = int(protocol["splits"][split]["count"])
    have = len(list_samples(cfg.data, split)) if (Path(cfg.data) / split).is_dir() else 0
    if have < want:
        raise DatasetError(f"the {split} split has {have} of its {want} samples: finish it with "
                           "relight data OUT --protocol", where=cfg.data)


def run_protocol(cfg: ProtocolConfig, quiet: bool = False, renderer=None) -> dict:
    """Steps 1-4 of the module docstring; returns the report (:func:`format_report`). The
    train split is loaded and the students trained before the val and test splits are read."""
    protocol = load_protocol(cfg.data)
    _run_root(cfg).mkdir(parents=True, exist_ok=True)
    own = renderer is None
    if own:
        from viewer.renderer import Renderer

        renderer = Renderer()
    try:
        images = {}
        _check_complete(cfg, protocol, "train")
        train_hash = dataset_hash(cfg.data, ("train",))
        root = str(degraded_dataset(cfg.data, cfg.level, splits=("train",), progress=not quiet))
        _log(f"loading train inputs (level {cfg.level:g})", quiet)
        images["train"] = load_images(root, "train", renderer, sun=True, multiscatter=True)
        for k, seed in enumerate(cfg.seeds):  # every seed's training first (checkpointed)
            if not _finished(cfg, seed):
                _log(f"student {k + 1}/{len(cfg.seeds)} (seed {seed}): training "
                     f"{cfg.student_steps} steps", quiet)
                train = images["train"]
                distill_student(_Run(_train_config(cfg, seed, root), 0, quiet), train,
                                [i.target for i in train])
        students = {}
        for k, seed in enumerate(cfg.seeds):
            _log(f"student {k + 1}/{len(cfg.seeds)} (seed {seed})", quiet)

            def val_images():
                return _split_images(cfg, protocol, images, "val", renderer, quiet)

            students[seed] = train_seed(cfg, seed, root, images["train"], val_images,
                                        train_hash, quiet)
        for split in ("val", "test"):
            _split_images(cfg, protocol, images, split, renderer, quiet)
    finally:
        if own:
            renderer.release()
    digest = protocol.get("hash") or dataset_hash(cfg.data)
    classical = pick_classical(cfg, images, quiet)
    best = Classical(**classical["best"]["model"])
    _log("scoring the test split", quiet)
    test = images["test"]
    rows = {"baseline": classical_scores(best, test), "default": classical_scores(DEFAULT, test)}
    per_seed = {s: student_scores(load_model(r["weights"], "student"), test)
                for s, r in students.items()}
    if cfg.shipped:
        rows["shipped"] = student_scores(load_model(cfg.shipped, "student"), test)
    diff = np.array([np.array(v) - np.array(rows["baseline"]) for v in per_seed.values()])
    models = [f"student seed {s}" for s in per_seed] + [best.name, DEFAULT.name] + (
        [f"weights {cfg.shipped}"] if cfg.shipped else [])
    count = record_test(cfg.data, f"relight eval --protocol --degrade {cfg.level:g}", models,
                        len(test), digest)
    report = {
        "data": str(cfg.data), "dataset_hash": digest, "level": cfg.level,
        "seeds": list(cfg.seeds), "student_steps": cfg.student_steps,
        "samples": {s: len(v) for s, v in images.items()},
        "baseline": {"name": best.name, "model": asdict(best),
                     "val_psnr": float(np.mean(classical["best"]["psnr"]))},
        "val": {"students": {str(s): float(np.mean(r["val"])) for s, r in students.items()},
                "baseline": float(np.mean(classical["best"]["psnr"])),
                "variants": len(classical["variants"])},
        "test": {"students": {str(s): float(np.mean(v)) for s, v in per_seed.items()},
                 "student_mean": float(diff.mean() + np.mean(rows["baseline"])),
                 "baseline": float(np.mean(rows["baseline"])),
                 "default": float(np.mean(rows["default"])),
                 "shipped": float(np.mean(rows["shipped"])) if "shipped" in rows else None,
                 "diff_over_samples": paired_bootstrap(diff, cfg.resamples, over_seeds=False),
                 "diff_over_seeds_and_samples": paired_bootstrap(diff, cfg.resamples),
                 "diff_per_seed": {str(s): paired_bootstrap(d, cfg.resamples)
                                   for s, d in zip(per_seed, diff)}},
        "test_scored": count,
        "command": " ".join(shlex.quote(a) for a in ["relight", *sys.argv[1:]])
        if sys.argv and sys.argv[0].endswith(("relight", "__main__.py")) else None,
    }
    if "shipped" in rows:
        report["test"]["diff_shipped"] = paired_bootstrap(
            np.array(rows["shipped"]) - np.array(rows["baseline"]), cfg.resamples)
    _write_json(_run_root(cfg) / "report.json", report)
    for s, r in students.items():  # beside each weights file: its val and test scores
        _write_json(Path(r["weights"]).with_suffix(".json"), {
            "command": report["command"], "seed": s, "dataset_hash": digest,
            "degrade": cfg.level, "val_psnr": float(np.mean(r["val"])),
            "test_psnr": report["test"]["students"][str(s)], "test_scored": count})
    return report


def _times(n: int) -> str:
    return f"{n} time" if n == 1 else f"{n} times"


def _ci(d: dict) -> str:
    return f"{d['mean']:+.2f} dB [{d['lo']:+.2f}, {d['hi']:+.2f}]"


def format_report(r: dict) -> str:
    t = r["test"]
    n = r["samples"]
    lines = [f"protocol {r['data']} (sha256 {r['dataset_hash'][:12]}), G-buffer degradation "
             f"{r['level']:g}; train {n['train']}, val {n['val']}, test {n['test']} samples",
             f"baseline (best of {r['val']['variants']} classical variants on val, "
             f"{r['val']['baseline']:.2f} dB there): {r['baseline']['name']}",
             f"TEST (scored {_times(r['test_scored'])}, this one included):",
             f"  {'model':<58} {'PSNR dB':>8}"]
    for s, v in t["students"].items():
        label = f"student seed {s} (val {r['val']['students'][s]:.2f})"
        lines.append(f"  {label:<58} {v:>8.2f}")
    lines.append(f"  {'student, mean over seeds':<58} {t['student_mean']:>8.2f}")
    lines.append(f"  {'baseline: ' + r['baseline']['name']:<58} {t['baseline']:>8.2f}")
    lines.append(f"  {'classical default (split-sum + SSAO + indirect, ms)':<58} "
                 f"{t['default']:>8.2f}")
    if t.get("shipped") is not None:
        lines.append(f"  {'given weights (--weights)':<58} {t['shipped']:>8.2f}")
    lines.append("  student - baseline, paired, 95 % bootstrap interval:")
    lines.append(f"    over samples (mean of seeds)      {_ci(t['diff_over_samples'])}")
    lines.append(f"    over seeds and samples            {_ci(t['diff_over_seeds_and_samples'])}")
    for s, d in t["diff_per_seed"].items():
        lines.append(f"    seed {s:<29} {_ci(d)}")
    if t.get("diff_shipped"):
        lines.append(f"    given weights - baseline          {_ci(t['diff_shipped'])}")
    lines.append(f"(test split scored {_times(r['test_scored'])}; ledger "
                 f"{Path(r['data']) / 'test_ledger.json'})")
    return "\n".join(lines)
