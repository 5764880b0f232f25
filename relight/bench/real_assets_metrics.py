"""The measures of :mod:`relight.bench.real_assets` and the tolerances of its verdict: the
floor's speckle (:func:`speckle`), the invented-shadow fraction (:func:`invented_shadow`) and the
verdict on issue 38's three conditions (:func:`verdict`). Numpy and scipy only."""
from __future__ import annotations

import numpy as np
from scipy import ndimage

# Speckle: a judged case's floor may carry at most this multiple of split-sum's high-frequency
# energy under the same visibility. The floor's own texture and the shading's smooth gradients
# give split-sum a floor of its own (the gun under lobby in tests/viewer/test_neural_rays.py:
# 0.0017 with rays and 0.0006 without, the shipped student the same to 4 decimals, the student
# that read S(x) 0.0084 without rays, 14 x); 15 % above it is the margin that test allows, far
# below the failure it guards.
# The reference is no yardstick here: at a few hundred spp its own Monte-Carlo noise is several
# times split-sum's (it is reported beside, for scale).
SPECKLE_TOL = 1.15
# Invented shadow: a pixel where the case is darker than split-sum (same visibility) by more than
# 20 % while the truth is not darker than split-sum by more than 10 %. 20 % is a shadow one sees
# (a penumbra's edge, not a shading nuance); the truth's 10 % leaves room for its noise (256 spp
# on a floor: a few % per pixel after the blur) and for split-sum's own small biases, so a pixel
# counts only where the truth plainly has no such shadow. All three images are blurred 3x3 (over
# covered pixels only) first, so one noisy reference pixel does not decide.
SHADOW_MODEL_DARKER = 0.8
SHADOW_TRUTH_DARKER = 0.9
# ... and the fraction of covered pixels allowed: 1 % of a 160 x 120 frame's ~15k covered pixels
# is ~150 pixels, the size of a small contact shadow; the failures issue 38 reports covered ~5 %.
SHADOW_TOL = 0.01
# PSNR: the judged case may be at most this far below split-sum's against the same truth (both
# carry the same reference noise, which cancels in the difference to well under this).
PSNR_TOL = 0.1


def _lum(radiance: np.ndarray) -> np.ndarray:
    """``[H, W]`` the sum of the RGB channels (as tests/viewer/test_neural_rays.py measures)."""
    return np.asarray(radiance[..., :3], np.float64).sum(-1)


def speckle(radiance: np.ndarray, mask: np.ndarray) -> float:
    """Mean ``|lum - median3x3(lum)|`` over the pixels of ``mask`` whose whole 3 x 3 window lies
    in it (the image's edges reflected; 0 when there are none): the high-frequency energy that
    isolated bright or dark pixels add to the floor itself. A floor pixel beside an object has
    the object's pixels in its window, so it would measure the object's shading against the
    floor's instead: at 96 x 72 the student's brighter panels made the floor's border read
    1.16-1.68 x split-sum's "speckle" where its inside reads 0.95-1.00 x (2026-11-29)."""
    inner = ndimage.binary_erosion(mask, np.ones((3, 3), bool), border_value=1)
    if not inner.any():
        return 0.0
    lum = _lum(radiance)
    return float(np.abs(lum - ndimage.median_filter(lum, 3))[inner].mean())


def _blur(lum: np.ndarray, mask: np.ndarray) -> np.ndarray:
    """3x3 box blur over ``mask``'s pixels only (normalised by how many of them each window
    holds), so the sky does not bleed into a silhouette."""
    m = mask.astype(np.float64)
    num = ndimage.uniform_filter(lum * m, 3, mode="nearest")
    den = ndimage.uniform_filter(m, 3, mode="nearest")
    return np.where(den > 0, num / np.maximum(den, 1e-12), 0.0)


def invented_shadow(image: np.ndarray, baseline: np.ndarray, truth: np.ndarray,
                    mask: np.ndarray) -> float:
    """The fraction of ``mask``'s pixels where ``image`` is darker than ``baseline`` by more than
    ``1 - SHADOW_MODEL_DARKER`` while ``truth`` is not darker than ``baseline`` by more than
    ``1 - SHADOW_TRUTH_DARKER`` (all ``[H, W, >=3]`` linear radiance, 3x3-blurred over ``mask``)."""
    if not mask.any():
        return 0.0
    m, b, t = (_blur(_lum(x), mask) for x in (image, baseline, truth))
    shadow = (m < SHADOW_MODEL_DARKER * b) & (t >= SHADOW_TRUTH_DARKER * b) & mask
    return float(shadow.sum() / mask.sum())


def relative_difference(image: np.ndarray, baseline: np.ndarray, mask: np.ndarray) -> float:
    """Mean ``|image - baseline| / baseline`` of the RGB sums over ``mask`` (0 for an empty one):
    how far a case is from its split-sum at all (a case that draws split-sum's image passes every
    condition trivially)."""
    if not mask.any():
        return 0.0
    a, b = _lum(image)[mask], _lum(baseline)[mask]
    return float((np.abs(a - b) / np.maximum(b, 1e-6)).mean())


def floor_mask(frame, scene) -> np.ndarray:
    """``[H, W]`` bool: the pixels of the scene's floor plane (its last ``plane`` object) in
    ``frame``, which must carry the ``normal`` and ``depth`` AOVs: covered, facing up, and at the
    plane's height (a model's own level ground, like the diorama's, is left out)."""
    plane = [o for o in scene.objects if o.type == "plane"][-1]
    cam = frame.camera
    rays = cam.view_rays_ws().astype(np.float64)  # [H, W, 3] unit, world space
    forward = -np.asarray(cam.basis()[2], np.float64)
    depth = np.asarray(frame.aovs["depth"][..., 0], np.float64)  # view-space, along forward
    y = cam.position[1] + rays[..., 1] * depth / np.maximum(rays @ forward, 1e-9)
    tol = 1e-3 * max(plane.size)  # world units: fp32 depth at the camera's distance is finer
    return ((frame.aovs["normal"][..., 1] > 0.99) & (frame.radiance[..., 3] > 0.5)
            & (np.abs(y - plane.center[1]) < tol))


def verdict(row: dict, base: dict) -> dict:
    """Issue 38's three conditions for ``row`` against ``base`` (its split-sum with the same
    visibility), each ``<name>_ok``, and ``ok`` for all three."""
    out = {"speckle_ok": bool(row["speckle"] <= SPECKLE_TOL * base["speckle"]),
           "shadow_ok": bool(row["invented_shadow_%"] / 100.0 < SHADOW_TOL),
           "psnr_ok": bool(row["psnr_db"] >= base["psnr_db"] - PSNR_TOL)}
    out["ok"] = all(out.values())
    return out
