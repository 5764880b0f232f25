"""The diffuse term's irradiance map: the exact cosine convolution of an environment, on the CPU.

Every shading model's Lambert term needs the irradiance ``E(n) = sum_l L(l) max(n.l, 0) dw_l`` at
the surface normal. Nine SH coefficients (Ramamoorthi & Hanrahan 2001) hold it only where the
environment has no compact bright light: a light of a few degrees projects onto every band, the
truncation rings, and the floor of a studio (several lamps, max / mean radiance ~1000) came out
25 % bright against the exact sum (``relight bench environments``, "diffuse floor" rows). Here the
sum is taken over every texel instead, as :mod:`viewer.prefilter` does for the GGX lobe: the kernel
max(n.l, 0) depends on n.l alone, so on an equirect map it is a convolution along each row, one
matrix product per frequency of an FFT along the rows (no samples, no band limit).

The result is an equirect map :data:`IRRADIANCE_WIDTH` wide, looked up per normal with bilinear
filtering (``irradiance_lookup`` in ``shaders/lib/ibl.glsl``). E(n) is smooth (a cosine lobe's
convolution): between texel centres bilinear interpolation errs by ~h^2 / 8 of a light's
irradiance (h = 2.8 degrees at 128 wide: 3e-4), more only within a texel of the terminator of a
light at a surface's horizon.

The source is the environment at :data:`SOURCE_WIDTH` at most (the radiance chain's 2x2 means of
a wider map): each texel's light moves by at most half a texel (0.35 degrees), which changes
max(n.l, 0) by 0.6 % of that light at the horizon and far less above it.

No torch: the runtime (``viewer``) calls this when it builds an environment's IBL.
"""
from __future__ import annotations

import math

import numpy as np

from .sun import texel_solid_angles

IRRADIANCE_WIDTH = 256  # the map's width (height: half); 512 KiB as RGBA32F
SOURCE_WIDTH = 512      # a wider environment is box-averaged to this before the convolution


def _spectra(ho: int, hs: int, ws: int) -> np.ndarray:
    """``[F, ho, hs]`` complex128: the rfft over d of K_os[d] = max(n.l, 0) dw_s, n at output row
    o (polar angle pi o / (ho - 1)), l at source row s, azimuth difference 2 pi (d + delta) / ws
    with delta = (r - 1) / 2 for a source r times as wide as the output (output texel centres
    fall between source centres)."""
    wo = 2 * ho
    r = ws // wo
    to = math.pi * np.arange(ho) / (ho - 1)  # rows from pole to pole (see irradiance_map)
    ts = math.pi * (np.arange(hs) + 0.5) / hs
    dphi = 2.0 * math.pi * (np.arange(ws) + (r - 1) / 2.0) / ws
    dw = texel_solid_angles(hs, ws)[:, None]
    cos_s, sin_s = np.cos(ts)[:, None], np.sin(ts)[:, None]
    out = np.empty((ws // 2 + 1, ho, hs), np.complex128)
    for o in range(ho):  # a row at a time: the temporaries stay small
        nol = math.cos(to[o]) * cos_s + math.sin(to[o]) * sin_s * np.cos(dphi)[None, :]
        out[:, o, :] = np.fft.rfft(np.maximum(nol, 0.0) * dw, axis=1).T
    return out


def irradiance_map(env: np.ndarray, width: int = IRRADIANCE_WIDTH) -> np.ndarray:
    """``[width / 2, width, 3]`` float32: the irradiance E(n) = sum over every texel of
    ``env [H, W, 3]`` of L max(n.l, 0) dw at the texel centres of an equirect map ``width`` wide
    (a power of two >= 4; a narrower environment is first upsampled bilinearly to it). A unit
    constant environment gives pi."""
    from .prefilter import working_map

    h, w = env.shape[:2]
    if w != 2 * h or w & (w - 1) or width & (width - 1) or width < 4:
        raise ValueError(f"environment {w}x{h} cannot give a {width}-wide irradiance map")
    src = working_map(env, max(min(w, SOURCE_WIDTH), width)).astype(np.float64)
    hs, ws = src.shape[:2]
    ho = width // 2
    lf = np.fft.rfft(src, axis=1).transpose(1, 0, 2)  # [F, hs, 3]
    spectra = _spectra(ho, hs, ws)                   # [F, ho, hs]
    g = np.fft.irfft(np.einsum("fos,fsc->foc", spectra, lf), n=ws, axis=0)  # [ws, ho, 3]
    out = g[:: ws // width].transpose(1, 0, 2)
    return np.maximum(out, 0.0).astype(np.float32)


def irradiance_brute(env: np.ndarray, normals: np.ndarray) -> np.ndarray:
    """``[N, 3]`` float64: E(n) for unit ``normals [N, 3]`` (environment frame), the sum over every
    texel of ``env`` (the reference the tests and the bench compare with)."""
    h, w = env.shape[:2]
    phi = 2.0 * math.pi * ((np.arange(w) + 0.5) / w - 0.5)
    theta = math.pi * (np.arange(h) + 0.5) / h
    st = np.sin(theta)[:, None]
    dirs = np.stack([st * np.sin(phi)[None, :], np.repeat(np.cos(theta)[:, None], w, 1),
                     -st * np.cos(phi)[None, :]], axis=-1).reshape(-1, 3)
    weighted = (env[..., :3].astype(np.float64)
                * texel_solid_angles(h, w)[:, None, None]).reshape(-1, 3)
    normals = np.asarray(normals, np.float64).reshape(-1, 3)
    return np.maximum(normals @ dirs.T, 0.0) @ weighted
