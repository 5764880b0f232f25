"""Image error metrics for the benchmark (numpy; HDR-FLIP through flip-evaluator).

PSNR and SSIM are computed on the display image (exposure, tone mapping and sRGB encoding of the
scene's settings, values in [0, 1]) because that is what a user compares; RMSE and HDR-FLIP on the
linear radiance. SSIM is Wang et al. 2004 with an 11-tap Gaussian window (sigma 1.5), K1 = 0.01,
K2 = 0.03, averaged over channels — the same definition as pytorch-msssim's ``ssim``
(tests/viewer/test_bench.py cross-checks the two).
"""
from __future__ import annotations

import math

import numpy as np


def rmse(reference: np.ndarray, test: np.ndarray) -> float:
    return float(np.sqrt(np.mean((np.asarray(test, np.float64) - reference) ** 2)))


def psnr(reference: np.ndarray, test: np.ndarray, peak: float = 1.0) -> float:
    """Peak signal-to-noise ratio in dB; ``inf`` for identical images."""
    mse = float(np.mean((np.asarray(test, np.float64) - np.asarray(reference, np.float64)) ** 2))
    return float("inf") if mse == 0.0 else 10.0 * math.log10(peak * peak / mse)


def _gaussian_window(size: int = 11, sigma: float = 1.5) -> np.ndarray:
    x = np.arange(size, dtype=np.float64) - size // 2
    g = np.exp(-(x * x) / (2.0 * sigma * sigma))
    return g / g.sum()


def _filter_valid(img: np.ndarray, g: np.ndarray) -> np.ndarray:
    """Separable 'valid' convolution of [H, W] with the 1-D kernel g along both axes."""
    k = len(g)
    h, w = img.shape
    rows = sum(g[i] * img[i:h - k + 1 + i, :] for i in range(k))
    return sum(g[j] * rows[:, j:w - k + 1 + j] for j in range(k))


def ssim(reference: np.ndarray, test: np.ndarray, data_range: float = 1.0) -> float:
    """Mean SSIM over pixels and channels of ``[H, W, C]`` images (H, W >= 11)."""
    ref = np.asarray(reference, np.float64)
    tst = np.asarray(test, np.float64)
    if ref.ndim == 2:
        ref, tst = ref[..., None], tst[..., None]
    g = _gaussian_window()
    c1, c2 = (0.01 * data_range) ** 2, (0.03 * data_range) ** 2
    values = []
    for c in range(ref.shape[2]):
        x, y = ref[..., c], tst[..., c]
        mu_x, mu_y = _filter_valid(x, g), _filter_valid(y, g)
        sxx = _filter_valid(x * x, g) - mu_x * mu_x
        syy = _filter_valid(y * y, g) - mu_y * mu_y
        sxy = _filter_valid(x * y, g) - mu_x * mu_y
        s = ((2 * mu_x * mu_y + c1) * (2 * sxy + c2)) / ((mu_x ** 2 + mu_y ** 2 + c1) * (sxx + syy + c2))
        values.append(s.mean())
    return float(np.mean(values))


def hdr_flip(reference: np.ndarray, test: np.ndarray) -> float:
    """Mean HDR-FLIP (Andersson et al. 2021) of linear radiance ``[H, W, 3]``; lower is better."""
    import flip_evaluator as flip

    ref = np.ascontiguousarray(np.clip(reference[..., :3], 0.0, None), np.float32)
    tst = np.ascontiguousarray(np.clip(test[..., :3], 0.0, None), np.float32)
    _, mean, _ = flip.evaluate(ref, tst, "HDR", inputsRGB=False, applyMagma=False)
    return float(mean)
