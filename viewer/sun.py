"""Extract a compact, very bright sun from an equirect environment, as an analytic disc light.

The split-sum model looks the environment up through a round, pre-blurred lobe, which cannot follow
the true GGX lobe where it is stretched and cut by the horizon (grazing angles): a small sun
reflected there is where split-sum loses or gains the most light (README "Split-sum accuracy").
Production renderers treat the sun as an analytic light instead (Lagarde & de Rousiers 2014,
"Moving Frostbite to PBR", sec. 4.7 and 4.9: the sun as a disc light beside the distant light
probe; Filament's sun: a directional light with an angular radius). We do the same, from the image
itself: the texels of the compact region around the brightest texel that stand far above the sky
are replaced by the sky around them, and the light they carried above it becomes one disc light
(direction, irradiance, angular radius) that the shading passes evaluate with the full BRDF
(``ggx_sun_light`` in ``lib/shading.glsl``). Energy is kept exactly: the residual environment plus
the disc's irradiance sum to the original.

No torch: the runtime (``viewer``) calls this when it builds the environment's IBL.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np


# A sun is a region whose every texel is at least SUN_THRESHOLD times the environment's median
# luminance, around a peak at least SUN_MIN_PEAK times that median, covering at most
# SUN_MAX_SOLID_ANGLE sr (the real sun is 6.8e-5 sr; 0.02 sr is a disc of 4.6 degrees radius) and
# carrying at least SUN_MIN_SHARE of the environment's total radiant energy: a bright window or a
# studio softbox is larger and stays in the image, where the split-sum blurs it correctly.
SUN_THRESHOLD = 100.0
SUN_MIN_PEAK = 1000.0
SUN_MAX_SOLID_ANGLE = 0.02
SUN_MIN_SHARE = 0.05
_LUMA = np.array([0.2126, 0.7152, 0.0722], np.float64)


@dataclass(frozen=True)
class Sun:
    """A disc light at infinity, in the environment's own frame (before its rotation)."""
    direction: tuple[float, float, float]   # unit vector towards the sun's centre
    irradiance: tuple[float, float, float]  # RGB irradiance on a surface facing it
    angular_radius: float                   # radians: the disc with the region's 2nd angular moment
    texels: int                             # how many texels were taken out
    share: float                            # its share of the environment's radiant energy


def texel_solid_angles(height: int, width: int) -> np.ndarray:
    """``[H]`` solid angle of one texel per row (exact for equirect rows)."""
    v0 = np.arange(height) / height
    v1 = (np.arange(height) + 1) / height
    return (2.0 * math.pi / width) * (np.cos(math.pi * v0) - np.cos(math.pi * v1))


def _region(mask: np.ndarray, seed: tuple[int, int], row_solid_angle: np.ndarray,
            limit: float) -> tuple[np.ndarray, np.ndarray] | None:
    """``(rows, columns)`` of the 8-connected flood fill of ``mask`` from ``seed`` (u wraps
    around); None as soon as its solid angle exceeds ``limit`` (a large bright area is rejected
    after visiting about ``limit`` of it, whatever the image's size)."""
    h, w = mask.shape
    seen = {seed}
    stack = [seed]
    out = []
    area = 0.0
    while stack:
        y, x = stack.pop()
        out.append((y, x))
        area += float(row_solid_angle[y])
        if area > limit:
            return None
        for dy in (-1, 0, 1):
            for dx in (-1, 0, 1):
                yy, xx = y + dy, (x + dx) % w
                if 0 <= yy < h and (yy, xx) not in seen and mask[yy, xx]:
                    seen.add((yy, xx))
                    stack.append((yy, xx))
    ys, xs = (np.array(c, np.int64) for c in zip(*out))
    return ys, xs


def _ring(ys: np.ndarray, xs: np.ndarray, h: int, w: int, width: int = 2
          ) -> tuple[np.ndarray, np.ndarray]:
    """The texels within ``width`` steps (8-connected, u wraps) of the region, outside it."""
    d = np.arange(-width, width + 1)
    yy = (ys[:, None, None] + d[None, :, None]).repeat(len(d), 2).ravel()
    xx = ((xs[:, None, None] + d[None, None, :]) % w).repeat(len(d), 1).ravel()
    keep = (yy >= 0) & (yy < h)
    idx = np.unique(yy[keep] * w + xx[keep])
    idx = idx[~np.isin(idx, ys * w + xs)]
    return idx // w, idx % w


def _directions(ys: np.ndarray, xs: np.ndarray, h: int, w: int) -> np.ndarray:
    """Directions of texel centres, as :func:`viewer.environment.texel_directions`."""
    phi = 2.0 * math.pi * ((xs + 0.5) / w - 0.5)
    theta = math.pi * (ys + 0.5) / h
    st = np.sin(theta)
    return np.stack([st * np.sin(phi), np.cos(theta), -st * np.cos(phi)], axis=-1)


def extract_sun(env: np.ndarray) -> tuple[np.ndarray, Sun | None]:
    """``(residual, sun)``: the environment with its sun replaced by the sky around it, and the
    sun as a disc light; ``(env, None)`` when it has no compact sun (see the constants)."""
    h, w = env.shape[:2]
    luma = env[..., :3].astype(np.float64) @ _LUMA
    dw = texel_solid_angles(h, w)
    median = float(np.median(luma))
    peak_at = np.unravel_index(int(np.argmax(luma)), luma.shape)
    floor = max(median, 1e-12)
    if not (luma[peak_at] >= SUN_MIN_PEAK * floor):
        return env, None
    found = _region(luma >= SUN_THRESHOLD * floor, peak_at, dw, SUN_MAX_SOLID_ANGLE)
    if found is None:
        return env, None
    ys, xs = found
    ry, rx = _ring(ys, xs, h, w)
    fill = (env[ry, rx, :3].astype(np.float64) * dw[ry, None]).sum(0) / float(dw[ry].sum())
    rgb = env[ys, xs, :3].astype(np.float64)
    excess = np.maximum(rgb - fill, 0.0)
    irradiance = (excess * dw[ys, None]).sum(0)
    total = float((luma * dw[:, None]).sum())
    share = float(irradiance @ _LUMA) / max(total, 1e-30)
    if share < SUN_MIN_SHARE:
        return env, None
    dirs = _directions(ys, xs, h, w)  # the environment's frame
    weight = (excess @ _LUMA) * dw[ys]
    centre = (dirs * weight[:, None]).sum(0)
    centre /= np.linalg.norm(centre)
    cos = np.clip(dirs @ centre, -1.0, 1.0)
    # a uniform disc of radius t has <theta^2> = t^2 / 2; each texel adds its own extent (a square
    # of side pi / H: <theta^2> = (pi / H)^2 / 6), so a one-texel sun is not a point
    spread = float((np.arccos(cos) ** 2 * weight).sum() / weight.sum()) + (math.pi / h) ** 2 / 6.0
    radius = math.sqrt(2.0 * spread)
    residual = env.copy()
    residual[ys, xs, :3] = (rgb - excess).astype(env.dtype)
    sun = Sun(direction=tuple(float(c) for c in centre),
              irradiance=tuple(float(c) for c in irradiance),
              angular_radius=radius, texels=int(len(ys)), share=share)
    return residual, sun
