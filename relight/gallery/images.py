"""The gallery's pictures: the renderer's display transform in numpy (:func:`display`), the error
colour map (:func:`colormap`, :func:`error_image`) and the labelled grids of tiles
(:func:`compose`) saved as palette PNGs."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from .cases import ERROR_MAX

# ---- display and error images -------------------------------------------------------------------

_ACES_IN = np.array([[0.59719, 0.35458, 0.04823],
                     [0.07600, 0.90834, 0.01566],
                     [0.02840, 0.13383, 0.83777]])
_ACES_OUT = np.array([[1.60475, -0.53108, -0.07367],
                      [-0.10208, 1.10813, -0.00605],
                      [-0.00327, -0.07276, 1.07602]])


def display(radiance: np.ndarray, exposure: float = 0.0) -> np.ndarray:
    """``[H, W, 3]`` uint8 sRGB of linear ``radiance``: the renderer's ``aces`` display transform
    (exposure, Hill's ACES fit, sRGB encoding; ``shaders/lib/tonemap.glsl``) in numpy, the one
    every gallery tile is shown with (the renderer's default is ``pbr_neutral``)."""
    v = np.clip(np.asarray(radiance[..., :3], np.float64) * 2.0 ** exposure, 0.0, 1e4) @ _ACES_IN.T
    a = v * (v + 0.0245786) - 0.000090537
    b = v * (0.983729 * v + 0.4329510) + 0.238081
    x = np.clip((a / b) @ _ACES_OUT.T, 0.0, 1.0)
    s = np.where(x <= 0.0031308, 12.92 * x, 1.055 * np.power(x, 1.0 / 2.4) - 0.055)
    return (s * 255.0 + 0.5).astype(np.uint8)


# a perceptually ordered ramp (black -> purple -> orange -> yellow), close to matplotlib's inferno
_RAMP = np.array([[0, 0, 4], [40, 11, 84], [101, 21, 110], [159, 42, 99], [212, 72, 66],
                  [245, 125, 21], [250, 193, 39], [252, 255, 164]], np.float64)


def colormap(t: np.ndarray) -> np.ndarray:
    """``[..., 3]`` uint8 colours of ``t`` in [0, 1] (clipped) along :data:`_RAMP`."""
    x = np.clip(np.nan_to_num(t), 0.0, 1.0) * (len(_RAMP) - 1)
    i = np.minimum(np.floor(x).astype(np.int64), len(_RAMP) - 2)
    f = (x - i)[..., None]
    return (_RAMP[i] * (1.0 - f) + _RAMP[i + 1] * f + 0.5).astype(np.uint8)


def error_image(image: np.ndarray, truth, mask: np.ndarray) -> np.ndarray:
    """``[H, W, 3]`` uint8: the per-pixel relative error beyond the truth's own noise,
    ``max(|image - truth|_1 - 2 |stderr|_1, 0) / |truth|_1`` (``truth`` a
    :class:`~relight.reference.Reference`), through :func:`colormap` from 0 to
    :data:`ERROR_MAX`; grey where ``mask`` is false."""
    a = np.asarray(image[..., :3], np.float64)
    b = np.asarray(truth.radiance[..., :3], np.float64)
    noise = 2.0 * np.asarray(truth.stderr[..., :3], np.float64).sum(-1)
    rel = np.maximum(np.abs(a - b).sum(-1) - noise, 0.0) / np.maximum(b.sum(-1), 1e-6)
    out = colormap(rel / ERROR_MAX)
    out[~mask] = 64
    return out


# ---- composing ----------------------------------------------------------------------------------

def _font(size: int):
    from PIL import ImageFont

    try:
        return ImageFont.load_default(size=size)  # Pillow >= 10.1: a scalable font
    except TypeError:  # pragma: no cover - older Pillow: the fixed bitmap font
        return ImageFont.load_default()


def wrap_label(label: str, width: float, measure) -> str:
    """``label`` with its spaces turned into line breaks wherever a line would be wider than
    ``width`` (``measure(text)``: its drawn width); a word wider than that keeps its own line."""
    lines = []
    for para in label.split("\n"):
        words = para.split(" ")
        line = words[0]
        for word in words[1:]:
            if measure(f"{line} {word}") <= width:
                line = f"{line} {word}"
            else:
                lines.append(line)
                line = word
        lines.append(line)
    return "\n".join(lines)


def compose(grid: list[list[np.ndarray | None]], col_labels: list[str], row_labels: list[str],
            scale: int = 1, note: str | None = None, font_size: int = 13):
    """A PIL image of ``grid`` (rows of equally sized uint8 tiles, ``None`` left blank) with a
    label above each column (wrapped to the tile's width) and left of each row (rows with an
    empty label get none)."""
    from PIL import Image, ImageDraw

    tiles = [t for row in grid for t in row if t is not None]
    th, tw = tiles[0].shape[0] * scale, tiles[0].shape[1] * scale
    font = _font(font_size)
    measure = ImageDraw.Draw(Image.new("RGB", (1, 1))).textlength
    col_labels = [wrap_label(label, tw - 4, lambda t: measure(t, font=font))
                  for label in col_labels]
    left = 8 + max((int(measure(s, font=font)) for s in row_labels), default=0)
    lines = max((label.count("\n") + 1 for label in col_labels), default=1)
    top, gap = lines * (font_size + 2) + 8, 2
    bottom = font_size + 10 if note else 0
    ncols = max(len(r) for r in grid)
    width = left + ncols * (tw + gap)
    height = top + len(grid) * (th + gap) + bottom
    img = Image.new("RGB", (width, height), (255, 255, 255))
    draw = ImageDraw.Draw(img)
    for j, label in enumerate(col_labels):
        x = left + j * (tw + gap) + tw / 2
        draw.multiline_text((x, top / 2), label, fill=(0, 0, 0), font=font, anchor="mm",
                            align="center")
    for i, row in enumerate(grid):
        y = top + i * (th + gap)
        if row_labels[i]:
            draw.text((4, y + th / 2), row_labels[i], fill=(0, 0, 0), font=font, anchor="lm")
        for j, tile in enumerate(row):
            if tile is None:
                continue
            t = Image.fromarray(tile)
            if scale != 1:
                t = t.resize((tw, th), Image.NEAREST)
            img.paste(t, (left + j * (tw + gap), y))
    if note:
        draw.text((4, height - bottom / 2), note, fill=(60, 60, 60), font=font, anchor="lm")
    return img


def _save_png(img, path: Path) -> Path:
    """Saved as an adaptive 256-colour palette PNG: a fraction of the bytes of RGB, and the
    pictures are for looking at (the numbers are in gallery.json)."""
    from PIL import Image

    quantize, dither = getattr(Image, "Quantize", Image), getattr(Image, "Dither", Image)
    img.quantize(colors=256, method=quantize.MEDIANCUT,
                 dither=dither.FLOYDSTEINBERG).save(path, optimize=True)
    return path
