"""Validation of decoded splat fields, shared by every splat reader (:mod:`.ply`, :mod:`.formats`):
:func:`fields_to_splats`.

Splats with NaN/Inf values, zero quaternions or huge/infinite scales are dropped; tiny scales are
clamped to :data:`MIN_SIGMA`; material values outside [0, 1] are clamped. Each kind of fix
produces one warning naming the file and the count. Zero splats (or none left) is a warning too.
"""
from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np

from .data import Splats, make_splats


MIN_SIGMA = 1e-7
MAX_SIGMA = 1e4


def fields_to_splats(path, f: dict, stacklevel: int = 2) -> Splats:
    """Validate decoded fields (every reader's output) into :class:`Splats`: ``means`` [N, 3],
    ``sh`` [N, K, 3], ``opacity`` [N] in [0, 1] (NaN = unreadable), ``log_scale`` [N, 3],
    ``rot`` [N, 4] (w, x, y, z), optional ``albedo`` [N, 3], ``roughness``, ``metallic`` [N],
    ``normals`` [N, 3] (any length; zero = none). Drops, clamps and warns as the module
    docstring says."""
    path = Path(path)
    stacklevel += 1
    means, sh, opacity = f["means"], f["sh"], f["opacity"]
    log_scale, rot = f["log_scale"], f["rot"]
    albedo, rough, metal = f.get("albedo"), f.get("roughness"), f.get("metallic")
    normals = f.get("normals")
    n = means.shape[0]
    if n == 0:
        warnings.warn(f"{path}: no splats", stacklevel=stacklevel)
    mats = albedo is not None
    arrays = [a.reshape(n, int(np.prod(a.shape[1:]))) for a in
              (means, sh, opacity, log_scale, rot, albedo, rough, metal, normals) if a is not None]
    finite = np.all(np.isfinite(np.concatenate(arrays, axis=1)), axis=1) if n else np.ones(0, bool)
    with np.errstate(over="ignore"):
        sigma = np.exp(log_scale)
    qnorm = np.linalg.norm(rot, axis=1)
    zero_q = finite & ~(qnorm > 1e-12)
    huge = finite & ~zero_q & np.any(sigma > MAX_SIGMA, axis=1)
    keep = finite & ~zero_q & ~huge
    for count, what in ((np.sum(~finite), "with NaN or Inf values"),
                        (np.sum(zero_q), "with zero quaternions"),
                        (np.sum(huge), f"with scales above {MAX_SIGMA:g}")):
        if count:
            warnings.warn(f"{path}: dropped {int(count)} splats {what}", stacklevel=stacklevel)
    tiny = keep & np.any(sigma < MIN_SIGMA, axis=1)
    if tiny.any():
        warnings.warn(f"{path}: clamped the scales of {int(tiny.sum())} splats to {MIN_SIGMA:g}",
                      stacklevel=stacklevel)
    sigma = np.clip(np.where(np.isfinite(sigma), sigma, MAX_SIGMA), MIN_SIGMA, MAX_SIGMA)
    if mats:
        vals = np.concatenate([albedo, rough[:, None], metal[:, None]], axis=1)
        out = keep & np.any((vals < 0.0) | (vals > 1.0), axis=1)
        if out.any():
            warnings.warn(f"{path}: clamped the materials of {int(out.sum())} splats to [0, 1]",
                          stacklevel=stacklevel)
        albedo, rough, metal = (np.clip(a, 0.0, 1.0) for a in (albedo, rough, metal))
    if normals is not None:
        length = np.linalg.norm(normals, axis=1, keepdims=True)
        normals = np.where(length > 1e-12, normals / np.maximum(length, 1e-30), 0.0)
    splats = make_splats(means[keep], sigma[keep], rot[keep], opacity[keep], sh=sh[keep],
                         albedo=None if albedo is None else albedo[keep],
                         roughness=None if rough is None else rough[keep],
                         metallic=None if metal is None else metal[keep],
                         normals=None if normals is None else normals[keep], source=str(path))
    if n and not len(splats):
        warnings.warn(f"{path}: no valid splats left", stacklevel=stacklevel)
    return splats
