"""``relight eval DATA --factors``: what a student's networks learned, as statistics of its factors.

A ``split3`` student shades ``ggx_split_sum`` times corrections S k (S =
:data:`learned.twins.neural.NEURAL_OUTPUT_SCALE`; S k = 1 is the classical model): k_d on the
diffuse light, k_a and k_b on the specular's f0 and f90 terms, and (a student with a learned
indirect factor) k_i on the screen-space one-bounce light. Over the foreground pixels of a split,
as the student sees them at run time (:func:`learned.train.stages.design_features`), each row
gives the mean of every correction and the bounce gain's 10th, 50th and 90th percentiles and its
share above 1: a student that reads only the material and n.v has no visibility evidence, so a
direct correction away from 1 changes its BRDF (the white furnace sees it), and a bounce gain
above 1 brightens every scene whose screen-space bounce is already too bright (the students
page, "Trained under sunless skies too").
"""
from __future__ import annotations

import numpy as np
import torch

from viewer.errors import RelightError

from .export import load_model
from .twins.neural import NEURAL_OUTPUT_SCALE

CORRECTIONS = ("k_d", "k_a", "k_b")  # the split3 / pbr3 student's direct corrections, in order
QUANTILES = (0.1, 0.5, 0.9)


def factor_row(name: str, model, features: list[tuple]) -> dict:
    """The statistics of ``model``'s corrections over ``features`` (``design_features``'s
    tuples, foreground pixels): ``{"student", "pixels", "k_d", "k_a", "k_b"[, "k_i",
    "k_i_p10", "k_i_p50", "k_i_p90", "k_i_above_1"]}`` (means of S k)."""
    if model.output == "free6":
        raise RelightError("a free6 student has six free per-channel factors, not split-sum "
                           "corrections: --factors reads pbr3 and split3 students", where=name)
    with torch.no_grad():
        k = torch.cat([model.network_outputs(f[0]) for f in features]) * NEURAL_OUTPUT_SCALE
    row = {"student": name, "pixels": int(k.shape[0])}
    row.update({c: float(k[:, j].mean()) for j, c in enumerate(CORRECTIONS)})
    if model.learns_indirect:
        g = k[:, 3].double().numpy()
        row["k_i"] = float(g.mean())
        for q in QUANTILES:
            row[f"k_i_p{round(100 * q):d}"] = float(np.quantile(g, q))
        row["k_i_above_1"] = float((g > 1.0).mean())
    return row


def student_factors(root: str, split: str, students: dict[str, str], limit: int | None = None,
                    renderer=None) -> list[dict]:
    """One :func:`factor_row` per student (name -> weights file) over ``split`` of dataset
    ``root`` (at most ``limit`` samples)."""
    from viewer.renderer import Renderer

    from .train.stages import design_features, load_images

    models = {name: load_model(path, "student") for name, path in students.items()}
    own = renderer is None
    renderer = renderer or Renderer()
    try:
        images = load_images(root, split, renderer, sun=True, multiscatter=True)[:limit]
    finally:
        if own:
            renderer.release()
    if not images:
        raise RelightError(f"no usable sample in its {split} split", where=root)
    return [factor_row(name, m, design_features(m, images)) for name, m in models.items()]


def format_factors(rows: list[dict]) -> str:
    """The rows as a text table (a student without an indirect factor: '-')."""
    cols = (*CORRECTIONS, "k_i", "k_i_p10", "k_i_p50", "k_i_p90", "k_i_above_1")
    lines = [f"{'student':<24} {'pixels':>8} " + " ".join(f"{c:>11}" for c in cols)]
    for r in rows:
        cells = [f"{r[c]:>11.4f}" if c in r else f"{'-':>11}" for c in cols]
        lines.append(f"{r['student']:<24} {r['pixels']:>8} " + " ".join(cells))
    return "\n".join(lines)
