"""Texture images of mesh files as float32 arrays: PIL decoding (no colour decoding) and the
sRGB-to-linear conversion of colour textures."""
from __future__ import annotations

import io

import numpy as np
from PIL import Image

from ...errors import InputError
from ..mesh import srgb_to_linear


def _pil_to_float(img) -> np.ndarray:
    """A PIL image as float32 ``[H, W, C]`` in [0, 1] (no colour decoding)."""
    mode = img.mode
    if mode in ("P", "PA", "1", "CMYK", "YCbCr", "LAB", "HSV"):
        img = img.convert("RGBA" if ("transparency" in img.info or mode == "PA") else "RGB")
        mode = img.mode
    arr = np.asarray(img)
    if mode.startswith("I;16") or mode == "I":
        arr = arr.astype(np.float32) / 65535.0
    elif mode == "F":
        arr = arr.astype(np.float32)
    else:
        arr = arr.astype(np.float32) / 255.0
    if arr.ndim == 2:
        arr = arr[:, :, None]
    return np.ascontiguousarray(arr, np.float32)


def _decode_image(data: bytes, what: str) -> np.ndarray:
    try:
        img = Image.open(io.BytesIO(data))
        img.load()
    except Exception as exc:
        raise InputError(f"cannot decode {what} ({type(exc).__name__}: "
                         f"{' '.join(str(exc).split())[:150]})") from None
    return _pil_to_float(img)


def _color_texture(rgba: np.ndarray) -> np.ndarray:
    """sRGB-encoded colour in [0, 1] -> linear, alpha (if any) kept linear."""
    out = rgba.copy()
    if out.shape[2] <= 2:  # grey (+ alpha): make it RGB(A)
        grey = out[:, :, :1]
        out = np.concatenate([grey, grey, grey] + ([out[:, :, 1:2]] if out.shape[2] == 2 else []),
                             axis=2)
    out[:, :, :3] = srgb_to_linear(out[:, :, :3])
    return out
