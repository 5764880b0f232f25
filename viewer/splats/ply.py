"""Gaussian-splat PLY files: the INRIA 3DGS layout and the GS-IR relightable extension.

Reads (ASCII or binary, through plyfile) one ``vertex`` element with

* ``x y z``; ``f_dc_0..2`` (SH band 0); ``f_rest_*`` (3 (K - 1) values, channel-major: all of
  red's higher coefficients, then green's, then blue's; K = 1, 4, 9 or 16);
* ``opacity`` as a logit (sigmoid applied); ``scale_0..2`` as log sigma (exp applied);
  ``rot_0..3`` a quaternion, w first, not necessarily normalised;
* optionally (GS-IR) ``normal_0..2``, ``albedo_0..2``, ``roughness``, ``metallic``. 3DGS exports
  often carry ``nx ny nz`` = 0; those are ignored.

:func:`write_ply` writes the relightable layout (binary little-endian).

Validation: splats with NaN/Inf values, zero quaternions or huge/infinite scales are dropped; tiny
scales are clamped to :data:`MIN_SIGMA`; material values outside [0, 1] are clamped. Each kind of
fix produces one warning naming the file and the count. Structural problems (not a PLY, truncated,
missing or list-typed properties, an unsupported f_rest count) raise
:class:`~viewer.errors.InputError`. A file with zero splats loads as an empty cloud with a warning.
"""
from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
from plyfile import PlyData, PlyElement

from ..errors import InputError
from .data import SH_COUNTS, Splats, make_splats

MIN_SIGMA = 1e-7
MAX_SIGMA = 1e4
REQUIRED = ("x", "y", "z", "f_dc_0", "f_dc_1", "f_dc_2", "opacity", "scale_0", "scale_1",
            "scale_2", "rot_0", "rot_1", "rot_2", "rot_3")
MATERIAL = ("albedo_0", "albedo_1", "albedo_2", "roughness", "metallic")
NORMAL = ("normal_0", "normal_1", "normal_2")


def read_ply(path) -> Splats:
    """Load a splat PLY (see the module docstring). Errors name ``path``."""

    path = Path(path)
    if not path.is_file():
        raise InputError("no such splat file", where=path)
    try:
        ply = PlyData.read(str(path))
    except Exception as exc:  # plyfile raises many types for corrupt data
        msg = " ".join(str(exc).split()) or type(exc).__name__
        raise InputError(f"not a readable PLY file (truncated or corrupt?): {msg}",
                         where=path) from None
    try:
        vertex = ply["vertex"]
    except KeyError:
        raise InputError("PLY has no 'vertex' element", where=path) from None
    props = {p.name: p for p in vertex.properties}
    missing = [name for name in REQUIRED if name not in props]
    if missing:
        raise InputError(f"missing splat propert{'ies' if len(missing) > 1 else 'y'} "
                         f"{', '.join(missing)}", where=path)
    for name, p in props.items():
        if name in REQUIRED or name in MATERIAL or name in NORMAL or name.startswith("f_rest_"):
            if type(p).__name__ == "PlyListProperty" or not _numeric(vertex, name):
                raise InputError(f"property {name!r} must be a numeric scalar", where=path)
    rest = sorted((n for n in props if n.startswith("f_rest_")), key=lambda n: int(n[7:])
                  if n[7:].isdigit() else -1)
    if rest and [n for n in rest] != [f"f_rest_{i}" for i in range(len(rest))]:
        raise InputError("f_rest_* properties must be numbered 0..n-1", where=path)
    k = len(rest) // 3 + 1
    if len(rest) % 3 or k not in SH_COUNTS:
        raise InputError(f"{len(rest)} f_rest properties: expected 0, 9, 24 or 45 "
                         f"(SH degree 0-3)", where=path)

    data = vertex.data
    n = len(data)
    if n == 0:
        warnings.warn(f"{path}: no splats", stacklevel=2)

    def col(name):
        return np.asarray(data[name], np.float64)

    means = np.stack([col(c) for c in "xyz"], -1)
    sh = np.zeros((n, k, 3))
    for c in range(3):
        sh[:, 0, c] = col(f"f_dc_{c}")
        for j in range(k - 1):
            sh[:, 1 + j, c] = col(f"f_rest_{c * (k - 1) + j}")
    logit = col("opacity")
    log_scale = np.stack([col(f"scale_{i}") for i in range(3)], -1)
    rot = np.stack([col(f"rot_{i}") for i in range(4)], -1)
    mats = all(m in props for m in MATERIAL)
    albedo = np.stack([col(f"albedo_{i}") for i in range(3)], -1) if mats else None
    rough = col("roughness") if mats else None
    metal = col("metallic") if mats else None
    normals = np.stack([col(n_) for n_ in NORMAL], -1) if all(m in props for m in NORMAL) else None

    arrays = [means, sh.reshape(n, 3 * k), logit[:, None], log_scale, rot]
    arrays += [a.reshape(n, a.size // max(n, 1)) for a in (albedo, rough, metal, normals) if a is not None]
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
            warnings.warn(f"{path}: dropped {int(count)} splats {what}", stacklevel=2)
    tiny = keep & np.any(sigma < MIN_SIGMA, axis=1)
    if tiny.any():
        warnings.warn(f"{path}: clamped the scales of {int(tiny.sum())} splats to {MIN_SIGMA:g}",
                      stacklevel=2)
    sigma = np.clip(np.where(np.isfinite(sigma), sigma, MAX_SIGMA), MIN_SIGMA, MAX_SIGMA)
    opacity = 1.0 / (1.0 + np.exp(-np.clip(logit, -60.0, 60.0)))
    if mats:
        vals = np.concatenate([albedo, rough[:, None], metal[:, None]], axis=1)
        out = keep & np.any((vals < 0.0) | (vals > 1.0), axis=1)
        if out.any():
            warnings.warn(f"{path}: clamped the materials of {int(out.sum())} splats to [0, 1]",
                          stacklevel=2)
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
        warnings.warn(f"{path}: no valid splats left", stacklevel=2)
    return splats


def _numeric(vertex, name: str) -> bool:
    return np.issubdtype(vertex.data.dtype[name], np.number)


def write_ply(path, splats: Splats, text: bool = False) -> None:
    """Write the relightable layout: 3DGS properties plus ``normal_*``, ``albedo_*``,
    ``roughness``, ``metallic`` (binary little-endian unless ``text``)."""
    n, k = len(splats), splats.sh.shape[1]
    names = ["x", "y", "z", "normal_0", "normal_1", "normal_2", "f_dc_0", "f_dc_1", "f_dc_2"]
    names += [f"f_rest_{i}" for i in range(3 * (k - 1))]
    names += ["opacity", "scale_0", "scale_1", "scale_2", "rot_0", "rot_1", "rot_2", "rot_3"]
    names += list(MATERIAL)
    arr = np.empty(n, dtype=[(nm, "f4") for nm in names])
    for i, c in enumerate("xyz"):
        arr[c] = splats.means[:, i]
    for i in range(3):
        arr[f"normal_{i}"] = splats.normals[:, i]
        arr[f"f_dc_{i}"] = splats.sh[:, 0, i]
        arr[f"scale_{i}"] = np.log(splats.scales[:, i])
        arr[f"albedo_{i}"] = splats.albedo[:, i]
        for j in range(k - 1):
            arr[f"f_rest_{i * (k - 1) + j}"] = splats.sh[:, 1 + j, i]
    op = np.clip(splats.opacities.astype(np.float64), 1e-7, 1 - 1e-7)
    arr["opacity"] = np.log(op / (1 - op))
    for i in range(4):
        arr[f"rot_{i}"] = splats.rotations[:, i]
    arr["roughness"] = splats.roughness
    arr["metallic"] = splats.metallic
    PlyData([PlyElement.describe(arr, "vertex")], text=text).write(str(path))
