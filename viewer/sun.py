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

from .environment import texel_directions

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


def _region(mask: np.ndarray, seed: tuple[int, int], limit: int) -> np.ndarray | None:
    """8-connected flood fill of ``mask`` from ``seed`` (u wraps around); None above ``limit``."""
    h, w = mask.shape
    seen = np.zeros_like(mask)
    stack = [seed]
    seen[seed] = True
    out = []
    while stack:
        y, x = stack.pop()
        out.append((y, x))
        if len(out) > limit:
            return None
        for dy in (-1, 0, 1):
            for dx in (-1, 0, 1):
                yy, xx = y + dy, (x + dx) % w
                if 0 <= yy < h and mask[yy, xx] and not seen[yy, xx]:
                    seen[yy, xx] = True
                    stack.append((yy, xx))
    region = np.zeros_like(mask)
    ys, xs = zip(*out)
    region[list(ys), list(xs)] = True
    return region


def _dilate(region: np.ndarray) -> np.ndarray:
    out = region.copy()
    for dy in (-1, 0, 1):
        for dx in (-1, 0, 1):
            shifted = np.roll(region, dx, axis=1)
            if dy:
                shifted = np.roll(shifted, dy, axis=0)
                if dy > 0:
                    shifted[:dy] = False
                else:
                    shifted[dy:] = False
            out |= shifted
    return out


def extract_sun(env: np.ndarray) -> tuple[np.ndarray, Sun | None]:
    """``(residual, sun)``: the environment with its sun replaced by the sky around it, and the
    sun as a disc light; ``(env, None)`` when it has no compact sun (see the constants)."""
    h, w = env.shape[:2]
    rgb = env[..., :3].astype(np.float64)
    luma = rgb @ _LUMA
    dw = texel_solid_angles(h, w)[:, None]
    median = float(np.median(luma))
    peak_at = np.unravel_index(int(np.argmax(luma)), luma.shape)
    floor = max(median, 1e-12)
    if not (luma[peak_at] >= SUN_MIN_PEAK * floor):
        return env, None
    limit = int(SUN_MAX_SOLID_ANGLE / float(dw.min())) + 1
    region = _region(luma >= SUN_THRESHOLD * floor, peak_at, limit)
    if region is None or float((dw * region).sum()) > SUN_MAX_SOLID_ANGLE:
        return env, None
    ring = _dilate(_dilate(region)) & ~region
    fill = (rgb[ring] * dw.repeat(w, 1)[ring][:, None]).sum(0) / float(
        dw.repeat(w, 1)[ring].sum())
    excess = np.where(region[..., None], np.maximum(rgb - fill, 0.0), 0.0)
    irradiance = (excess * dw[..., None]).sum((0, 1))
    total = float(((rgb @ _LUMA) * dw).sum())
    share = float(irradiance @ _LUMA) / max(total, 1e-30)
    if share < SUN_MIN_SHARE:
        return env, None
    dirs = texel_directions(w).astype(np.float64)  # [H, W, 3], the environment's frame
    weight = (excess @ _LUMA) * dw
    centre = (dirs * weight[..., None]).sum((0, 1))
    centre /= np.linalg.norm(centre)
    cos = np.clip(dirs @ centre, -1.0, 1.0)
    # a uniform disc of radius t has <theta^2> = t^2 / 2; each texel adds its own extent (a square
    # of side pi / H: <theta^2> = (pi / H)^2 / 6), so a one-texel sun is not a point
    spread = float((np.arccos(cos) ** 2 * weight).sum() / weight.sum()) + (math.pi / h) ** 2 / 6.0
    radius = math.sqrt(2.0 * spread)
    residual = env.copy()
    residual[..., :3] = np.where(region[..., None], np.minimum(rgb, fill), rgb).astype(env.dtype)
    sun = Sun(direction=tuple(float(c) for c in centre),
              irradiance=tuple(float(c) for c in irradiance),
              angular_radius=radius, texels=int(region.sum()), share=share)
    return residual, sun
