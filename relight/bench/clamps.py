"""What each numerical clamp of the shading path costs in accuracy (rows for ``relight bench``).

Every clamp is measured against an unclamped reference computed independently of it:

* ``perceptual roughness >= 0.045`` (``clamp_perceptual_roughness``): a roughness-0 sphere
  rendered with ``ggx_split_sum`` vs the exact mirror, computed in numpy from the renderer's normal
  AOV, the camera rays and the environment image: L_env(reflect(d, n)) x F_Schlick(f0, f90, n.v),
  the limit of the split sum (DFG -> Schlick, Vis -> 1) as roughness -> 0. The same against a
  sphere asking for roughness 0.045 shows the clamp adds nothing beyond what a 0.045 surface costs.
* ``n.v >= 1e-4`` (``shading_normal``): an image-space G-buffer of normals at n.v from 0 to 1e-3
  (fov 0.01 deg, so every pixel sees the same view direction), shaded on the GLSL path. The
  unclamped limit is the model's own output where the clamp is inactive (n.v in [2e-4, 1e-3]),
  fitted linearly and extrapolated down to n.v = 0. Also: how many pixels of the sphere's
  silhouette the clamp touches.
* ``radiance <= 1e4 before ACES`` (``tonemap_aces_fitted``): the torch twin (clamped, float32)
  against the same fit evaluated unclamped in float64 numpy, on radiances from 1e4 to 1e30.
* ``dfg.y >= 1e-4`` (``ibl_energy_compensation``): the smallest dfg.y in the renderer's DFG LUT;
  bilinear lookups cannot go below it, so if it is above 1e-4 the floor never acts.

:func:`clamp_costs` returns rows ``{"clamp", "value", "scene", "metric", "error", "note"}``.
"""
from __future__ import annotations

import math

import numpy as np

from viewer.environment.ibl import prefilter_lod
from viewer.geometry.imagespace import ImageGBuffer, view_dirs_cs
from viewer.scene.description import ObjectSpec, Scene, scene_from_dict

from . import metrics
from .scenes import bench_scene, with_material

COPPER = (0.95, 0.64, 0.54)  # metallic: f0 = albedo, no diffuse lobe


def clamp_costs(renderer, config, size: tuple[int, int] | None = None) -> list[dict]:
    """Rows for every clamp (see the module docstring) at ``size`` (default 256x256, 128x128 for
    a quick ``config``)."""
    if size is None:
        size = (128, 128) if getattr(config, "quick", False) else (256, 256)
    rows: list[dict] = []
    for env in ("studio", "sky"):
        rows += _roughness_rows(renderer, env, size)
    rows += _nov_rows(renderer, size)
    rows += _aces_rows()
    rows += _dfg_rows(renderer)
    return rows


def _row(clamp, value, scene, metric, error, note="") -> dict:
    return {"clamp": clamp, "value": value, "scene": scene, "metric": metric,
            "error": float(error), "note": note}


# ---- (a) minimum roughness ----------------------------------------------------------------------

def _sphere_scene(env: str, roughness: float, size):
    """``assets/scenes/bench/copper_sphere.toml`` under ``env`` at ``roughness`` and ``size``."""
    scene = with_material(bench_scene("copper_sphere"), albedo=COPPER, roughness=roughness)
    return scene.with_environment(procedural=env).with_camera(size=tuple(size))


def equirect_lookup(env: np.ndarray, d: np.ndarray) -> np.ndarray:
    """Bilinear lookup of an equirect image ``[H, W, 3]`` (project convention, GL_REPEAT in u,
    clamp in v, texel centres at (i + 0.5) / W) along directions ``[..., 3]``."""
    h, w = env.shape[:2]
    d = d / np.linalg.norm(d, axis=-1, keepdims=True)
    u = np.arctan2(d[..., 0], -d[..., 2]) / (2 * math.pi) + 0.5
    v = np.arctan2(np.hypot(d[..., 0], d[..., 2]), d[..., 1]) / math.pi
    x = u * w - 0.5
    y = np.clip(v * h - 0.5, 0.0, h - 1.0)
    x0 = np.floor(x).astype(np.int64)
    y0 = np.minimum(np.floor(y).astype(np.int64), h - 2)
    fx, fy = (x - x0)[..., None], (y - y0)[..., None]
    xa, xb = x0 % w, (x0 + 1) % w
    e = env.astype(np.float64)
    top = e[y0, xa] * (1 - fx) + e[y0, xb] * fx
    bottom = e[y0 + 1, xa] * (1 - fx) + e[y0 + 1, xb] * fx
    return top * (1 - fy) + bottom * fy


def exact_mirror(frame, env: np.ndarray, f0) -> np.ndarray:
    """``[H, W, 3]`` float64 radiance of a perfect mirror with Schlick Fresnel (f90 = 1) from the
    frame's normal AOV and camera rays."""
    d = frame.camera.view_rays_ws().astype(np.float64)
    n = frame.aovs["normal"].astype(np.float64)
    n /= np.maximum(np.linalg.norm(n, axis=-1, keepdims=True), 1e-30)
    nov = np.clip(-(d * n).sum(-1, keepdims=True), 0.0, 1.0)
    r = d + 2.0 * nov * n
    fresnel = np.asarray(f0) + (1.0 - np.asarray(f0)) * (1.0 - nov) ** 5
    return equirect_lookup(env, r) * fresnel


def _display(radiance: np.ndarray) -> np.ndarray:
    """The display transform in float64 numpy (ACES fit with its 1e4 input clamp, then sRGB), in
    [0, 1] without 8-bit rounding."""
    return linear_to_srgb(aces_unclamped(np.minimum(radiance[..., :3], 1e4)))


def linear_to_srgb(x: np.ndarray) -> np.ndarray:
    """IEC 61966-2-1 encoding (GLSL ``linear_to_srgb``) in numpy."""
    x = np.clip(x, 0.0, 1.0)
    return np.where(x <= 0.0031308, 12.92 * x, 1.055 * np.power(x, 1.0 / 2.4) - 0.055)


def _roughness_rows(renderer, env: str, size) -> list[dict]:
    frames = {r: renderer.render(_sphere_scene(env, r, size), aovs=("normal", "alpha"))
              for r in (0.0, 0.045)}
    scene = _sphere_scene(env, 0.0, size)
    env_img = renderer.ibl(scene).read_level("radiance", 0)[..., :3]
    ref = exact_mirror(frames[0.0], env_img, COPPER)
    mask = frames[0.0].aovs["alpha"][..., 0] >= 1.0
    rows = []
    ref_disp = _display(ref)[mask]
    tag = f"copper sphere, {env}, {size[0]}x{size[1]}"
    for r, frame in frames.items():
        rad = frame.radiance[..., :3].astype(np.float64)
        label = "roughness 0 (clamped to 0.045)" if r == 0.0 else "roughness 0.045 requested"
        err = np.abs(rad - ref)[mask]
        rows.append(_row("perceptual roughness >= 0.045", 0.045, tag, f"{label}: PSNR dB vs mirror",
                         metrics.psnr(ref_disp, _display(rad)[mask]),
                         "display (ACES + sRGB) over sphere pixels; reference = env(reflect) x "
                         "Schlick(f0, 1, n.v) in numpy"))
        rows.append(_row("perceptual roughness >= 0.045", 0.045, tag,
                         f"{label}: max abs linear vs mirror", err.max(),
                         f"reference radiance up to {ref[mask].max():.3g}"))
        rows.append(_row("perceptual roughness >= 0.045", 0.045, tag,
                         f"{label}: relative RMSE linear vs mirror",
                         np.sqrt(np.mean(err ** 2)) / np.sqrt(np.mean(ref[mask] ** 2)),
                         "includes the split-sum mip blend between the prefiltered levels "
                         "around prefilter_lod(0.045)"))
    # where the error comes from: the split sum reads the prefiltered chain at
    # viewer.environment.ibl.prefilter_lod(0.045, levels) (shaders/lib/ibl.glsl's), a blend of two levels
    ibl = renderer.ibl(scene)
    lod = prefilter_lod(0.045, ibl.levels)
    lo, frac = int(math.floor(lod)), lod - math.floor(lod)
    d = frames[0.0].camera.view_rays_ws().astype(np.float64)
    n = frames[0.0].aovs["normal"].astype(np.float64)
    n /= np.maximum(np.linalg.norm(n, axis=-1, keepdims=True), 1e-30)
    refl = d - 2.0 * (d * n).sum(-1, keepdims=True) * n
    blend = ((1 - frac) * equirect_lookup(ibl.read_level("prefiltered", lo)[..., :3], refl)
             + frac * equirect_lookup(ibl.read_level("prefiltered", lo + 1)[..., :3], refl))
    blend = blend * (ref / np.maximum(equirect_lookup(env_img, refl), 1e-30))  # x Schlick
    rows.append(_row("perceptual roughness >= 0.045", 0.045, tag,
                     "roughness 0 render vs mirror through the mip blend: PSNR dB",
                     metrics.psnr(_display(blend)[mask], _display(frames[0.0].radiance)[mask]),
                     f"reference = ({1 - frac:.3f} level {lo} + {frac:.3f} level {lo + 1}) x Schlick: "
                     f"the split sum's mip chain (level resolution halves), not the 0.002-alpha "
                     f"lobe, makes the error above"))
    diff = np.abs(frames[0.0].radiance - frames[0.045].radiance).max()
    rows.append(_row("perceptual roughness >= 0.045", 0.045, tag,
                     "max abs: roughness 0 render - roughness 0.045 render", diff,
                     "0 = the clamp itself adds nothing beyond a 0.045 surface"))
    return rows


# ---- (b) minimum n.v ----------------------------------------------------------------------------

NOV_CLAMPED = (0.0, 1e-6, 1e-5, 3e-5, 5e-5, 8e-5)
NOV_FREE = tuple(np.linspace(2e-4, 1e-3, 9))
NOV_MATERIALS = {"dielectric r=0.5": ((0.8, 0.8, 0.8), 0.5, 0.0),
                 "copper r=0.045": (COPPER, 0.045, 1.0)}


def _nov_gbuffer(fov_y: float = 0.01):
    xs = NOV_CLAMPED + NOV_FREE
    w, h = len(xs), len(NOV_MATERIALS)
    v = -view_dirs_cs(w, h, fov_y).astype(np.float64)
    ch = {k: np.zeros((h, w, c), np.float32) for k, c in
          (("albedo", 3), ("normal", 3), ("roughness", 1), ("metallic", 1), ("specular", 1),
           ("ao", 1), ("depth", 1), ("alpha", 1))}
    ch["ao"][:] = ch["alpha"][:] = ch["specular"][:] = 1.0
    ch["depth"][:] = 10.0
    for y, (albedo, rough, metal) in enumerate(NOV_MATERIALS.values()):
        for x, nov in enumerate(xs):
            vv = v[y, x]
            t = np.cross(vv, [1.0, 0.0, 0.0])
            t /= np.linalg.norm(t)  # tangent towards -Y: the grazing reflection looks at the ground
            ch["normal"][y, x] = nov * vv + math.sqrt(1.0 - nov * nov) * t
            ch["albedo"][y, x] = albedo
            ch["roughness"][y, x] = rough
            ch["metallic"][y, x] = metal
    return ImageGBuffer(channels=ch, fov_y=fov_y)


def _nov_rows(renderer, size) -> list[dict]:
    rows = []
    obj = ObjectSpec("gbuffer", path="<clamp-bench n.v stack>.exr")
    renderer.add_geometry(obj, _nov_gbuffer())  # in memory: the loader would renormalise nothing
    base = scene_from_dict({"environment": {"procedural": "studio"},
                            "render": {"model": "ggx_split_sum", "tonemap": "none"}})
    scene = Scene(environment=base.environment, render=base.render, objects=(obj,))
    try:
        rad = renderer.render(scene).radiance[..., :3].astype(np.float64)
    finally:
        renderer.geometry_cache.remove(obj)
    xs = np.array(NOV_CLAMPED + NOV_FREE)
    k = len(NOV_CLAMPED)
    for y, name in enumerate(NOV_MATERIALS):
        fit = [np.polyfit(xs[k:], rad[y, k:, c], 1) for c in range(3)]
        pred = np.stack([np.polyval(f, xs) for f in fit], -1)
        resid = np.abs(rad[y, k:] - pred[k:]).max() / np.abs(pred[k:]).max()
        err = np.abs(rad[y, :k] - pred[:k]).max(-1) / np.abs(pred[:k]).max(-1)
        rows.append(_row("n.v >= 1e-4", 1e-4, f"{name}, studio",
                         "max relative error for n.v in [0, 1e-4)", err.max(),
                         f"vs the unclamped limit: linear fit of the output over n.v in "
                         f"[2e-4, 1e-3] extrapolated to n.v = 0 (fit residual {resid:.1e})"))
    # how often: pixels of a mesh sphere's silhouette where the clamp acts
    frame = renderer.render(_sphere_scene("studio", 0.3, size), aovs=("normal", "alpha"))
    d = frame.camera.view_rays_ws()
    n = frame.aovs["normal"]
    covered = frame.aovs["alpha"][..., 0] > 0
    nov = -(d * n).sum(-1)
    rows.append(_row("n.v >= 1e-4", 1e-4, f"sphere, {size[0]}x{size[1]}",
                     "fraction of covered pixels clamped", (covered & (nov < 1e-4)).sum()
                     / max(int(covered.sum()), 1),
                     "interpolated normals at the silhouette with n.v < 1e-4 (incl. back-facing)"))
    return rows


# ---- (c) the ACES input clamp ------------------------------------------------------------------

_ACES_IN = np.array([[0.59719, 0.35458, 0.04823], [0.07600, 0.90834, 0.01566],
                     [0.02840, 0.13383, 0.83777]])
_ACES_OUT = np.array([[1.60475, -0.53108, -0.07367], [-0.10208, 1.10813, -0.00605],
                      [-0.00327, -0.07276, 1.07602]])


def aces_unclamped(c: np.ndarray) -> np.ndarray:
    """Hill's ACES fit (``tonemap_aces_fitted``) without the 1e4 input clamp, in float64."""
    v = np.maximum(np.asarray(c, np.float64), 0.0) @ _ACES_IN.T
    fit = (v * (v + 0.0245786) - 0.000090537) / (v * (0.983729 * v + 0.4329510) + 0.238081)
    return np.clip(fit @ _ACES_OUT.T, 0.0, 1.0)


def _aces_rows() -> list[dict]:
    try:
        import torch

        from learned.twins.tonemap import tonemap_aces_fitted
    except ImportError:  # the twin is the clamped side: no torch, no rows
        return []

    rng = np.random.default_rng(0)
    peak = 10.0 ** rng.uniform(4.0, 30.0, 20000)
    c = peak[:, None] * 10.0 ** rng.uniform(-36.0, 0.0, (20000, 3))  # other channels anything
    c[np.arange(20000), rng.integers(0, 3, 20000)] = peak  # the brightest channel beyond 1e4
    c = np.concatenate([c, np.diag([1e4 * 1.0001] * 3), np.diag([3e38] * 3)])
    with torch.no_grad():
        clamped = tonemap_aces_fitted(torch.from_numpy(c.astype(np.float32))).double().numpy()
    free = aces_unclamped(c)
    disp_c, disp_f = linear_to_srgb(clamped), linear_to_srgb(free)
    codes = int(np.sum(np.round(disp_c * 255) != np.round(disp_f * 255)))
    note = (f"{len(c)} radiances, brightest channel 1e4..1e30 (and 3e38), others 1e-36..1; "
            f"twin (clamped, float32) vs the fit unclamped in float64; 8-bit codes that differ: "
            f"{codes}")
    return [_row("radiance <= 1e4 before ACES", 1e4, "random HDR colours",
                 "max abs tone-mapped difference", np.abs(clamped - free).max(), note),
            _row("radiance <= 1e4 before ACES", 1e4, "random HDR colours",
                 "max abs display (sRGB) difference", np.abs(disp_c - disp_f).max(), note)]


# ---- (d) the dfg.y floor -----------------------------------------------------------------------

def _dfg_rows(renderer) -> list[dict]:
    scene = _sphere_scene("studio", 0.0, (8, 8))
    dfg = renderer.ibl(scene).read_level("dfg", 0)
    y = dfg[..., 1]
    f0 = 1.0  # the largest compensation: 1 + f0 (1 / dfg.y - 1)
    y = y.astype(np.float64)
    floored = 1.0 + f0 * (1.0 / np.maximum(y, 1e-4) - 1.0)
    free = 1.0 + f0 * (1.0 / y - 1.0)
    return [_row("dfg.y >= 1e-4", 1e-4, f"DFG LUT {y.shape[1]}x{y.shape[0]}", "min dfg.y in the LUT",
                 y.min(), f"{int((y < 1e-4).sum())} texels below the floor; bilinear lookups stay "
                 f"above the smallest texel"),
            _row("dfg.y >= 1e-4", 1e-4, f"DFG LUT {y.shape[1]}x{y.shape[0]}",
                 "max relative change of the energy compensation (f0 = 1)",
                 np.abs(floored - free).max() / np.abs(free).max(), "")]
