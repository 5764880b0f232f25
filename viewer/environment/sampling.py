"""Environment importance sampling: the 2D distribution ``luminance x sin(theta)`` built on the GPU.

:func:`build_env_sampling` turns the level-0 radiance texture of an :class:`~viewer.environment.ibl.IBL` (an
equirect ``W x H`` RGBA32F texture) into three R32F textures that ``lib/env_sampling.glsl`` samples
(marginal + conditional CDFs and the per-texel density), in three compute passes:

1. ``env_cdf_rows.comp`` (one invocation per row): f = 3x3-dilated luminance x sin(theta); the
   row's conditional CDF (uniform for an all-zero row) and its sum.
2. ``env_cdf_marginal.comp`` (one invocation): the marginal CDF over rows; an all-zero (or
   overflowing) environment falls back to uniform sampling of the sphere.
3. ``env_cdf_pdf.comp``: ``p_uv = f / mean(f)``, the density on the uv square.

Intensity and rotation stay shader uniforms (they do not change the normalised distribution).
Torch twin: :func:`learned.twins.env_sampling.env_distribution`.
"""
from __future__ import annotations

import math

import moderngl
import numpy as np


class EnvSampling:
    """GPU textures of one environment's sampling distribution (``needs`` entry ``"cdf"``)."""
    def __init__(self, marginal, conditional, pdf, fallback: bool):
        self.marginal = marginal        # moderngl.Texture R32F [(H + 1) x 1]
        self.conditional = conditional  # moderngl.Texture R32F [(W + 1) x H]
        self.pdf = pdf                  # moderngl.Texture R32F [W x H], p_uv (mean 1)
        self.fallback = fallback        # True: the environment was black; sampling is uniform

    def bind(self, program, first_unit: int = 0) -> int:
        """Bind to the uniforms ``program`` has among ``u_env_marginal``, ``u_env_conditional``,
        ``u_env_pdf`` (texture units from ``first_unit`` on). Returns the next free unit."""
        unit = first_unit
        for name, tex in (("u_env_marginal", self.marginal),
                          ("u_env_conditional", self.conditional), ("u_env_pdf", self.pdf)):
            if tex is not None and name in program:
                tex.use(location=unit)
                program[name].value = unit
                unit += 1
        return unit

    def read(self) -> dict[str, np.ndarray]:
        """``marginal [H + 1]``, ``conditional [H, W + 1]``, ``pdf [H, W]`` float32 (row 0 = the
        zenith row, as in the texture)."""
        out = {}
        for name in ("marginal", "conditional", "pdf"):
            tex = getattr(self, name)
            arr = np.frombuffer(tex.read(), np.float32).reshape(tex.height, tex.width)
            out[name] = arr[0].copy() if name == "marginal" else arr.copy()
        return out

    @classmethod
    def from_arrays(cls, ctx, marginal: np.ndarray, conditional: np.ndarray, pdf: np.ndarray,
                    fallback: bool) -> "EnvSampling":
        """The textures of arrays :meth:`read` returned (e.g. from the disk cache)."""
        h, w = pdf.shape
        if marginal.shape != (h + 1,) or conditional.shape != (h, w + 1):
            raise ValueError(f"sampling tables of shapes {marginal.shape}, {conditional.shape}, "
                             f"{pdf.shape} do not belong together")
        out = []
        try:
            for arr, (tw, th) in ((marginal, (h + 1, 1)), (conditional, (w + 1, h)), (pdf, (w, h))):
                tex = _r32f(ctx, tw, th)
                out.append(tex)
                tex.write(np.ascontiguousarray(arr, np.float32).tobytes())
        except BaseException:
            for tex in out:
                tex.release()
            raise
        return cls(out[0], out[1], out[2], bool(fallback))

    def release(self) -> None:
        for name in ("marginal", "conditional", "pdf"):
            tex = getattr(self, name)
            if tex is not None:
                tex.release()
                setattr(self, name, None)


def _r32f(ctx, width: int, height: int):
    tex = ctx.texture((width, height), 1, dtype="f4")
    tex.filter = (moderngl.NEAREST, moderngl.NEAREST)
    tex.repeat_x = tex.repeat_y = False
    return tex


def build_env_sampling(programs, radiance) -> EnvSampling:
    """The sampling distribution of the equirect ``radiance`` texture (level 0 is read; W x H with
    W = 2H, as :func:`viewer.environment.ibl.build_ibl` makes it), computed on the GPU of ``programs.ctx``."""
    ctx = programs.ctx
    w, h = radiance.width, radiance.height
    func = _r32f(ctx, w, h)
    conditional = _r32f(ctx, w + 1, h)
    marginal = _r32f(ctx, h + 1, 1)
    rows = ctx.buffer(reserve=4 * h)
    stats = ctx.buffer(reserve=8)
    try:
        prog = programs.compute("passes/env_cdf_rows.comp")
        radiance.use(location=0)
        prog["u_env_radiance"].value = 0
        func.bind_to_image(0, read=False, write=True)
        conditional.bind_to_image(1, read=False, write=True)
        rows.bind_to_storage_buffer(2)
        prog.run((h + 63) // 64)
        ctx.memory_barrier()

        prog = programs.compute("passes/env_cdf_marginal.comp")
        marginal.bind_to_image(0, read=False, write=True)
        rows.bind_to_storage_buffer(2)
        stats.bind_to_storage_buffer(3)
        prog["u_height"].value = h
        prog.run(1)
        ctx.memory_barrier()

        prog = programs.compute("passes/env_cdf_pdf.comp")
        func.bind_to_image(0, read=True, write=True)
        stats.bind_to_storage_buffer(3)
        prog.run((w + 7) // 8, (h + 7) // 8)
        ctx.memory_barrier()
        fallback = bool(np.frombuffer(stats.read(), np.float32)[1] > 0.5)
    except BaseException:
        for tex in (func, conditional, marginal):
            tex.release()
        raise
    finally:
        rows.release()
        stats.release()
    return EnvSampling(marginal, conditional, func, fallback)


def power_directions(env: np.ndarray, count: int = 8) -> np.ndarray:
    """``count`` unit directions (environment frame ``[count, 3]`` float32) that split the
    environment's power into equal parts: the texel at each stratified quantile (k + 0.5) / count
    of the luminance x sin(theta) distribution (rows in order, columns within a row), at the texel
    centre (``lib/equirect.glsl``'s convention). Under a sky with a small bright sun most of them
    land on the sun, under an overcast one they spread over the sky: each stands for 1 / count of
    the light. The screen-space visibility towards them (``passes/ssao.frag``, ``SSAO_ENV_VIS``)
    is an input of the students that see visibility. An all-black environment gives the
    quantiles of sin(theta) alone (directions spread over the sphere). ``env [H, W, >=3]``."""
    env = np.asarray(env, np.float64)
    h, w = env.shape[:2]
    lum = np.clip(env[..., 0] * 0.2126 + env[..., 1] * 0.7152 + env[..., 2] * 0.0722, 0.0, None)
    lum = np.where(np.isfinite(lum), lum, 0.0)
    sin_t = np.sin(np.pi * (np.arange(h) + 0.5) / h)[:, None]
    f = (lum * sin_t).ravel()
    if not f.sum() > 0.0:
        f = np.broadcast_to(sin_t, (h, w)).ravel().copy()
    cdf = np.cumsum(f)
    cdf /= cdf[-1]
    q = (np.arange(count) + 0.5) / count
    idx = np.minimum(np.searchsorted(cdf, q, side="right"), f.size - 1)
    u = (idx % w + 0.5) / w
    v = (idx // w + 0.5) / h
    phi, theta = 2.0 * np.pi * (u - 0.5), np.pi * v
    d = np.stack([np.sin(theta) * np.sin(phi), np.cos(theta), -np.sin(theta) * np.cos(phi)], -1)
    return d.astype(np.float32)


def median_cut(env: np.ndarray, count: int = 8, max_width: int = 512
               ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The environment as ``count`` lights of its light (Debevec 2005, "A median cut algorithm
    for light probe sampling"): the equirect split into regions of about equal power, each a
    light at its power-weighted mean direction. Returns (directions ``[count, 3]`` unit,
    environment frame; shares ``[count]``, each region's part of the power, summing to 1;
    angular radii ``[count]``, radians: the disc with the region's spread about its direction,
    sqrt(2 x its power-weighted mean squared angle)). The most powerful region is split each
    time (so any count, not only powers of two), across its longer side (a row's width counted
    at its latitude) where its power is halved; a one-texel region is not split further (fewer
    lights then). Power is luminance x sin(theta) per texel, from the image box-filtered to at most
    ``max_width`` texels wide; an all-black environment splits sin(theta) alone."""
    env = np.asarray(env, np.float64)
    h, w = env.shape[:2]
    step = max(1, int(math.ceil(w / max_width)))
    while h % step or w % step:
        step -= 1
    env = env[..., :3].reshape(h // step, step, w // step, step, 3).mean((1, 3))
    h, w = env.shape[:2]
    lum = np.clip(env[..., 0] * 0.2126 + env[..., 1] * 0.7152 + env[..., 2] * 0.0722, 0.0, None)
    lum = np.where(np.isfinite(lum), lum, 0.0)
    theta = np.pi * (np.arange(h) + 0.5) / h
    sin_t = np.sin(theta)[:, None]
    f = lum * sin_t
    if not f.sum() > 0.0:
        f = np.broadcast_to(sin_t, (h, w)).copy()
    phi = 2.0 * np.pi * ((np.arange(w) + 0.5) / w - 0.5)
    dirs = np.stack([np.sin(theta)[:, None] * np.sin(phi)[None], np.cos(theta)[:, None]
                     * np.ones(w)[None], -np.sin(theta)[:, None] * np.cos(phi)[None]], -1)
    regions = [(0, h, 0, w)]
    while len(regions) < count:
        power = [f[y0:y1, x0:x1].sum() for y0, y1, x0, x1 in regions]
        order = np.argsort(power)[::-1]
        split = None
        for i in order:
            y0, y1, x0, x1 = regions[i]
            if (y1 - y0) * (x1 - x0) > 1:
                split = i
                break
        if split is None:
            break
        y0, y1, x0, x1 = regions.pop(split)
        block = f[y0:y1, x0:x1]
        wide = (x1 - x0) / w * 2.0 * np.pi * float(sin_t[y0:y1].max())
        tall = (y1 - y0) / h * np.pi
        along_x = (wide >= tall and x1 - x0 > 1) or y1 - y0 == 1
        marginal = block.sum(0 if along_x else 1)
        cut = int(np.searchsorted(np.cumsum(marginal), 0.5 * marginal.sum())) + 1
        cut = min(max(cut, 1), len(marginal) - 1)
        if along_x:
            regions += [(y0, y1, x0, x0 + cut), (y0, y1, x0 + cut, x1)]
        else:
            regions += [(y0, y0 + cut, x0, x1), (y0 + cut, y1, x0, x1)]
    total = f.sum()
    out_d, out_s, out_r = [], [], []
    for y0, y1, x0, x1 in regions:
        wts = f[y0:y1, x0:x1]
        d = dirs[y0:y1, x0:x1]
        mean = (wts[..., None] * d).sum((0, 1))
        norm = np.linalg.norm(mean)
        c = mean / norm if norm > 0 else d[d.shape[0] // 2, d.shape[1] // 2]
        ang = np.arccos(np.clip((d * c).sum(-1), -1.0, 1.0))
        m2 = float((wts * ang * ang).sum() / max(wts.sum(), 1e-300))
        out_d.append(c)
        out_s.append(wts.sum() / total)
        out_r.append(math.sqrt(2.0 * m2))
    return (np.asarray(out_d, np.float32), np.asarray(out_s, np.float32),
            np.asarray(out_r, np.float32))
