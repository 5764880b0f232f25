"""Students scored on frames that take a shadow estimator's V in place of SSAO's O(x) (``[render]
shadow_net_use = "visibility"``): how the student of that route was chosen on validation data.

``python -m relight.bench.student_visibility ESTIMATOR NAME=FILE [NAME=FILE ...] --data
NAME=DIR[:SPLIT] [...] [--json OUT]``

Each dataset's images are loaded as a student trained with ``relight train --student-visibility
ESTIMATOR`` sees them (:func:`learned.train.load_images` with ``visibility``: V's mean over the
colours from the estimator's torch twin on the frame its file records), and every student
file is scored in its torch form (the GL pass's twin, held to it by the ``neural`` parity
checks): the mean over the images of the PSNR of ``x / (1 + x)`` over the foreground (the metric
of ``relight eval``) against the dataset's targets. The row ``split-sum given V`` is a fresh
student of the shipped design, whose corrections start at the classical model (k = 0.5: the
split-sum base, the indirect light at factor 1): the strongest classical model given the same
evidence in the same form. A dataset's split defaults to ``val``; ``all`` takes every split (a
held-out set). Nothing here reads a test split unless asked to.
"""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

BASE = "split-sum given V"  # the classical row's name (a student at its start)


def base_student():
    """A student of the shipped design at its start: k = 0.5 everywhere, the split-sum base."""
    from learned.neural.student import Student
    from learned.train.config import SHIPPED_STUDENT

    return Student(hidden=tuple(SHIPPED_STUDENT["student_hidden"]),
                   features=SHIPPED_STUDENT["student_features"],
                   output=SHIPPED_STUDENT["student_output"],
                   indirect=SHIPPED_STUDENT["student_indirect"], sun=SHIPPED_STUDENT["student_sun"],
                   multiscatter=SHIPPED_STUDENT["student_multiscatter"]).eval()


def image_psnr(model, images) -> list[float]:
    """Per image, the PSNR of ``model``'s prediction (torch) against the target, x / (1 + x) over
    the foreground, as ``relight eval`` scores a frame."""
    import torch

    from learned.evaluate import tonemapped_psnr
    from learned.train.stages import design_features, fixed_light, student_args

    out = []
    with torch.no_grad():
        for img, f in zip(images, design_features(model, images)):
            pred = model(*student_args(model, img, f))
            fixed = fixed_light(model, img, f)
            if fixed is not None:
                pred = pred + fixed
            out.append(tonemapped_psnr(pred.numpy(), img.target.numpy()))
    return out


def load_set(renderer, root: str, split: str, estimator: str):
    """The images of ``split`` (``all``: every split) of ``root`` on V's frames."""
    from learned.data.reader import list_samples
    from learned.train import load_images

    splits = ("train", "val", "test") if split == "all" else (split,)
    return [img for s in splits if list_samples(root, s)
            for img in load_images(root, s, renderer, sun=True, multiscatter=True,
                                   visibility=estimator)]


def score(estimator: str, students: dict[str, str], sets: dict[str, tuple[str, str]],
          renderer=None, progress: bool = True) -> dict:
    """``{set name: {row: mean PSNR}}`` and ``pooled`` (the mean over the sets) for every student
    file of ``students`` (name -> file) and :data:`BASE`, on each dataset of ``sets`` (name ->
    (root, split))."""
    import numpy as np

    from learned.export import load_model
    from viewer.renderer import Renderer

    own = renderer is None
    renderer = renderer or Renderer()
    models = {BASE: base_student()} | {k: load_model(f, "student") for k, f in students.items()}
    table: dict = {}
    try:
        for name, (root, split) in sets.items():
            images = load_set(renderer, root, split, estimator)
            table[name] = {k: float(np.mean(image_psnr(m, images))) for k, m in models.items()}
            table[name]["images"] = len(images)
            if progress:
                print(f"{name} ({len(images)}): " + ", ".join(
                    f"{k} {v:.3f}" for k, v in table[name].items() if k != "images"),
                    file=sys.stderr, flush=True)
    finally:
        if own:
            renderer.release()
    table["pooled"] = {k: float(np.mean([table[s][k] for s in sets])) for k in models}
    return table


def main(argv=None) -> int:
    p = argparse.ArgumentParser(prog="python -m relight.bench.student_visibility",
                                description=__doc__.split("\n\n")[0])
    p.add_argument("estimator", help="the shadow estimator's weights file whose V the frames take")
    p.add_argument("students", nargs="+", metavar="NAME=FILE", help="student weights files")
    p.add_argument("--data", action="append", required=True, metavar="NAME=DIR[:SPLIT]",
                   help="a dataset and its split (default val; all: every split); repeatable")
    p.add_argument("--json", metavar="OUT", help="also write the table as JSON")
    args = p.parse_args(argv)
    from viewer.errors import RelightError

    try:
        students = dict(_pair(s, "student") for s in args.students)
        sets = {}
        for d in args.data:
            name, where = _pair(d, "--data")
            root, _, split = where.partition(":")
            sets[name] = (root, split or "val")
        table = score(args.estimator, students, sets)
    except RelightError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    rows = [BASE, *students]
    print("| set | " + " | ".join(rows) + " |")
    print("|---|" + "---|" * len(rows))
    for name in (*sets, "pooled"):
        n = f" ({table[name]['images']})" if "images" in table[name] else ""
        print(f"| {name}{n} | " + " | ".join(f"{table[name][r]:.3f}" for r in rows) + " |")
    if args.json:
        Path(args.json).write_text(json.dumps(table, indent=1))
    return 0


def _pair(text: str, what: str) -> tuple[str, str]:
    from viewer.errors import RelightError

    name, sep, value = text.partition("=")
    if not sep or not name or not value:
        raise RelightError(f"expected NAME=VALUE, got {text!r}", where=what)
    return name, value


if __name__ == "__main__":
    sys.exit(main())
