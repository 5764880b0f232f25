"""Image files through OpenImageIO: reading with validation, writing EXR and PNG.

Every failure is an :class:`~viewer.errors.InputError` naming the file: a missing or corrupt file,
a truncated one, or one with the wrong number of channels. Arrays are ``[H, W, C]`` float32 with
row 0 at the top of the image.
"""
from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import OpenImageIO as oiio

from .errors import InputError


def _oiio():
    return oiio


def read_image(path: str | os.PathLike, channels: int | tuple[int, ...] | None = None
               ) -> tuple[np.ndarray, list[str]]:
    """Read any image OpenImageIO understands as float32 ``[H, W, C]`` plus its channel names.

    ``channels`` is the number (or the allowed numbers) of channels the caller accepts; anything
    else is an :class:`InputError`. 8/16-bit files come back in [0, 1] without colour conversion
    (callers decode sRGB where the data is colour).
    """
    oiio = _oiio()
    path = Path(path)
    if not path.is_file():
        raise InputError("file not found", where=path)
    inp = oiio.ImageInput.open(str(path))
    if inp is None:
        raise InputError(f"cannot read image ({_clean(oiio.geterror())})", where=path)
    try:
        spec = inp.spec()
        pixels = inp.read_image(0, 0, 0, spec.nchannels, "float")
        err = inp.geterror()
    finally:
        inp.close()
    if pixels is None or (err and "truncat" in err.lower()) or getattr(pixels, "size", 0) == 0:
        raise InputError(f"corrupt or truncated image ({_clean(err) or 'no pixel data'})", where=path)
    arr = np.asarray(pixels, dtype=np.float32)
    if arr.ndim == 2:
        arr = arr[:, :, None]
    if arr.shape[:2] != (spec.height, spec.width):
        raise InputError(f"corrupt image: expected {spec.width}x{spec.height} pixels", where=path)
    names = list(spec.channelnames)
    if channels is not None:
        allowed = (channels,) if isinstance(channels, int) else tuple(channels)
        if arr.shape[2] not in allowed:
            want = " or ".join(str(c) for c in allowed)
            raise InputError(f"has {arr.shape[2]} channels ({','.join(names)}), expected {want}",
                             where=path)
    return arr, names


def pixel_type(path: str | os.PathLike) -> str:
    """The stored pixel type of an image file, from its header: ``"uint8"``, ``"uint16"``,
    ``"half"``, ``"float"``... (an 8-bit PNG or JPEG says ``"uint8"``). Errors as
    :func:`read_image`'s."""
    path = Path(path)
    if not path.is_file():
        raise InputError("file not found", where=path)
    inp = _oiio().ImageInput.open(str(path))
    if inp is None:
        raise InputError(f"cannot read image ({_clean(oiio.geterror())})", where=path)
    try:
        return str(inp.spec().format)
    finally:
        inp.close()


def _clean(msg: str | None) -> str:
    return " ".join((msg or "").split())[:300]


def write_exr(path: str | os.PathLike, array: np.ndarray, channel_names: list[str] | None = None,
              half: bool = False, attributes: dict | None = None) -> None:
    """Write ``[H, W, C]`` linear data to an OpenEXR file (float32 unless ``half``), with optional
    header ``attributes`` (e.g. ``{"fov_y": 30.0}``)."""
    oiio = _oiio()
    path = Path(path)
    arr = np.ascontiguousarray(array, dtype=np.float32)
    if arr.ndim == 2:
        arr = arr[:, :, None]
    h, w, c = arr.shape
    spec = oiio.ImageSpec(w, h, c, "half" if half else "float")
    if channel_names is not None:
        if len(channel_names) != c:
            raise ValueError(f"{len(channel_names)} channel names for {c} channels")
        spec.channelnames = tuple(channel_names)
    spec.attribute("compression", "zip")
    for key, value in (attributes or {}).items():
        spec.attribute(key, value)
    _write(path, spec, arr)


def write_png(path: str | os.PathLike, array_u8: np.ndarray) -> None:
    """Write ``[H, W, C]`` uint8 (already display-encoded) to PNG."""
    oiio = _oiio()
    path = Path(path)
    arr = np.ascontiguousarray(array_u8, dtype=np.uint8)
    if arr.ndim == 2:
        arr = arr[:, :, None]
    h, w, c = arr.shape
    _write(path, oiio.ImageSpec(w, h, c, "uint8"), arr)


def _write(path: Path, spec, arr: np.ndarray) -> None:
    oiio = _oiio()
    if path.parent and not path.parent.exists():
        raise InputError("output folder does not exist", where=path.parent)
    # Write to a temporary name and rename: a failed write never leaves a partial file behind.
    tmp = path.with_name(f".{path.stem}.partial{path.suffix}")
    out = oiio.ImageOutput.create(str(tmp))
    if out is None:
        raise InputError(f"cannot write this image format ({_clean(oiio.geterror())})", where=path)
    try:
        if not out.open(str(tmp), spec):
            raise InputError(f"cannot open for writing ({_clean(out.geterror())})", where=path)
        ok = out.write_image(arr)
        out.close()
        if not ok:
            raise InputError(f"write failed ({_clean(out.geterror())})", where=path)
        os.replace(tmp, path)
    finally:
        if tmp.exists():
            tmp.unlink()
