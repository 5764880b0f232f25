"""Gaussian-splat PLY files: the INRIA 3DGS layout, the relightable layouts of GS-IR, R3DG and
GaussianShader, and SuperSplat's compressed PLY. Other formats: :mod:`.formats`.

Every layout is decoded into the same raw fields (means, SH, opacity, log sigma, quaternion,
optional albedo / roughness / metallic / normal), then validated once
(:func:`fields_to_splats`). The layout is told from the property names:

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
* **SuperSplat compressed** (PlayCanvas ``gsplat-compressed-data.js``): a ``chunk`` element
  (one per 256 splats: ``min_/max_x y z``, ``min_/max_scale_x y z``, optionally
  ``min_/max_r g b``), ``vertex`` with uint32 ``packed_position`` and ``packed_scale`` (11/10/11
  bits, lerped between the chunk's min and max; scales are log sigma), ``packed_rotation`` (2 bits:
  index of the largest quaternion component in (w, x, y, z), then the other three in order, 10
  bits each, (u / 1023 - 0.5) sqrt(2); the largest is sqrt(1 - the others' squares)),
  ``packed_color`` (8/8/8/8: SH band-0 colour 0.5 + C0 f_dc, lerped by the chunk's colour range
  when present, and sigmoid(opacity)), and optionally an ``sh`` element of uint8 ``f_rest_*``
  (value = u 8 / 255 - 4, the 3DGS order).

Every property (or element) the chosen layout does not use is named once in one warning per file,
so nothing is silently ignored.

:func:`write_ply` writes the GS-IR layout (binary little-endian).

Validation: splats with NaN/Inf values, zero quaternions or huge/infinite scales are dropped; tiny
scales are clamped to :data:`MIN_SIGMA`; material values outside [0, 1] are clamped. Each kind of
fix produces one warning naming the file and the count. Structural problems (not a PLY, truncated,
missing or list-typed properties, an unsupported f_rest count) raise
:class:`~viewer.errors.InputError`. A file with zero splats loads as an empty cloud with a warning.
"""
from __future__ import annotations

import re
import warnings
from pathlib import Path

import numpy as np
from plyfile import PlyData, PlyElement

from ..errors import InputError
from .data import SH_C0, SH_COUNTS, Splats, make_splats, quat_to_matrix

MIN_SIGMA = 1e-7
MAX_SIGMA = 1e4
CORE = ("x", "y", "z", "opacity", "scale_0", "scale_1", "scale_2", "rot_0", "rot_1", "rot_2",
        "rot_3")
DC = ("f_dc_0", "f_dc_1", "f_dc_2")
REQUIRED = CORE[:3] + DC + CORE[3:]
MATERIAL = ("albedo_0", "albedo_1", "albedo_2", "roughness", "metallic")
NORMAL = ("normal_0", "normal_1", "normal_2")
NXYZ = ("nx", "ny", "nz")
R3DG = ("base_color_0", "base_color_1", "base_color_2", "roughness")
GSHADER = ("roughness", "specular0", "specular1", "specular2")
CHUNK = ("min_x", "min_y", "min_z", "max_x", "max_y", "max_z", "min_scale_x", "min_scale_y",
         "min_scale_z", "max_scale_x", "max_scale_y", "max_scale_z")
CHUNK_COLOR = ("min_r", "min_g", "min_b", "max_r", "max_g", "max_b")
PACKED = ("packed_position", "packed_rotation", "packed_scale", "packed_color")
SPLATS_PER_CHUNK = 256


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
            fields["normals"] = _min_axis(fields["rot"], fields["log_scale"]) + cols(NXYZ)
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


def _compressed(elements, path: Path):
    """Decode SuperSplat's compressed PLY (bit layout in the module docstring)."""
    chunk, vertex = elements["chunk"], elements["vertex"]
    cnames = {p.name for p in chunk.properties}
    vnames = {p.name for p in vertex.properties}
    missing = [c for c in CHUNK if c not in cnames] + [p for p in PACKED if p not in vnames]
    if missing:
        raise InputError(f"compressed PLY: missing propert{'ies' if len(missing) > 1 else 'y'} "
                         f"{', '.join(missing)}", where=path)
    n = len(vertex.data)
    n_chunks = len(chunk.data)
    if n_chunks != -(-n // SPLATS_PER_CHUNK):
        raise InputError(f"compressed PLY: {n_chunks} chunks for {n} splats (expected "
                         f"{-(-n // SPLATS_PER_CHUNK)}, one per 256)", where=path)
    for name in PACKED:
        if not np.issubdtype(vertex.data.dtype[name], np.integer):
            raise InputError(f"compressed PLY: {name!r} must be an unsigned integer", where=path)
    has_color = all(c in cnames for c in CHUNK_COLOR)
    cn = CHUNK + (CHUNK_COLOR if has_color else ())
    ch = np.stack([np.asarray(chunk.data[c], np.float64) for c in cn], -1)
    ch = ch[np.arange(n) // SPLATS_PER_CHUNK] if n else np.zeros((0, len(cn)))

    def packed(name):
        return np.asarray(vertex.data[name]).astype(np.uint32)

    def lerp(lo, hi, t):
        return lo * (1.0 - t) + hi * t

    fields = {
        "means": lerp(ch[:, 0:3], ch[:, 3:6], _unpack_111011(packed("packed_position"))),
        "log_scale": lerp(ch[:, 6:9], ch[:, 9:12], _unpack_111011(packed("packed_scale"))),
        "rot": _unpack_rotation(packed("packed_rotation")),
    }
    color = _unpack_8888(packed("packed_color"))
    rgb = lerp(ch[:, 12:15], ch[:, 15:18], color[:, :3]) if has_color else color[:, :3]
    fields["opacity"] = color[:, 3]
    used = {("chunk", c) for c in cn} | {("vertex", p) for p in PACKED}
    k = 1
    sh_rest = None
    if "sh" in elements:
        sh_el = elements["sh"]
        rest = [p.name for p in sh_el.properties if p.name.startswith("f_rest_")]
        k = len(rest) // 3 + 1
        if rest != [f"f_rest_{i}" for i in range(len(rest))] or len(rest) % 3 or k not in SH_COUNTS:
            raise InputError(f"compressed PLY: the 'sh' element needs f_rest_0..f_rest_(m-1), "
                             f"m = 9, 24 or 45; got {len(rest)}", where=path)
        if len(sh_el.data) != n:
            raise InputError(f"compressed PLY: 'sh' has {len(sh_el.data)} rows for {n} splats",
                             where=path)
        sh_rest = np.stack([np.asarray(sh_el.data[r], np.float64) for r in rest], -1)
        sh_rest = sh_rest * (8.0 / 255.0) - 4.0
        used |= {("sh", r) for r in rest}
    sh = np.zeros((n, k, 3))
    sh[:, 0] = (rgb - 0.5) / SH_C0
    if sh_rest is not None:
        sh[:, 1:] = sh_rest.reshape(n, 3, k - 1).transpose(0, 2, 1)
    fields["sh"] = sh
    return fields, used


def _unpack_111011(v: np.ndarray) -> np.ndarray:
    """uint32 -> [N, 3] in [0, 1]: 11 bits x, 10 bits y, 11 bits z (high to low)."""
    return np.stack([(v >> 21) / 2047.0, ((v >> 11) & 0x3FF) / 1023.0, (v & 0x7FF) / 2047.0], -1)


def _unpack_8888(v: np.ndarray) -> np.ndarray:
    return np.stack([((v >> s) & 0xFF) / 255.0 for s in (24, 16, 8, 0)], -1)


def _unpack_rotation(v: np.ndarray) -> np.ndarray:
    """uint32 (2 bits largest index in (w, x, y, z), 3 x 10 bits the others) -> [N, 4]."""
    abc = np.stack([(((v >> s) & 0x3FF) / 1023.0 - 0.5) * np.sqrt(2.0) for s in (20, 10, 0)], -1)
    m = np.sqrt(np.maximum(1.0 - np.sum(abc * abc, axis=1), 0.0))
    largest = (v >> 30).astype(np.int64)
    slot = np.arange(4)[None, :]
    others = slot - (slot > largest[:, None])  # index into abc for the non-largest slots
    return np.where(slot == largest[:, None], m[:, None],
                    np.take_along_axis(abc, np.clip(others, 0, 2), axis=1))


def _min_axis(rot: np.ndarray, log_scale: np.ndarray) -> np.ndarray:
    """[N, 3] the unit shortest axis of each Gaussian (ties: lowest index), as in
    ``splat_min_axis`` (shaders/lib/splat.glsl); zero quaternions give the identity."""
    norm = np.linalg.norm(rot, axis=1, keepdims=True)
    with np.errstate(invalid="ignore", divide="ignore"):
        q = np.where(norm > 0, rot / np.where(norm > 0, norm, 1.0), [[1.0, 0.0, 0.0, 0.0]])
    r = quat_to_matrix(q)
    k = np.argmin(log_scale, axis=1)
    return r[np.arange(len(k)), :, k]


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
