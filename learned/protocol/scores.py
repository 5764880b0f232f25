"""Scores of the protocol: PSNR per sample (the metric of ``relight eval``), the paired bootstrap
of a difference, and the test set's ledger (how many times it has been scored).

The ledger is ``ROOT/test_ledger.json`` in the dataset folder: one entry per scoring of the test
split (when, what, which models, how many samples, the dataset's hash). Every test result the
protocol prints carries the count, so a reader sees how often the test set has been looked at
(and any number picked after many looks is suspect).
"""
from __future__ import annotations

import json
import math
import os
import time
from pathlib import Path

import numpy as np
import torch

LEDGER_FILE = "test_ledger.json"


def psnr(pred: torch.Tensor, target: torch.Tensor) -> float:
    """PSNR (dB) of ``pred`` against ``target`` (``[P, 3]`` linear radiance at the foreground
    pixels) on Reinhard-mapped x / (1 + x): :func:`learned.evaluate.metrics`'s ``psnr``."""
    p = pred.clamp_min(0.0)
    r = target.clamp_min(0.0)
    mse = float(((p / (1 + p) - r / (1 + r)) ** 2).mean())
    return 10.0 * math.log10(1.0 / max(mse, 1e-12))


def paired_bootstrap(diff: np.ndarray, resamples: int = 10000, seed: int = 0,
                     over_seeds: bool = True) -> dict:
    """Mean and 95 % percentile interval of the paired differences ``diff``: ``[n]`` (per
    sample) or ``[seeds, n]`` (per training seed and sample). With seeds and ``over_seeds``,
    each resample draws the seeds and the samples with replacement (the seed-to-seed spread
    counts too); otherwise the samples alone (of the mean over seeds)."""
    d = np.asarray(diff, np.float64)
    if d.ndim == 1:
        d = d[None]
    rng = np.random.default_rng(seed)
    k, n = d.shape
    if over_seeds and k > 1:
        si = rng.integers(0, k, (resamples, k))
        ni = rng.integers(0, n, (resamples, n))
        means = np.array([d[s][:, i].mean() for s, i in zip(si, ni)])
    else:
        m = d.mean(0)
        means = m[rng.integers(0, n, (resamples, n))].mean(1)
    lo, hi = np.percentile(means, [2.5, 97.5])
    return {"mean": float(d.mean()), "lo": float(lo), "hi": float(hi), "seeds": k, "samples": n,
            "resamples": resamples, "over_seeds": bool(over_seeds and k > 1)}


def ledger(root) -> list[dict]:
    path = Path(root) / LEDGER_FILE
    if not path.is_file():
        return []
    return json.loads(path.read_text()).get("entries", [])


def record_test(root, what: str, models: list[str], samples: int, dataset_hash: str) -> int:
    """Append one scoring of ``root``'s test split to its ledger; returns how many times it has
    been scored, this one included."""
    entries = ledger(root) + [{"when": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()),
                               "what": what, "models": list(models), "samples": int(samples),
                               "dataset_hash": dataset_hash}]
    path = Path(root) / LEDGER_FILE
    tmp = path.with_suffix(".tmp")
    tmp.write_text(json.dumps({"entries": entries}, indent=1))
    os.replace(tmp, path)
    return len(entries)
