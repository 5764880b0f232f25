"""Edits of G-buffer channels: spatially varying materials on an image G-buffer
(:func:`perturb_materials`) and inputs degraded the way inverse rendering's estimates are
(:func:`degrade_inputs`)."""
from __future__ import annotations

import numpy as np


def _smooth_field(rng, size: int, cells: int) -> np.ndarray:
    """``[size, size, 1]`` in [0, 1]: bilinear upsampling of a random ``cells`` x ``cells`` grid."""
    grid = rng.random((cells, cells)).astype(np.float32)
    t = (np.arange(size, dtype=np.float32) + 0.5) / size * (cells - 1)
    i0 = np.clip(np.floor(t).astype(int), 0, cells - 2)
    f = t - i0
    rows = grid[i0] * (1 - f)[:, None] + grid[i0 + 1] * f[:, None]  # [size, cells]
    out = rows[:, i0] * (1 - f)[None, :] + rows[:, i0 + 1] * f[None, :]
    return out[..., None]


def perturb_materials(channels: dict, rng) -> tuple[dict, dict]:
    """Spatially varying materials on an image G-buffer (channel -> ``[H, W, C]``, square):
    albedo times a random tint and a smooth field, roughness / specular blended towards random
    smooth fields, metallic set where a smooth field exceeds a random threshold, AO darkened by a
    smooth field. Returns the new channels and the recipe (for ``meta.json``)."""
    size = channels["albedo"].shape[0]
    cells = int(rng.integers(2, 7))
    tint = rng.uniform(0.4, 1.2, 3).astype(np.float32)
    mix = float(rng.uniform(0.3, 1.0))
    metal_threshold = float(rng.uniform(0.6, 1.0))
    fields = [_smooth_field(rng, size, cells) for _ in range(5)]
    out = dict(channels)
    out["albedo"] = np.clip(channels["albedo"] * tint * (0.5 + fields[0]), 0.02, 0.95)
    out["roughness"] = np.clip((1 - mix) * channels["roughness"] + mix * (0.05 + 0.95 * fields[1]),
                               0.0, 1.0)
    out["specular"] = np.clip((1 - mix) * channels["specular"] + mix * (0.2 + 0.8 * fields[2]),
                              0.0, 1.0)
    out["metallic"] = np.where(fields[3] > metal_threshold, 1.0,
                               channels["metallic"]).astype(np.float32)
    out["ao"] = np.clip(channels["ao"] * (0.6 + 0.4 * fields[4]), 0.0, 1.0)
    fg = channels["alpha"] > 0.0
    for k in ("albedo", "roughness", "specular", "metallic", "ao"):
        out[k] = np.where(fg, out[k], channels[k]).astype(np.float32)
    recipe = {"cells": cells, "tint": [float(x) for x in tint], "mix": mix,
              "metal_threshold": metal_threshold}
    return out, recipe


def _masked_blur(img: np.ndarray, mask: np.ndarray, sigma: float) -> np.ndarray:
    """Gaussian blur (``sigma`` pixels) of ``img`` ``[H, W, C]`` over the pixels of ``mask``
    ``[H, W]`` alone (normalised by the blurred mask: the background does not bleed in)."""
    def kernel(n):
        x = np.arange(n, dtype=np.float64)
        k = np.exp(-0.5 * ((x[:, None] - x[None, :]) / max(sigma, 1e-3)) ** 2)
        return k / k.sum(1, keepdims=True)

    gy, gx = kernel(img.shape[0]), kernel(img.shape[1])
    m = mask.astype(np.float64)[..., None]
    num = np.einsum("ij,jkc,lk->ilc", gy, img.astype(np.float64) * m, gx)
    den = np.einsum("ij,jkc,lk->ilc", gy, m, gx)
    return num / np.maximum(den, 1e-12)


def degrade_inputs(channels: dict, radiance: np.ndarray, rng,
                   strength: float = 1.0) -> tuple[dict, dict]:
    """G-buffer inputs wrong the way inverse rendering's estimates are (thesis ch. 4's setting),
    on the foreground pixels; ``strength`` in [0, 1] scales every error:

    - normals: plus a smooth random field (amplitude ~0.15-0.35) and per-pixel Gaussian noise
      (~0.03-0.12), renormalised;
    - albedo: shading baked in: times ``S ** bake`` (bake ~0.3-0.8), S the luminance of
      ``radiance`` (the unoccluded render) blurred over the foreground (sigma 2-6 % of the
      width), relative to its foreground median (clipped to [0.1, 10]), albedo clipped to [0, 1];
    - roughness: biased, ``r * scale + offset`` (scale 1 +- 0.4, offset -0.1..0.15), clipped to
      [0.02, 1].

    Returns the new channels (the others shared) and the recipe (for ``meta.json``)."""
    s = float(strength)
    fg2 = channels["alpha"][..., 0] > 0.0
    fg = fg2[..., None]
    size = channels["normal"].shape[0]
    cells = int(rng.integers(3, 9))
    smooth_amp = s * float(rng.uniform(0.15, 0.35))
    pixel_amp = s * float(rng.uniform(0.03, 0.12))
    field = np.concatenate([_smooth_field(rng, size, cells) for _ in range(3)], -1) * 2 - 1
    noise = rng.standard_normal(channels["normal"].shape).astype(np.float32)
    n = channels["normal"] + smooth_amp * field + pixel_amp * noise
    n = n / np.maximum(np.linalg.norm(n, axis=-1, keepdims=True), 1e-8)
    bake = s * float(rng.uniform(0.3, 0.8))
    sigma = size * float(rng.uniform(0.02, 0.06))
    lum = (radiance[..., :3].astype(np.float64) @ np.array([0.2126, 0.7152, 0.0722]))[..., None]
    shade = _masked_blur(lum, fg2, sigma)
    med = float(np.median(shade[fg2])) if fg2.any() else 1.0
    shade = np.clip(shade / max(med, 1e-8), 0.1, 10.0)
    albedo = np.clip(channels["albedo"] * shade ** bake, 0.0, 1.0)
    scale = 1.0 + s * float(rng.uniform(-0.4, 0.4))
    offset = s * float(rng.uniform(-0.1, 0.15))
    rough = np.clip(channels["roughness"] * scale + offset, 0.02, 1.0)
    out = dict(channels)
    out["normal"] = np.where(fg, n, channels["normal"]).astype(np.float32)
    out["albedo"] = np.where(fg, albedo, channels["albedo"]).astype(np.float32)
    out["roughness"] = np.where(fg, rough, channels["roughness"]).astype(np.float32)
    recipe = {"strength": s,
              "normal": {"cells": cells, "smooth": smooth_amp, "pixel": pixel_amp},
              "albedo": {"bake": bake, "sigma_px": sigma, "shading": "unoccluded render"},
              "roughness": {"scale": scale, "offset": offset}}
    return out, recipe
