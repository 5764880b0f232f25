"""The diffuse term's irradiance map: the exact cosine convolution of an environment, on the CPU.

Every shading model's Lambert term needs the irradiance ``E(n) = sum_l L(l) max(n.l, 0) dw_l`` at
the surface normal. Nine SH coefficients (Ramamoorthi & Hanrahan 2001) hold it only where the
environment has no compact bright light: a light of a few degrees projects onto every band, the
truncation rings, and the floor of a studio (several lamps, max / mean radiance ~1000) came out
25 % bright against the exact sum (``relight bench environments``, "diffuse floor" rows). Here the
sum is taken over every texel instead, as :mod:`viewer.environment.prefilter` does for the GGX lobe: the kernel
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

from .sun import _LUMA, texel_solid_angles

# the map's width (height: half); 2 MiB as RGBA32F. 256 wide held every real map within 1.2 %
# but a studio's lamps (max / median 3e5) to 2.1 % at a normal within a texel of a lamp's
# terminator; 512 holds it (tests/viewer/test_env_lights.py) for 0.2 s more per new environment
IRRADIANCE_WIDTH = 512
SOURCE_WIDTH = 512      # a wider environment is box-averaged to this before the convolution


# The kernel spectra depend on the sizes alone: the process keeps the last one (67 MB for the
# default 512-wide map from a 512-wide source), so a second environment skips them
_spectra_memo: dict = {}


def _spectra(ho: int, hs: int, ws: int) -> np.ndarray:
    """``[F, ceil(ho / 2), hs]`` complex64: the rfft over d of K_os[d] = max(n.l, 0) dw_s, n at
    output row o < ceil(ho / 2) (polar angle pi o / (ho - 1); row ho - 1 - o mirrors it: it sees
    source row hs - 1 - s as row o sees s), l at source row s, azimuth difference
    2 pi (d + delta) / ws with delta = (r - 1) / 2 for a source r times as wide as the output
    (output texel centres fall between source centres)."""
    key = (ho, hs, ws)
    if key in _spectra_memo:
        return _spectra_memo[key]
    wo = 2 * ho
    r = ws // wo
    half = (ho + 1) // 2
    to = math.pi * np.arange(half) / (ho - 1)  # rows from pole to pole (see irradiance_map)
    ts = math.pi * (np.arange(hs) + 0.5) / hs
    dphi = 2.0 * math.pi * (np.arange(ws) + (r - 1) / 2.0) / ws
    dw = texel_solid_angles(hs, ws)[:, None]
    cos_s, sin_s, cos_d = np.cos(ts)[:, None], np.sin(ts)[:, None], np.cos(dphi)[None, :]
    out = np.empty((ws // 2 + 1, half, hs), np.complex64)
    for o in range(half):  # a row at a time: the temporaries stay small
        nol = math.cos(to[o]) * cos_s + math.sin(to[o]) * sin_s * cos_d
        out[:, o, :] = np.fft.rfft(np.maximum(nol, 0.0) * dw, axis=1).T
    _spectra_memo.clear()
    _spectra_memo[key] = out
    return out


def irradiance_map(env: np.ndarray, width: int = IRRADIANCE_WIDTH,
                   texels: tuple | None = None) -> np.ndarray:
    """``[width / 2, width, 3]`` float32: the irradiance E(n) = sum over every texel of
    ``env [H, W, 3]`` of L max(n.l, 0) dw at the texel centres of an equirect map ``width`` wide
    (a power of two >= 4; a narrower environment is first upsampled bilinearly to it). A unit
    constant environment gives pi. With ``texels = (rows, columns, excess [n, 3])`` (the light
    :func:`viewer.environment.sun.extract_lights` took out), ``(E of env, E of env minus the excess)`` from
    one convolution."""
    from .prefilter import box_down_sparse, working_map

    h, w = env.shape[:2]
    if w != 2 * h or w & (w - 1) or width & (width - 1) or width < 4:
        raise ValueError(f"environment {w}x{h} cannot give a {width}-wide irradiance map")
    src = working_map(env, max(min(w, SOURCE_WIDTH), width)).astype(np.float64)
    hs, ws = src.shape[:2]
    if texels is not None:  # the residual's source: the same means without the light (linear)
        ys, xs, vals = texels
        if ws < w:
            ys, xs, vals = box_down_sparse(texels, h, w, (w // ws).bit_length() - 1)
        if ws <= w:
            res = src.copy()
            res[ys, xs] -= np.asarray(vals, np.float64)
            src = np.concatenate([src, res], axis=2)
        else:  # a narrower map upsampled to the source: upsample the residual itself
            residual = env[..., :3].astype(np.float64)
            residual[texels[0], texels[1]] -= np.asarray(texels[2], np.float64)
            src = np.concatenate([src, working_map(residual.astype(np.float32), ws)], axis=2)
    ho = width // 2
    spectra = _spectra(ho, hs, ws)  # [F, half, hs]
    half = spectra.shape[1]
    lf = np.fft.rfft(src, axis=1).astype(np.complex64).transpose(1, 0, 2)  # [F, hs, C]
    both = np.concatenate([lf, lf[:, ::-1, :]], axis=2)  # rows o and ho - 1 - o at once
    g = np.fft.irfft(np.einsum("fos,fsc->foc", spectra, both), n=ws, axis=0)[:: ws // width]
    c = src.shape[2]
    top = g[..., :c].transpose(1, 0, 2)
    bottom = g[..., c:].transpose(1, 0, 2)[::-1]  # rows ho - 1 - o, o = half - 1 .. 0
    out = np.maximum(np.concatenate([top, bottom[half - (ho - half):]], axis=0), 0.0)
    out = out.astype(np.float32)
    return out if texels is None else (out[..., :3], out[..., 3:6])


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
    out = np.empty((len(normals), 3))
    for i in range(0, len(normals), 64):  # 64 normals at a time: a few MB of cosines
        out[i:i + 64] = np.maximum(normals[i:i + 64] @ dirs.T, 0.0) @ weighted
    return out


def env_below(irradiance: np.ndarray, lights=()) -> float:
    """How bright an environment's light from below is against its light from above: the
    luminance of the irradiance on a surface facing down (-Y) over that on one facing up, in
    [0, 1] (0 for a black sky, 1 for light from below alone). ``irradiance [h, w, >= 3]`` is the
    map of :func:`irradiance_map` (rows from pole to pole: row 0 faces +Y, the last row -Y; the
    mean of each row, whose texels are one point); ``lights`` the compact lights taken out of it
    (:class:`viewer.environment.sun.Sun`: irradiance times max(n.l, 0) added back). The neural
    student with ``ssao-env`` inputs reads it (``u_env_below``, one value a frame); twin:
    :func:`learned.neural.torch_lighting.env_below`. Exact where nine SH coefficients are not:
    a compact sun's SH rings below the horizon (the procedural sky's clamps to 0 there)."""
    irr = np.asarray(irradiance, np.float64)
    up, down = irr[0, :, :3].mean(0), irr[-1, :, :3].mean(0)
    for light in lights:
        y = float(light.direction[1])
        e = np.asarray(light.irradiance, np.float64)
        up, down = up + e * max(y, 0.0), down + e * max(-y, 0.0)
    lum_up, lum_down = float(up @ _LUMA), float(down @ _LUMA)  # Rec. 709
    if lum_up <= 0.0:  # a black sky 0; light from below alone 1 (the clamp's end)
        return 1.0 if lum_down > 0.0 else 0.0
    return min(max(lum_down / lum_up, 0.0), 1.0)
