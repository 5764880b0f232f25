"""Scoring a render against a path-traced :class:`~relight.reference.render.Reference`.

Two kinds of check, as Mitsuba's own render tests make them:

* **z-test** (:func:`z_test`): for an image that should equal the reference in expectation (the
  same integrand, e.g. ``ggx_mc``), each pixel's difference divided by its combined standard error
  is a standard normal variate. With Bonferroni's correction over ``P`` pixels the test fails
  when any |z| exceeds the two-sided normal quantile at ``alpha / P``; the false-alarm rate of the
  whole image is then at most ``alpha``, on any hardware, because it depends only on the
  reference's and the image's own sample variance.
* **approximation scores** (:func:`score`): a model that approximates (split-sum, SH) differs by
  more than noise; its total energy bias and median per-pixel relative error are compared with a
  documented bound, after subtracting what the reference's noise can explain.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from statistics import NormalDist

import numpy as np

from .render import Reference


def normal_quantile(p: float) -> float:
    """The standard normal quantile z with P(Z > z) = p."""
    return NormalDist().inv_cdf(1.0 - p)


def coverage_mask(image: np.ndarray, ref: Reference) -> np.ndarray:
    """Pixels fully covered in both (alpha > 0.99): the silhouette's partial pixels differ by
    rasterisation, not shading."""
    cov = ref.radiance[..., 3] > 0.99
    if image.shape[-1] >= 4:
        cov &= image[..., 3] > 0.99
    return cov


@dataclass(frozen=True)
class ZTest:
    max_abs_z: float       # the largest |z| over the tested pixel channels
    threshold: float       # Bonferroni-corrected two-sided quantile
    count: int             # pixel channels tested
    failing: int           # pixel channels beyond the threshold

    @property
    def passed(self) -> bool:
        return self.failing == 0


def z_test(image: np.ndarray, ref: Reference, image_stderr: np.ndarray | None = None,
           alpha: float = 0.01, mask: np.ndarray | None = None,
           floor: float = 0.0, quantile=None) -> ZTest:
    """Per pixel channel z = (image - ref) / sqrt(se_ref^2 + se_img^2 + floor^2) over ``mask``
    (default: :func:`coverage_mask`). ``floor`` is an absolute error the caller can justify that
    is not sampling noise (e.g. the float32 accumulation of the image); 0 by default.
    ``quantile(p)``: the two-sided threshold's distribution, the normal by default; pass a
    Student-t quantile when ``image_stderr`` is estimated from few independent renders."""
    m = coverage_mask(image, ref) if mask is None else mask
    a = np.asarray(image[..., :3], np.float64)[m]
    b = np.asarray(ref.radiance[..., :3], np.float64)[m]
    var = np.asarray(ref.stderr, np.float64)[m] ** 2 + floor ** 2
    if image_stderr is not None:
        var = var + np.asarray(image_stderr, np.float64)[m] ** 2
    z = np.abs(a - b) / np.sqrt(np.maximum(var, 1e-30))
    count = int(z.size)
    thr = (quantile or normal_quantile)(alpha / (2.0 * max(count, 1)))
    return ZTest(max_abs_z=float(z.max()) if count else 0.0, threshold=thr, count=count,
                 failing=int((z > thr).sum()))


@dataclass(frozen=True)
class Score:
    bias: float            # sum(image) / sum(ref) - 1 over covered pixels (all channels)
    bias_noise: float      # one standard error of that ratio from the reference's noise
    median_rel: float      # median over pixels of |image - ref|_1 / |ref|_1
    psnr: float            # dB, peak = the reference's 99.9th percentile
    pixels: int

    def row(self) -> dict:
        return {"bias_%": round(100 * self.bias, 2),
                "median_rel_%": round(100 * self.median_rel, 2),
                "psnr_db": round(self.psnr, 2), "pixels": self.pixels}


def score(image: np.ndarray, ref: Reference, mask: np.ndarray | None = None) -> Score:
    """Energy bias, median relative error and PSNR of ``image`` against ``ref`` (module
    docstring). The bias's noise is propagated from the reference's per-pixel standard errors
    (independent pixels): a bias within ~3 of it is not resolved by this reference."""
    m = coverage_mask(image, ref) if mask is None else mask
    a = np.asarray(image[..., :3], np.float64)[m]
    b = np.asarray(ref.radiance[..., :3], np.float64)[m]
    se = np.asarray(ref.stderr, np.float64)[m]
    total = b.sum()
    bias = a.sum() / total - 1.0
    bias_noise = math.sqrt(float((se ** 2).sum())) * a.sum() / total ** 2
    rel = np.abs(a - b).sum(-1) / np.maximum(b.sum(-1), 1e-12)
    peak = float(np.percentile(b, 99.9)) if b.size else 1.0
    mse = float(((a - b) ** 2).mean()) if b.size else 0.0
    psnr = 10.0 * math.log10(peak * peak / mse) if mse > 0 else math.inf
    return Score(bias=float(bias), bias_noise=float(bias_noise),
                 median_rel=float(np.median(rel)) if rel.size else 0.0, psnr=psnr,
                 pixels=int(m.sum()))
