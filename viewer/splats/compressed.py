"""SuperSplat's compressed PLY (PlayCanvas ``gsplat-compressed-data.js``), decoded into the raw
fields of :mod:`.ply` (:func:`_compressed`).

A ``chunk`` element (one per 256 splats: ``min_/max_x y z``, ``min_/max_scale_x y z``, optionally
``min_/max_r g b``), ``vertex`` with uint32 ``packed_position`` and ``packed_scale`` (11/10/11
bits, lerped between the chunk's min and max; scales are log sigma), ``packed_rotation`` (2 bits:
index of the largest quaternion component in (w, x, y, z), then the other three in order, 10 bits
each, (u / 1023 - 0.5) sqrt(2); the largest is sqrt(1 - the others' squares)), ``packed_color``
(8/8/8/8: SH band-0 colour 0.5 + C0 f_dc, lerped by the chunk's colour range when present, and
sigmoid(opacity)), and optionally an ``sh`` element of uint8 ``f_rest_*`` (value = u 8 / 255 - 4,
the 3DGS order).
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from ..errors import InputError
from .data import SH_C0, SH_COUNTS

CHUNK = ("min_x", "min_y", "min_z", "max_x", "max_y", "max_z", "min_scale_x", "min_scale_y",
         "min_scale_z", "max_scale_x", "max_scale_y", "max_scale_z")
CHUNK_COLOR = ("min_r", "min_g", "min_b", "max_r", "max_g", "max_b")
PACKED = ("packed_position", "packed_rotation", "packed_scale", "packed_color")
SPLATS_PER_CHUNK = 256


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
