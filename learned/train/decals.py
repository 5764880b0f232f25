"""Painted-on detail for the shadow estimator's training images (``relight train --stage
shadow_net --shadow-decals P``): a random pattern multiplied into the frame, its target and its
base colour alike, so that the best visibility target / frame is unchanged where the light is
diffuse - what the estimator should do with a texture is nothing.

The real assets' textures (the panels' check marks and letters, the gun's panel lines) read to
an estimator trained on plain materials as geometry: it darkened them where the path tracer does
not (docs/measurements/real-assets.md). The patterns are what textures draw: stripes at any
angle, checkers, blocks of random grey, and short strokes (letters, panel lines), each at a
random scale and contrast, grey or tinted."""
from __future__ import annotations

import numpy as np
import torch

KINDS = ("stripes", "checker", "blocks", "strokes")


def decal(rng: np.random.Generator, height: int, width: int) -> torch.Tensor:
    """A ``[1, 3, H, W]`` factor in (0, 1]: one pattern of :data:`KINDS` at contrast
    c ~ U(0.2, 0.9) (its dark parts are 1 - c), grey or, half the time, tinted per colour."""
    y, x = np.mgrid[:height, :width].astype(np.float64)
    kind = KINDS[int(rng.integers(len(KINDS)))]
    if kind == "stripes":
        a, period = rng.uniform(0.0, np.pi), rng.uniform(3.0, 16.0)
        dark = np.mod((x * np.cos(a) + y * np.sin(a)) / period, 1.0) < rng.uniform(0.2, 0.6)
        mask = dark.astype(np.float64)
    elif kind == "checker":
        cell = rng.uniform(3.0, 16.0)
        mask = np.mod(np.floor(x / cell) + np.floor(y / cell), 2.0)
    elif kind == "blocks":
        cell = int(rng.integers(2, 13))
        cells = rng.random((height // cell + 1, width // cell + 1))
        mask = cells[(y // cell).astype(int), (x // cell).astype(int)]
    else:  # strokes: short bars across the image, like letters and panel lines
        mask = np.zeros((height, width))
        for _ in range(int(rng.integers(10, 40))):
            h, w = (int(rng.integers(1, 4)), int(rng.integers(3, 12)))
            if rng.random() < 0.5:
                h, w = w, h
            r0, c0 = int(rng.integers(0, height)), int(rng.integers(0, width))
            mask[r0:r0 + h, c0:c0 + w] = 1.0
    c = rng.uniform(0.2, 0.9)
    tint = rng.uniform(0.5, 1.0, 3) if rng.random() < 0.5 else np.ones(3)
    factor = 1.0 - c * tint[:, None, None] * mask[None]
    return torch.from_numpy(factor[None].astype(np.float32))
