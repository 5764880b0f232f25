"""Splat file formats, told apart by their content (magic bytes and header), not by the extension.

=========================  ==========================================================  ===========
format                     how it is recognised                                        reader
=========================  ==========================================================  ===========
PLY (every layout of       starts with ``ply`` + newline                               :func:`.ply.read_ply`
:mod:`.ply`, SuperSplat's
compressed PLY included)
antimatter15 ``.splat``    no header: a whole number of 32-byte records (under another  :func:`read_splat`
                           extension: whose positions and scales are also plausible)
``.spz`` (Niantic)         gzip stream whose first bytes are ``NGSP`` (or raw          unsupported
                           ``NGSP``)
``.ksplat`` (mkkellogg     4096-byte header: version 0.1, section and splat counts     unsupported
GaussianSplats3D)          consistent with the file size
=========================  ==========================================================  ===========

``.spz`` and ``.ksplat`` raise a one-line :class:`~viewer.errors.InputError` naming the format:
PyPI has no usable reader for either (``spz`` 0.0.1 is an unbuilt Rust sdist, ``alspz`` a Cython
sdist binding one C++ tiler; nothing reads ``.ksplat``), and both are lossy web-delivery encodings
of the same 3DGS data that the PLY and ``.splat`` paths read. Convert them with their own tools
(SuperSplat / splat-transform) to PLY.

``.splat`` records (little-endian, 32 bytes, as antimatter15/splat's ``convert.py`` writes them):
``x y z`` float32; ``sx sy sz`` float32 sigma (linear, not log); ``r g b a`` uint8 where rgb =
255 (0.5 + C0 f_dc) (the SH band-0 colour, clamped) and a = 255 sigmoid(opacity); ``qw qx qy qz``
uint8 = q 128 + 128 of the normalised quaternion. Decoded: f_dc = (rgb / 255 - 0.5) / C0 (SH
degree 0, no materials), opacity = a / 255, q = (byte - 128) / 128 (normalised later).
"""
from __future__ import annotations

import gzip
import struct
import zlib
from pathlib import Path

import numpy as np

from ..errors import InputError
from .data import SH_C0

SPLAT_RECORD = np.dtype([("position", "<f4", 3), ("scale", "<f4", 3), ("rgba", "u1", 4),
                         ("rot", "u1", 4)])
FORMATS = ("ply", "splat", "spz", "ksplat")
KSPLAT_HEADER = 4096
_PLAUSIBLE_POSITION = 1e7  # |x| above this in a headerless file: not .splat records
_PLAUSIBLE_SIGMA = 1e6


def detect_format(path) -> str:
    """One of :data:`FORMATS`, from the first bytes and the size of ``path``. Raises
    :class:`~viewer.errors.InputError` for a missing file or content no reader recognises."""
    path = Path(path)
    if not path.is_file():
        raise InputError("no such splat file", where=path)
    size = path.stat().st_size
    with path.open("rb") as f:
        head = f.read(KSPLAT_HEADER)
    if head.startswith((b"ply\n", b"ply\r\n", b"ply\r")):
        return "ply"
    if head.startswith(b"NGSP") or (head.startswith(b"\x1f\x8b") and _gunzip_head(path)
                                    .startswith(b"NGSP")):
        return "spz"
    if _looks_like_ksplat(head, size):
        return "ksplat"
    ext = path.suffix.lower()
    if size and size % SPLAT_RECORD.itemsize == 0 and (ext == ".splat"
                                                       or _plausible_splat_records(path)):
        return "splat"  # (NaN records of a .splat are dropped with a warning by the loader)
    if ext == ".ply":
        raise InputError("not a readable PLY file (truncated or corrupt?): it does not start "
                         "with the 'ply' magic line, and it is not a .splat, .spz or .ksplat "
                         "file either", where=path)
    if ext == ".splat":
        raise InputError(f"not a valid .splat file: {size} bytes is not a whole number of "
                         f"32-byte records (truncated?)", where=path)
    if head.startswith(b"\x1f\x8b"):
        raise InputError("a gzip stream that is not a .spz splat file: unrecognised splat "
                         "format", where=path)
    raise InputError("unrecognised splat file format (readable: PLY - INRIA 3DGS, GS-IR, R3DG, "
                     "GaussianShader, SuperSplat compressed - and antimatter15 .splat)",
                     where=path)


def unsupported(fmt: str, path) -> InputError:
    """The one-line error for a recognised format without a reader."""
    why = {
        "spz": "Niantic .spz splat files are not supported: no maintained reader is available "
               "on PyPI (spz 0.0.1 is an unbuilt Rust sdist); convert to PLY (e.g. with "
               "splat-transform)",
        "ksplat": ".ksplat (GaussianSplats3D) splat files are not supported: no reader is "
                  "available on PyPI; convert to PLY (e.g. with splat-transform)",
    }[fmt]
    return InputError(why, where=path)


def read_splat(path) -> dict:
    """Decode an antimatter15 ``.splat`` file into the loader's raw fields (see
    :func:`viewer.splats.validate.fields_to_splats`): means, sh [N, 1, 3], opacity (activated),
    log_scale, rot (w, x, y, z, not normalised)."""
    path = Path(path)
    data = path.read_bytes()
    if len(data) % SPLAT_RECORD.itemsize:
        raise InputError(f"not a valid .splat file: {len(data)} bytes is not a whole number of "
                         f"32-byte records (truncated?)", where=path)
    rec = np.frombuffer(data, SPLAT_RECORD)
    n = len(rec)
    scale = rec["scale"].astype(np.float64)
    with np.errstate(divide="ignore", invalid="ignore"):
        # sigma 0 (an underflowed exp on export) becomes tiny and is clamped with a warning
        log_scale = np.log(np.where(scale == 0.0, 1e-30, scale))
    rgba = rec["rgba"].astype(np.float64) / 255.0
    return {
        "means": rec["position"].astype(np.float64),
        "sh": ((rgba[:, :3] - 0.5) / SH_C0).reshape(n, 1, 3),
        "opacity": rgba[:, 3],
        "log_scale": log_scale,
        "rot": (rec["rot"].astype(np.float64) - 128.0) / 128.0,
    }


def write_splat(path, means, scales, rgba, rotations) -> None:
    """Write antimatter15 ``.splat`` records (tests and conversions): ``means``/``scales`` [N, 3]
    (sigma, linear), ``rgba`` [N, 4] uint8, ``rotations`` [N, 4] (w, x, y, z), normalised and
    encoded q 128 + 128 (clamped to 0..255)."""
    n = len(means)
    rec = np.zeros(n, SPLAT_RECORD)
    rec["position"] = means
    rec["scale"] = scales
    rec["rgba"] = rgba
    q = np.asarray(rotations, np.float64)
    q = q / np.linalg.norm(q, axis=1, keepdims=True)
    rec["rot"] = np.clip(np.round(q * 128.0 + 128.0), 0, 255)
    Path(path).write_bytes(rec.tobytes())


def _gunzip_head(path: Path, n: int = 16) -> bytes:
    try:
        with gzip.open(path, "rb") as f:
            return f.read(n)
    except (OSError, EOFError, zlib.error):
        return b""


def _looks_like_ksplat(head: bytes, size: int) -> bool:
    """The GaussianSplats3D header: u8 version major 0, minor >= 1; u32 max section count,
    section count, max splat count, splat count; u16 compression level (0-2)."""
    if size < KSPLAT_HEADER or len(head) < 24 or head[0] != 0 or head[1] < 1:
        return False
    max_sections, sections, max_splats, splats = struct.unpack_from("<4I", head, 4)
    level = struct.unpack_from("<H", head, 20)[0]
    return (0 < sections <= max_sections < 1 << 20 and splats <= max_splats
            and level <= 2 and size >= KSPLAT_HEADER + 1024 * sections)


def _plausible_splat_records(path: Path) -> bool:
    """Headerless bytes read as .splat records: every position finite and below 1e7, every
    scale finite, >= 0 and below 1e6 (text or other binary data fails this at once)."""
    rec = np.fromfile(path, SPLAT_RECORD)
    pos, scale = rec["position"], rec["scale"]
    with np.errstate(invalid="ignore"):
        return bool(np.all(np.abs(pos) < _PLAUSIBLE_POSITION)
                    and np.all((scale >= 0) & (scale < _PLAUSIBLE_SIGMA)))
