"""The GGX-prefiltered chain by exact convolution on the CPU (``IBLOptions.prefilter_method =
"convolution"``, the default; :mod:`viewer.environment.ibl_build` puts the result on the GPU).

Level k >= 1 of the chain holds, at each texel direction n, the split-sum's first term with
n = v = r (Karis 2013): the radiance weighted by the GGX kernel

    k(n.l) = D(h) max(n.l, 0),  h = normalize(n + l),  alpha = alpha_k

(:func:`viewer.environment.ibl.prefilter_roughness`), normalised by its integral. It depends on n.l alone (a
zonal kernel), so on an equirect map it is a convolution along each row: output row o and source
row s interact through a kernel row K_os(dphi), and the sum over every source texel is, per
frequency of an FFT along the rows, one matrix product (rows_out x rows_src) @ (rows_src x
channels). That is the brute-force sum over every texel of the source, computed in
O(H_o H_s W log W) instead of O(H_o W_o H_s W_s), with no samples and so no sampling error:
0.1-0.2 s for a 512-wide map on two CPU cores where filtered importance sampling with 1024-65536
samples per texel (``prefilter_method = "fis"``, the previous method) took 2-4 s a chain, and
erred by 0.1-0.5 % (median; up to 15-110 % at single texels near a sun) against this sum.

Every level is computed at a fixed *working width* (``IBLOptions.prefilter_width``, 512): level k
at ``width >> k``, from a source at twice its width (level 1) or 256 wide (levels >= 2): kernel
widths are then 6-7 source texels or more at every level, where the sum matches a finer source to
1e-5 (level 1) - 1e-3 (level 5, the cosine lobe's horizon kink). A wider map's levels are
resampled to its chain's sizes on the GPU (the lobe spans >= 6 texels of the working level, so a
bilinear upsampling of a smooth residual moves it by < 0.1 %); its sun, the one sharp feature, is
added afterwards at the chain's full resolution (:func:`sun_points`, ``ibl_compose.comp``). A map
narrower than the working width is first upsampled to it (:func:`working_map`), so every roughness
lands on a level with enough texels (a 128-wide map's alpha = 1 level was 4x2 texels).

No torch: this is the runtime (``viewer``). The float64 reference for tests is
``tests/shaders/test_prefilter.py``'s brute-force sum over every texel.
"""
from __future__ import annotations

import math
from collections import OrderedDict

import numpy as np

from .sun import texel_solid_angles

# every level's source is at least this wide (at most the working width): the alpha = 1 level's
# cosine lobe has a kink at the horizon that a coarser source resolves to a few % only
MIN_SOURCE_WIDTH = 256
# a level at most this wide in the chain is computed at its own size, not at the working width's
EXACT_WIDTH = 128
# sun points: cells of min(alpha, SUN_CELL_ALPHA) / SUN_CELLS radians (the centroid of a uniform
# cell of side s moves the kernel's peak by s^2 / (12 alpha^2): 0.13 %; wide kernels keep cells of
# 1/64 rad for the horizon, where k(n.l) has a kink: one point for a whole sun erred by 2 % there at
# alpha = 1), at most SUN_MAX_POINTS points per level
SUN_CELLS = 8.0
SUN_CELL_ALPHA = 0.125
SUN_MAX_POINTS = 256


def box_down(img: np.ndarray) -> np.ndarray:
    """One level of the radiance chain on the CPU, as ``passes/ibl_downsample.comp``: the 2x2 mean
    with each source row weighted by sin(theta) of its centre. ``[h, w, C]`` -> ``[h/2, w/2, C]``
    (h, w even)."""
    h, w = img.shape[:2]
    s = np.sin(np.pi * (np.arange(h) + 0.5) / h).astype(np.float32)
    pairs = img.reshape(h // 2, 2, w // 2, 2, -1).sum(axis=3, dtype=np.float32)
    w0, w1 = s[0::2, None, None], s[1::2, None, None]
    return ((pairs[:, 0] * w0 + pairs[:, 1] * w1) * (0.5 / (w0 + w1))).astype(np.float32)


def working_map(env: np.ndarray, width: int) -> np.ndarray:
    """``env [H, W, 3]`` at ``width`` (a power of two): solid-angle-weighted 2x2 means down to it
    (the radiance chain's own rule), or bilinear upsampling (u wraps, v clamps: what GL's LINEAR
    filter reads at the new texel centres) up to it."""
    from .maps import resample

    env = np.ascontiguousarray(env[..., :3], dtype=np.float32)
    while env.shape[1] > width:
        env = box_down(env)
    if env.shape[1] < width:
        env = resample(env, width, width // 2)
    return env


def box_down_sparse(texels: tuple, height: int, width: int, steps: int) -> tuple:
    """:func:`box_down` applied ``steps`` times to a ``width x height`` map that is zero except at
    ``texels = (rows, columns, values [n, C])``; returns the nonzero texels of the result in the
    same form (the sun's share of a wide map's working map, without the dense zeros)."""
    ys, xs, values = texels
    values = np.asarray(values, np.float64)
    for _ in range(steps):
        s = np.sin(np.pi * (np.arange(height) + 0.5) / height)
        pair = (ys // 2) * 2
        values = values * (s[ys] * 0.5 / (s[pair] + s[pair + 1]))[:, None]
        ys, xs, height, width = ys // 2, xs // 2, height // 2, width // 2
        keys, inverse = np.unique(ys * width + xs, return_inverse=True)
        merged = np.zeros((len(keys), values.shape[1]))
        np.add.at(merged, inverse.ravel(), values)
        ys, xs, values = keys // width, keys % width, merged
    return ys, xs, values


def ggx_normalisation(alpha: float) -> float:
    """Z(alpha) = the integral over the sphere of k(n.l) = D(h) max(n.l, 0) with
    h = normalize(n + l) (float64). With u = 1 - n.l, a = alpha^2, b = (1 - a) / 2,
    D = a / (pi (a + b u)^2) and Z = 2 a int_0^1 (1 - u) / (a + b u)^2 du
    = 2 a [(1 + a / b) / (a (a + b)) - log1p(b / a) / b^2]; for b < 0.01 (alpha > 0.99, where
    the two terms cancel) a 20 000-point midpoint rule (the kernel is smooth there)."""
    a = max(float(alpha) ** 2, 1e-12)
    b = 0.5 * (1.0 - a)
    if b >= 0.01:
        return 2.0 * a * ((1.0 + a / b) / (a * (a + b)) - math.log1p(b / a) / (b * b))
    u = (np.arange(20000) + 0.5) / 20000.0
    return float(2.0 * a * np.mean((1.0 - u) / (a + b * u) ** 2))


# The kernel spectra depend on the sizes and alpha alone: a process keeps the most recently used
# ones, at most SPECTRA_BYTES (the default chain's: 45 MB for a 512-wide, 52 MB for a 2048-wide map)
SPECTRA_BYTES = 64 << 20
_spectra: OrderedDict = OrderedDict()


def spectra_bytes() -> int:
    """Bytes the process keeps in kernel spectra (``EnvironmentStore.memory()`` reports it)."""
    return sum(v.nbytes for v in _spectra.values())


def _kernel_spectra(ho: int, hs: int, ws: int, alpha: float) -> np.ndarray:
    key = (ho, hs, ws, float(alpha))
    if key in _spectra:
        _spectra.move_to_end(key)
        return _spectra[key]
    value = _compute_spectra(ho, hs, ws, alpha)
    _spectra[key] = value
    while spectra_bytes() > SPECTRA_BYTES and len(_spectra) > 1:
        _spectra.popitem(last=False)
    return value


def _compute_spectra(ho: int, hs: int, ws: int, alpha: float) -> np.ndarray:
    """``[F, ceil(ho/2), hs]`` complex64: the rfft over d of K_os[d] = k(1 - n.l) dw_s, with n at
    output row o < ceil(ho/2) (the other rows mirror them) and l at source row s, azimuth
    difference 2 pi (d + delta) / ws, delta = (r - 1) / 2 for a source r times as wide as the
    output (output texel centres fall between source centres)."""
    wo = 2 * ho
    r = ws // wo
    half = (ho + 1) // 2
    to = math.pi * (np.arange(half) + 0.5) / ho
    ts = math.pi * (np.arange(hs) + 0.5) / hs
    dphi = 2.0 * math.pi * (np.arange(ws) + (r - 1) / 2.0) / ws
    # 1 - n.l = 2 sin^2((to - ts) / 2) + 2 sin(to) sin(ts) sin^2(dphi / 2): no cancellation near
    # n = l, where the sharp kernels live
    rows_a = (2.0 * np.sin(0.5 * (to[:, None] - ts[None, :])) ** 2).astype(np.float32)
    rows_b = (2.0 * np.sin(to)[:, None] * np.sin(ts)[None, :]).astype(np.float32)
    cols = (np.sin(0.5 * dphi) ** 2).astype(np.float32)
    a2 = alpha * alpha
    dw = (texel_solid_angles(hs, ws) * (a2 / math.pi)).astype(np.float32)
    out = np.empty((ws // 2 + 1, half, hs), np.complex64)
    for o in range(half):  # a row at a time: the temporaries stay in cache
        omc = rows_a[o][:, None] + rows_b[o][:, None] * cols[None, :]  # [hs, ws]
        bracket = omc * np.float32(0.5 * (1.0 - a2)) + np.float32(a2)
        k = np.maximum(np.float32(1.0) - omc, np.float32(0.0)) / (bracket * bracket)
        k *= dw[:, None]
        out[:, o, :] = np.fft.rfft(k, axis=1).T
    return out


def convolve_level(source: np.ndarray, out_height: int, alpha: float) -> np.ndarray:
    """The GGX prefilter at ``alpha`` of ``source [hs, ws, 3]`` (equirect texels, each constant
    over its solid angle) at the texel centres of an ``[out_height, 2 out_height]`` level (ws a
    multiple of its width): sum_s k(n.l_s) dw_s L_s / sum_s k(n.l_s) dw_s over every source texel.
    Returns ``[out_height, 2 out_height, 3]`` float32."""
    hs, ws = source.shape[:2]
    ho, wo = out_height, 2 * out_height
    if ws % wo or hs * 2 != ws:
        raise ValueError(f"source {ws}x{hs} is not a 2:1 multiple of the output {wo}x{ho}")
    r = ws // wo
    spectra = _kernel_spectra(ho, hs, ws, float(alpha))  # [F, half, hs]
    half = spectra.shape[1]
    lf = np.fft.rfft(np.ascontiguousarray(source[..., :3], dtype=np.float32), axis=1)
    lf = lf.astype(np.complex64).transpose(1, 0, 2)  # [F, hs, 3]
    both = np.concatenate([lf, lf[:, ::-1, :]], axis=2)  # rows o and ho - 1 - o at once
    # a batch of small products per frequency: einsum's own loop, not BLAS, whose threads (two
    # cores shared with other work) turned 7 ms into 0.1-0.5 s at random
    g = np.fft.irfft(np.einsum("fos,fsc->foc", spectra, both), n=ws, axis=0)[::r]  # [wo, half, 6]
    # the kernel's discrete integral (what a constant environment sums to) is the spectra's DC
    # term summed over the source rows; the same for row o and its mirror ho - 1 - o
    norm = spectra[0].real.astype(np.float64).sum(axis=1)[:, None, None]  # [half, 1, 1]
    top = g[..., :3].transpose(1, 0, 2) / norm
    bottom = (g[..., 3:].transpose(1, 0, 2) / norm)[::-1]  # rows ho - 1 - o, o = half - 1 .. 0
    full = np.concatenate([top, bottom[half - (ho - half):]], axis=0)
    out = np.maximum(full, 0.0)
    return out.astype(np.float32)


def level_widths(chain_width: int, work_width: int, levels: int) -> list[int]:
    """Width each level 1..levels-1 of a ``chain_width``-wide chain is computed at: the working
    width's level (``work_width >> k``), or the chain's own where that is at most
    :data:`EXACT_WIDTH` (small levels cost little at full size, and are then not resampled)."""
    return [int(min(max(1, chain_width >> k), max(work_width >> k, EXACT_WIDTH, 2)))
            for k in range(1, levels)]


def source_width(out_width: int, work_width: int) -> int:
    """Width of the source a level ``out_width`` wide is convolved from: twice its width, at
    least :data:`MIN_SOURCE_WIDTH`, at most the working width."""
    return int(min(work_width, max(2 * out_width, MIN_SOURCE_WIDTH)))


def prefilter_levels(work: np.ndarray, roughness: list[float], widths: list[int] | None = None,
                     progress=None) -> list[np.ndarray]:
    """Levels 1.. of the prefiltered chain of ``work [P/2, P, 3]`` (a :func:`working_map`) with
    perceptual roughness ``roughness[k]``, level k ``widths[k - 1]`` wide (default ``P >> k``;
    see :func:`level_widths`). ``progress(k)`` is called after each level."""
    width = work.shape[1]
    if widths is None:
        widths = [max(2, width >> k) for k in range(1, len(roughness))]
    chain = {width: np.ascontiguousarray(work, dtype=np.float32)}
    out = []
    for k in range(1, len(roughness)):
        wo = int(widths[k - 1])
        sw = source_width(wo, width)
        if sw % wo:
            raise ValueError(f"level {k}: {wo} wide does not divide the source's {sw}")
        while sw not in chain:
            smallest = min(chain)
            chain[smallest // 2] = box_down(chain[smallest])
        out.append(convolve_level(chain[sw], max(1, wo // 2), float(roughness[k]) ** 2))
        if progress is not None:
            progress(k)
    return out


# ---- the sun, as points ---------------------------------------------------------------------

def sun_texels(env: np.ndarray, residual: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(rows, columns, excess [n, 3] float64)``: the texels :func:`viewer.environment.sun.extract_sun` took
    the sun out of and the light it took (``env - residual`` there; zero everywhere else)."""
    ys, xs = np.nonzero((env[..., :3] != residual[..., :3]).any(axis=-1))
    excess = env[ys, xs, :3].astype(np.float64) - residual[ys, xs, :3].astype(np.float64)
    return ys, xs, np.maximum(excess, 0.0)


def sun_points(texels: tuple, height: int, width: int, alpha: float,
               max_points: int = SUN_MAX_POINTS) -> np.ndarray:
    """The sun's light (``texels`` from :func:`sun_texels` of a ``width x height`` map) as at
    most :data:`SUN_MAX_POINTS` points for a kernel of ``alpha``: its texels binned into cells of
    ``alpha / SUN_CELLS`` radians on the plane tangent at its centre, each cell one point at the
    energy-weighted mean direction carrying the cell's energy sum(excess dw). Returns ``[P, 6]``
    float32: unit direction (environment frame), RGB energy / Z(alpha) (the kernel's integral,
    :func:`ggx_normalisation`): ``ibl_compose.comp`` adds sum_p E_p k(n.l_p) to the level."""
    ys, xs, excess = texels
    if len(ys) == 0:
        return np.zeros((0, 6), np.float32)
    energy = excess * texel_solid_angles(height, width)[ys][:, None]     # [n, 3]
    phi = 2.0 * math.pi * ((xs + 0.5) / width - 0.5)
    theta = math.pi * (ys + 0.5) / height
    st = np.sin(theta)
    dirs = np.stack([st * np.sin(phi), np.cos(theta), -st * np.cos(phi)], axis=-1)
    weight = np.maximum(energy.sum(axis=1), 1e-300)
    centre = (dirs * weight[:, None]).sum(0)
    centre /= np.linalg.norm(centre)
    t1 = np.cross(centre, [0.0, 1.0, 0.0] if abs(centre[1]) < 0.9 else [1.0, 0.0, 0.0])
    t1 /= np.linalg.norm(t1)
    t2 = np.cross(centre, t1)
    cos = np.maximum(dirs @ centre, 1e-6)
    px, py = (dirs @ t1) / cos, (dirs @ t2) / cos  # gnomonic: angles near the centre
    cell = min(max(float(alpha), 1e-4), SUN_CELL_ALPHA) / SUN_CELLS
    while True:
        keys = np.stack([np.floor(px / cell), np.floor(py / cell)], -1).astype(np.int64)
        uniq, inverse = np.unique(keys, axis=0, return_inverse=True)
        if len(uniq) <= max_points:
            break
        cell *= 1.5
    inverse = inverse.ravel()
    n = len(uniq)
    e = np.zeros((n, 3))
    d = np.zeros((n, 3))
    np.add.at(e, inverse, energy)
    np.add.at(d, inverse, dirs * weight[:, None])
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    e /= ggx_normalisation(alpha)
    return np.concatenate([d, e], axis=1).astype(np.float32)


def light_points(texels: tuple, lights: tuple, height: int, width: int, alpha: float
                 ) -> np.ndarray:
    """:func:`sun_points` of each light's texels (each texel goes to the light
    whose direction is nearest), SUN_MAX_POINTS / len(lights) points at most per light."""
    ys, xs, excess = texels
    if len(lights) <= 1:
        return sun_points(texels, height, width, alpha)
    phi = 2.0 * math.pi * ((xs + 0.5) / width - 0.5)
    theta = math.pi * (ys + 0.5) / height
    st = np.sin(theta)
    dirs = np.stack([st * np.sin(phi), np.cos(theta), -st * np.cos(phi)], axis=-1)
    owner = np.argmax(dirs @ np.array([li.direction for li in lights]).T, axis=1)
    cap = SUN_MAX_POINTS // len(lights)
    return np.concatenate([sun_points((ys[owner == i], xs[owner == i], excess[owner == i]),
                                      height, width, alpha, max_points=cap)
                           for i in range(len(lights))], axis=0)
