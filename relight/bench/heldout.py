"""The bench against path-traced truth on held-out datasets (``relight bench --heldout DATA``).

Every model of :func:`learned.evaluate.models_to_evaluate` (the classical models alone and with the
screen-space passes, ``ggx_mc``, the shipped student, the teacher at 128 spp) is scored on every
sample of each dataset (``relight eval DATA --split all``: a dataset no model was trained on, in the
FFHQ256-PBR layout with path-traced targets, e.g. from ``learned.data.generator.held_out_config``):
mean PSNR / SSIM / HDR-FLIP / energy bias against the truth and mean ms per frame at the samples'
size. Each row says whether it is on that dataset's Pareto front (no other model is both faster and
closer in PSNR): the front the issue asks the neural model to be on.
"""
from __future__ import annotations

import math
from pathlib import Path

from viewer.errors import RelightError


def heldout_front(rows: list[dict]) -> list[dict]:
    """Rows not dominated in (lower ms, higher PSNR) within their dataset, fastest first."""
    front = []
    for name in dict.fromkeys(r["dataset"] for r in rows):
        best = -math.inf
        group = [r for r in rows if r["dataset"] == name
                 and math.isfinite(r["ms"]) and math.isfinite(r["psnr"])]
        for r in sorted(group, key=lambda r: (r["ms"], -r["psnr"])):
            if r["psnr"] > best:
                front.append(r)
                best = r["psnr"]
    return front


def heldout_rows(renderer, datasets, teacher_samples: int = 128) -> list[dict]:
    """One row per (dataset, model, variant): the dataset's folder name and path, the model's
    means over every sample and ``pareto`` (on the dataset's front)."""
    try:
        from learned.evaluate import evaluate
    except ImportError as exc:  # the learned extra (torch) is not installed
        raise RelightError(f"--heldout needs torch: pip install -e '.[learned]' ({exc})",
                           where="--heldout") from None
    rows = []
    for data in datasets:
        path = Path(data)
        if not path.is_dir():
            raise RelightError("held-out dataset folder not found", where=path)
        for r in evaluate(str(path), split="all", teacher_samples=teacher_samples,
                          renderer=renderer):
            rows.append({"dataset": path.name, "dataset_path": str(path), **r})
    front = {id(r) for r in heldout_front(rows)}
    for r in rows:
        r["pareto"] = id(r) in front
    return rows
