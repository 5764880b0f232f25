"""Gaussian-splat PLY files: the INRIA 3DGS layout, the relightable layouts of GS-IR, R3DG and
GaussianShader, and SuperSplat's compressed PLY. Other formats: :mod:`.formats`.

Every layout is decoded into the same raw fields (means, SH, opacity, log sigma, quaternion,
optional albedo / roughness / metallic / normal), then validated once
(:func:`~.validate.fields_to_splats`). The layout is told from the property names:

* **3DGS** (INRIA): one ``vertex`` element with ``x y z``; ``f_dc_0..2`` (SH band 0);
  ``f_rest_*`` (3 (K - 1) values, channel-major: all of red's higher coefficients, then green's,
  then blue's; K = 1, 4, 9 or 16); ``opacity`` as a logit (sigmoid applied); ``scale_0..2`` as
  log sigma (exp applied); ``rot_0..3`` a quaternion, w first, not necessarily normalised.
  ``nx ny nz`` are normals where non-zero (INRIA writes zeros: then the shortest axis is used).
* **GS-IR**: 3DGS + ``normal_0..2``, ``albedo_0..2``, ``roughness``, ``metallic``, stored as
  values in [0, 1] (this is also what :func:`write_ply` writes).
* **R3DG** (Relightable 3D Gaussians, Gao et al. 2023, ``scene/gaussian_model.py``): 3DGS +
  ``nx ny nz`` (normal, normalised), ``base_color_0..2`` (pre-activation: albedo =
  0.77 sigmoid(x) + 0.03), ``roughness`` (pre-activation: 0.9 sigmoid(x) + 0.09); metallic = 0
  (R3DG's BRDF has none). ``incidents_dc_*``, ``incidents_rest_*`` (baked incident light SH) and
  ``visibility_dc_*``, ``visibility_rest_*`` (baked visibility SH) describe the capture's light,
  not the surface: ignored, with the warning below.
* **GaussianShader** (Jiang et al. 2024): ``f_dc_0..2`` hold the diffuse colour (albedo =
  clamp(f_dc, 0, 1); the baked colour is that albedo), ``roughness`` and ``specular0..2``
  pre-sigmoid (roughness = sigmoid(x); metallic = mean of the specular tint sigmoid(s) - an
  approximation: a tinted specular colour has no exact metallic-roughness equivalent), normal =
  normalise(shortest axis + ``nx ny nz``) (their residual for the side the shortest axis faces;
  ``nx2 ny2 nz2``, the other side's residual, needs a view-dependent normal and is ignored), and
  ``f_rest_*`` are BRDF-MLP features, not SH: ignored.
* **SuperSplat compressed**: a ``chunk`` element and ``vertex`` with ``packed_*`` properties
  (optionally an ``sh`` element); the bit layout is in :mod:`.compressed`, which decodes it.

Every property (or element) the chosen layout does not use is named once in one warning per file,
so nothing is silently ignored.

:func:`write_ply` writes the GS-IR layout (binary little-endian).

Validation (:mod:`.validate`): splats that cannot be drawn are dropped, tiny scales and material
values outside [0, 1] clamped, each kind of fix with one warning. Structural problems (not a PLY,
truncated, missing or list-typed properties, an unsupported f_rest count) raise
:class:`~viewer.errors.InputError`. A file with zero splats loads as an empty cloud with a warning.
"""
from __future__ import annotations

import re
import warnings
from pathlib import Path

import numpy as np
from plyfile import PlyData, PlyElement

from ..errors import InputError
from .compressed import CHUNK, CHUNK_COLOR, PACKED, SPLATS_PER_CHUNK, _compressed
from .data import SH_C0, SH_COUNTS, Splats, min_axis, quat_to_matrix
from .validate import MAX_SIGMA, MIN_SIGMA, fields_to_splats

# the compressed layout's and the validation's names stay importable from here
__all__ = ["CHUNK", "CHUNK_COLOR", "CORE", "DC", "GSHADER", "MATERIAL", "MAX_SIGMA", "MIN_SIGMA",
           "NORMAL", "NXYZ", "PACKED", "R3DG", "REQUIRED", "SPLATS_PER_CHUNK", "fields_to_splats",
           "layout_of", "read_ply", "write_ply"]

CORE = ("x", "y", "z", "opacity", "scale_0", "scale_1", "scale_2", "rot_0", "rot_1", "rot_2",
        "rot_3")
DC = ("f_dc_0", "f_dc_1", "f_dc_2")
REQUIRED = CORE[:3] + DC + CORE[3:]
MATERIAL = ("albedo_0", "albedo_1", "albedo_2", "roughness", "metallic")
NORMAL = ("normal_0", "normal_1", "normal_2")
NXYZ = ("nx", "ny", "nz")
R3DG = ("base_color_0", "base_color_1", "base_color_2", "roughness")
GSHADER = ("roughness", "specular0", "specular1", "specular2")


def read_ply(path) -> Splats:
    """Load a splat PLY of any layout in the module docstring. Errors name ``path``."""
    path = Path(path)
    if not path.is_file():
        raise InputError("no such splat file", where=path)
    try:
        ply = PlyData.read(str(path))
    except Exception as exc:  # plyfile raises many types for corrupt data
        msg = " ".join(str(exc).split()) or type(exc).__name__
        raise InputError(f"not a readable PLY file (truncated or corrupt?): {msg}",
                         where=path) from None
    elements = {e.name: e for e in ply.elements}
    if "vertex" not in elements:
        raise InputError("PLY has no 'vertex' element", where=path)
    vertex = elements["vertex"]
    names = {p.name for p in vertex.properties}
    if "chunk" in elements and "packed_position" in names:
        layout = "SuperSplat compressed"
        fields, used = _compressed(elements, path)
    else:
        layout, fields, names_used = _vertex_layout(vertex, path)
        used = {("vertex", p) for p in names_used}
    _warn_unused(path, ply, used, layout)
    return fields_to_splats(path, fields, stacklevel=3)


def layout_of(names) -> str:
    """The layout a vertex element's property ``names`` select (see the module docstring)."""
    names = set(names)
    if "base_color_0" in names:
        return "R3DG"
    if "specular0" in names or "nx2" in names:
        return "GaussianShader"
    if names & set(MATERIAL + NORMAL):
        return "GS-IR"
    return "3DGS"


def _vertex_layout(vertex, path: Path):
    props = {p.name: p for p in vertex.properties}
    layout = layout_of(props)
    required = list(REQUIRED) + {"R3DG": list(R3DG), "GaussianShader": list(GSHADER)}.get(layout, [])
    missing = [name for name in required if name not in props]
    if missing:
        raise InputError(f"missing splat propert{'ies' if len(missing) > 1 else 'y'} "
                         f"{', '.join(missing)} ({layout} layout)", where=path)
    data = vertex.data
    n = len(data)

    def col(name):
        p = props[name]
        if type(p).__name__ == "PlyListProperty" or not np.issubdtype(data.dtype[name], np.number):
            raise InputError(f"property {name!r} must be a numeric scalar", where=path)
        return np.asarray(data[name], np.float64)

    def cols(names_):
        return np.stack([col(c) for c in names_], -1).reshape(n, len(names_))

    used = set(REQUIRED)
    logit = col("opacity")
    fields = {"means": cols("xyz"), "log_scale": cols(CORE[4:7]), "rot": cols(CORE[7:]),
              "opacity": _sigmoid(logit)}
    dc = cols(DC)
    if layout == "GaussianShader":
        albedo = np.clip(dc, 0.0, 1.0)
        fields["sh"] = ((albedo - 0.5) / SH_C0).reshape(n, 1, 3)
        fields["albedo"] = albedo
        fields["roughness"] = _sigmoid(col("roughness"))
        fields["metallic"] = _sigmoid(cols(GSHADER[1:])).mean(axis=1)
        used |= set(GSHADER)
        if all(c in props for c in NXYZ):
            fields["normals"] = min_axis(fields["rot"], fields["log_scale"]) + cols(NXYZ)
            used |= set(NXYZ)
        return layout, fields, used
    fields["sh"] = _sh(props, col, dc, path)
    used |= {p for p in props if p.startswith("f_rest_")}
    has_normal = layout == "GS-IR" and all(m in props for m in NORMAL)
    if all(c in props for c in NXYZ):
        nxyz = cols(NXYZ)
        placeholder = not np.any(nxyz != 0)  # INRIA's exports write zeros
        if not placeholder and not has_normal:
            fields["normals"] = nxyz
        if placeholder or not has_normal:  # beside GS-IR's normal_*, non-zero nx ny nz warn
            used |= set(NXYZ)
    if layout == "R3DG":
        fields["albedo"] = 0.77 * _sigmoid(cols(R3DG[:3])) + 0.03
        fields["roughness"] = 0.9 * _sigmoid(col("roughness")) + 0.09
        fields["metallic"] = np.zeros(n)
        used |= set(R3DG)
    elif layout == "GS-IR":
        if all(m in props for m in MATERIAL):
            fields["albedo"] = cols(MATERIAL[:3])
            fields["roughness"] = col("roughness")
            fields["metallic"] = col("metallic")
            used |= set(MATERIAL)
        if has_normal:
            fields["normals"] = cols(NORMAL)
            used |= set(NORMAL)
    return layout, fields, used


def _sh(props, col, dc, path) -> np.ndarray:
    """[N, K, 3] SH from f_dc and the channel-major f_rest_* (checked: numbered 0..m-1, m =
    3 (K - 1))."""
    rest = sorted((p for p in props if p.startswith("f_rest_")),
                  key=lambda p: int(p[7:]) if p[7:].isdigit() else -1)
    if rest and rest != [f"f_rest_{i}" for i in range(len(rest))]:
        raise InputError("f_rest_* properties must be numbered 0..n-1", where=path)
    k = len(rest) // 3 + 1
    if len(rest) % 3 or k not in SH_COUNTS:
        raise InputError(f"{len(rest)} f_rest properties: expected 0, 9, 24 or 45 "
                         f"(SH degree 0-3)", where=path)
    n = dc.shape[0]
    sh = np.zeros((n, k, 3))
    sh[:, 0] = dc
    for c in range(3):
        for j in range(k - 1):
            sh[:, 1 + j, c] = col(f"f_rest_{c * (k - 1) + j}")
    return sh


def _sigmoid(x: np.ndarray) -> np.ndarray:
    """Logistic function; NaN and +-Inf logits give NaN (the splat is dropped as non-finite)."""
    x = np.asarray(x, np.float64)
    out = 1.0 / (1.0 + np.exp(-np.clip(np.nan_to_num(x), -60.0, 60.0)))
    return np.where(np.isfinite(x), out, np.nan)


def _warn_unused(path: Path, ply: PlyData, used: set, layout: str) -> None:
    """One warning naming every property (and element) of ``ply`` whose (element, property)
    pair is not in ``used``."""
    unused = []
    for el in ply.elements:
        names = [p.name for p in el.properties]
        left = [p for p in names if (el.name, p) not in used]
        if not left:
            continue
        if el.name == "vertex":
            unused.append(_compact(left))
        elif len(left) == len(names):
            unused.append(f"element {el.name!r} ({_compact(names)})")
        else:
            unused.append(f"{el.name}: {_compact(left)}")
    if unused:
        warnings.warn(f"{path}: ignored PLY properties not used by the {layout} layout: "
                      f"{'; '.join(unused)}", stacklevel=3)


def _compact(names: list[str]) -> str:
    """``a_0, a_1, a_2, b`` -> ``a_0..2, b``: consecutive numbers of one prefix collapsed."""
    parsed = [re.fullmatch(r"(.*?)(\d+)", nm) for nm in names]
    out, i = [], 0
    while i < len(names):
        j = i
        while (parsed[i] and j + 1 < len(names) and parsed[j + 1]
               and parsed[j + 1].group(1) == parsed[i].group(1)
               and int(parsed[j + 1].group(2)) == int(parsed[i].group(2)) + j + 1 - i):
            j += 1
        out.append(names[i] if j == i else f"{names[i]}..{parsed[j].group(2)}")
        i = j + 1
    return ", ".join(out)


def write_ply(path, splats: Splats, text: bool = False, comments=()) -> None:
    """Write the relightable layout: 3DGS properties plus ``normal_*``, ``albedo_*``,
    ``roughness``, ``metallic`` (binary little-endian unless ``text``); ``comments``: header
    comment lines (e.g. ``"up +Z"``, the up-axis marker :mod:`viewer.scene.orientation` reads)."""
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
    PlyData([PlyElement.describe(arr, "vertex")], text=text,
            comments=list(comments)).write(str(path))
