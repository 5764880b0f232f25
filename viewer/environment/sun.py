"""Extract the compact, very bright lights of an equirect environment (its sun, lamps, a sun's
reflection in a window) as analytic disc lights.

The split-sum model looks the environment up through a round, pre-blurred lobe, which cannot follow
the true GGX lobe where it is stretched and cut by the horizon (grazing angles): a small sun
reflected there is where split-sum loses or gains the most light (README "Split-sum accuracy").
Production renderers treat the sun as an analytic light instead (Lagarde & de Rousiers 2014,
"Moving Frostbite to PBR", sec. 4.7 and 4.9: the sun as a disc light beside the distant light
probe; Filament's sun: a directional light with an angular radius). We do the same, from the image
itself: the texels of the compact region around the brightest texel that stand far above the sky
are replaced by the sky around them, and the light they carried above it becomes a disc light
(direction, irradiance, angular radius) that the shading passes evaluate with the full BRDF
(``ggx_environment_sun`` in ``lib/shading.glsl``). :func:`extract_lights` takes up to
:data:`ENV_MAX_LIGHTS` such regions, each carrying at least SUN_MIN_SHARE of the environment's
energy (the rule is in its docstring); :func:`extract_sun` the most energetic one. Energy is kept
exactly: the residual environment plus the discs' irradiance sum to the original.

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
# A region above the threshold that is too large may hold a compact core: a studio lamp inside the
# glow of its reflector (studio.exr: 63 % of the energy in 0.008 sr, in a 0.08 sr region 100 x the
# median). Such a region is cut again at SUN_CORE_FRACTION of its own peak and its parts judged by
# the same rule; an evenly lit softbox stays whole at that level too, and stays in the image.
SUN_CORE_FRACTION = 0.05
_LUMA = np.array([0.2126, 0.7152, 0.0722], np.float64)
# at most this many compact regions become lights (each a uniform array entry and a shadow map)
ENV_MAX_LIGHTS = 4


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
    """Directions of texel centres, as :func:`viewer.environment.maps.texel_directions`."""
    phi = 2.0 * math.pi * ((xs + 0.5) / w - 0.5)
    theta = math.pi * (ys + 0.5) / h
    st = np.sin(theta)
    return np.stack([st * np.sin(phi), np.cos(theta), -st * np.cos(phi)], axis=-1)


def _components(mask: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(rows, columns, label)`` of every texel of ``mask``, labelled by its 8-connected component
    (u wraps around): min-label propagation over the neighbour pairs with pointer jumping, in
    numpy (a handful of passes for compact regions)."""
    h, w = mask.shape
    ys, xs = np.nonzero(mask)
    n = len(ys)
    index = np.full(mask.shape, -1, np.int64)
    index[ys, xs] = np.arange(n)
    pairs_a, pairs_b = [], []
    for dy, dx in ((0, 1), (1, -1), (1, 0), (1, 1)):
        yy, xx = ys + dy, (xs + dx) % w
        ok = np.nonzero(yy < h)[0]
        j = index[yy[ok], xx[ok]]
        pairs_a.append(ok[j >= 0])
        pairs_b.append(j[j >= 0])
    a, b = np.concatenate(pairs_a), np.concatenate(pairs_b)
    label = np.arange(n)
    while True:
        m = np.minimum(label[a], label[b])
        new = label.copy()
        np.minimum.at(new, a, m)
        np.minimum.at(new, b, m)
        new = new[new]
        if np.array_equal(new, label):
            return ys, xs, label
        label = new


def _light(env: np.ndarray, ys: np.ndarray, xs: np.ndarray, dw: np.ndarray, total: float
           ) -> tuple[np.ndarray, Sun]:
    """``(excess [n, 3], light)``: the light the region's texels carry above the mean of the ring
    around them (the sky they hide), as a disc light."""
    h, w = env.shape[:2]
    ry, rx = _ring(ys, xs, h, w)
    fill = (env[ry, rx, :3].astype(np.float64) * dw[ry, None]).sum(0) / float(dw[ry].sum())
    rgb = env[ys, xs, :3].astype(np.float64)
    excess = np.maximum(rgb - fill, 0.0)
    irradiance = (excess * dw[ys, None]).sum(0)
    share = float(irradiance @ _LUMA) / max(total, 1e-30)
    dirs = _directions(ys, xs, h, w)  # the environment's frame
    weight = (excess @ _LUMA) * dw[ys]
    if not float(weight.sum()) > 0.0:  # nothing above the ring (share 0): the region's own centre
        weight = dw[ys].astype(np.float64)
    centre = (dirs * weight[:, None]).sum(0)
    centre /= np.linalg.norm(centre)
    cos = np.clip(dirs @ centre, -1.0, 1.0)
    # a uniform disc of radius t has <theta^2> = t^2 / 2; each texel adds its own extent (a square
    # of side pi / H: <theta^2> = (pi / H)^2 / 6), so a one-texel sun is not a point
    spread = float((np.arccos(cos) ** 2 * weight).sum() / weight.sum()) + (math.pi / h) ** 2 / 6.0
    return excess, Sun(direction=tuple(float(c) for c in centre),
                       irradiance=tuple(float(c) for c in irradiance),
                       angular_radius=math.sqrt(2.0 * spread), texels=int(len(ys)), share=share)


def extract_lights(env: np.ndarray, max_lights: int = ENV_MAX_LIGHTS
                   ) -> tuple[np.ndarray, tuple[Sun, ...]]:
    """``(residual, lights)``: the environment with its compact lights replaced by the sky around
    them, and those lights as disc lights, brightest (most energy) first.

    The rule: a candidate is an 8-connected region of texels at least SUN_THRESHOLD times the
    median luminance, around a peak at least SUN_MIN_PEAK times it, covering at most
    SUN_MAX_SOLID_ANGLE; it becomes a light when the light it carries above the sky around it is
    at least SUN_MIN_SHARE of the environment's radiant energy; at most ``max_lights`` of them
    (the most energetic). Energy is kept exactly: per texel, residual + excess = original, and
    each light's irradiance is the sum of its texels' excess times their solid angle."""
    h, w = env.shape[:2]
    luma = env[..., :3].astype(np.float64) @ _LUMA
    dw = texel_solid_angles(h, w)
    floor = max(float(np.median(luma)), 1e-12)
    if not (float(luma.max()) >= SUN_MIN_PEAK * floor) or max_lights < 1:
        return env, ()
    total = float((luma * dw[:, None]).sum())
    ys, xs, label = _components(luma >= SUN_THRESHOLD * floor)
    area = np.bincount(label, weights=dw[ys], minlength=len(ys))
    peak = np.zeros(len(ys))
    np.maximum.at(peak, label, luma[ys, xs])
    regions = []
    for root in np.nonzero((area > 0) & (peak >= SUN_MIN_PEAK * floor))[0]:
        sel = label == root
        if area[root] <= SUN_MAX_SOLID_ANGLE:
            regions.append((ys[sel], xs[sel]))
            continue
        core = luma[ys[sel], xs[sel]] >= SUN_CORE_FRACTION * peak[root]  # the too-large region's
        cy, cx = ys[sel][core], xs[sel][core]                            # core (SUN_CORE_FRACTION)
        mask = np.zeros_like(luma, dtype=bool)
        mask[cy, cx] = True
        cys, cxs, clabel = _components(mask)
        carea = np.bincount(clabel, weights=dw[cys], minlength=len(cys))
        for croot in np.nonzero((carea > 0) & (carea <= SUN_MAX_SOLID_ANGLE))[0]:
            csel = clabel == croot
            if luma[cys[csel], cxs[csel]].max() >= SUN_MIN_PEAK * floor:
                regions.append((cys[csel], cxs[csel]))
    found = []
    for ry, rx in regions:
        excess, light = _light(env, ry, rx, dw, total)
        if light.share >= SUN_MIN_SHARE:
            found.append((light.share, ry, rx, excess, light))
    found.sort(key=lambda f: -f[0])
    found = found[:max_lights]
    if not found:
        return env, ()
    residual = env.copy()
    for _, ry, rx, excess, _ in found:
        residual[ry, rx, :3] = (env[ry, rx, :3].astype(np.float64) - excess).astype(env.dtype)
    return residual, tuple(f[4] for f in found)


def extract_sun(env: np.ndarray) -> tuple[np.ndarray, Sun | None]:
    """``(residual, sun)``: :func:`extract_lights` with one light at most, the most energetic
    compact region; ``(env, None)`` when there is none."""
    residual, lights = extract_lights(env, 1)
    return residual, (lights[0] if lights else None)
