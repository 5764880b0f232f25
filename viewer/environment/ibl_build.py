"""An environment's IBLs with ``IBLOptions.prefilter_method = "convolution"``: one prefiltered
convolution (:mod:`viewer.environment.prefilter`, on the CPU) serves both the whole environment's IBL and, when
it has a compact sun (:func:`viewer.environment.sun.extract_sun`), the sun-less one.

The convolution runs on the residual (the environment without its sun, or the environment when it
has none) at the working width; ``ibl_compose.comp`` writes each level into the sun-less chain as is
(resampled to the chain's size) and into the whole environment's chain with the sun's light added as
points at the chain's full resolution (prefiltering is linear, and the sun is compact: a few dozen
points carry it). The previous method built two full chains by importance sampling.

Textures are allocated with their mip levels directly (:func:`mip_texture`): moderngl allocates
levels only through glGenerateMipmap, which on llvmpipe costs 0.2-0.4 s for a 2048-wide map and
computes levels the passes overwrite anyway.

:func:`build_environment_ibls` returns the textures, the two :class:`~viewer.environment.ibl.IBL` objects (which
own none of them: :class:`EnvironmentIBLs` does) and the CPU results the disk cache keeps
(:mod:`viewer.environment.disk_cache`), from which a later build skips the convolution and the SH passes.
"""
from __future__ import annotations

import ctypes
import ctypes.util
from dataclasses import dataclass, field

import moderngl
import numpy as np

from ..cache import texture_bytes
from .ibl_core import (
    IBL,
    IBLOptions,
    _downsample_chain,
    _groups,
    _validate,
    build_luts,
    irradiance_texture,
    mip_sizes,
    prefilter_roughness,
    sh_project,
)
from .irradiance import IRRADIANCE_WIDTH, env_below, irradiance_map
from .prefilter import (
    SUN_MAX_POINTS,
    box_down_sparse,
    level_widths,
    light_points,
    prefilter_levels,
    working_map,
)

_GL_TEXTURE_2D = 0x0DE1
_GL_RGBA32F = 0x8814
_GL_R8 = 0x8229
_GL_RGB = 0x1907
_GL_FLOAT = 0x1406
_GL_TEXTURE0 = 0x84C0
_GL_UNPACK_ALIGNMENT = 0x0CF5
_GL_PIXEL_UNPACK_BUFFER = 0x88EC
_raw_gl = None  # the raw entry points, once loaded; False: not available (fallback)


def _gl():
    """glTexImage2D and friends straight from the GL dispatch library (GLVND's libOpenGL, or
    libGL), which forwards to the current context, EGL or GLX; None where there is none."""
    global _raw_gl
    if _raw_gl is None:
        _raw_gl = False
        for name in ("libOpenGL.so.0", ctypes.util.find_library("OpenGL"), "libGL.so.1",
                     ctypes.util.find_library("GL")):
            if not name:
                continue
            try:
                lib = ctypes.CDLL(name)
                fns = {f: getattr(lib, f) for f in ("glActiveTexture", "glBindTexture",
                                                    "glTexImage2D", "glPixelStorei",
                                                    "glBindBuffer", "glCopyImageSubData")}
            except (OSError, AttributeError):
                continue
            u, i, p = ctypes.c_uint, ctypes.c_int, ctypes.c_void_p
            fns["glActiveTexture"].argtypes = [u]
            fns["glBindTexture"].argtypes = [u, u]
            fns["glTexImage2D"].argtypes = [u, i, i, i, i, i, u, u, p]
            fns["glPixelStorei"].argtypes = [u, i]
            fns["glBindBuffer"].argtypes = [u, u]
            fns["glCopyImageSubData"].argtypes = [u, u, i, i, i, i, u, u, i, i, i, i, i, i, i]
            for f in fns.values():
                f.restype = None
            _raw_gl = fns
            break
    return _raw_gl or None


def mip_texture(ctx, width: int, height: int, levels: int, rgb: np.ndarray | None = None,
                level_data: dict | None = None):
    """An RGBA32F equirect texture with mip levels 0..levels-1 allocated (level k is
    ``max(1, width >> k)`` by ``max(1, height >> k)``), level 0 set to ``rgb [height, width, 3]``
    and level k to ``level_data[k]`` (alpha 1) where given, the others undefined until a pass
    writes them; LINEAR(_MIPMAP_LINEAR), REPEAT in u, CLAMP in v. Where the GL entry points cannot
    be loaded, moderngl's build_mipmaps allocates the levels instead (the same texture, slower)."""
    gl = _gl()
    data = dict(level_data or {})
    if rgb is not None:
        data[0] = rgb
    for k in list(data):
        shape = (max(1, height >> k), max(1, width >> k))
        data[k] = np.ascontiguousarray(data[k][..., :3], dtype=np.float32)
        if data[k].shape[:2] != shape:
            raise ValueError(f"level {k} data {data[k].shape[1]}x{data[k].shape[0]} is not "
                             f"{shape[1]}x{shape[0]}")
    if gl is None:
        tex = ctx.texture((width, height), 4, dtype="f4")
        if levels > 1:
            tex.build_mipmaps(0, levels - 1)
        for k, arr in data.items():
            rgba = np.concatenate([arr, np.ones(arr.shape[:2] + (1,), np.float32)], axis=2)
            tex.write(rgba.tobytes(), level=k)
    else:
        # moderngl records the size (and allocates level 0) here; R8 keeps that allocation a
        # sixteenth of the RGBA32F one (21 ms for 2048x1024 on llvmpipe), replaced just below
        tex = ctx.texture((width, height), 4, dtype="f4", internal_format=_GL_R8)
        unit = _GL_TEXTURE0 + ctx.default_texture_unit

        def define(level, w, h, ptr=None):
            gl["glActiveTexture"](unit)
            gl["glBindTexture"](_GL_TEXTURE_2D, tex.glo)
            gl["glTexImage2D"](_GL_TEXTURE_2D, level, _GL_RGBA32F, w, h, 0, _GL_RGB, _GL_FLOAT,
                               ptr)
            gl["glBindTexture"](_GL_TEXTURE_2D, 0)

        gl["glBindBuffer"](_GL_PIXEL_UNPACK_BUFFER, 0)
        gl["glPixelStorei"](_GL_UNPACK_ALIGNMENT, 4)
        if levels > 1:
            # moderngl records the level count only in build_mipmaps: run it on a 1x1 level 0
            # (nothing to generate), then give every level its real size
            define(0, 1, 1)
            tex.build_mipmaps(0, levels - 1)
        for k in range(levels):
            ptr = data[k].ctypes.data if k in data else None
            define(k, max(1, width >> k), max(1, height >> k), ptr)
    tex.filter = ((moderngl.LINEAR_MIPMAP_LINEAR if levels > 1 else moderngl.LINEAR),
                  moderngl.LINEAR)
    tex.repeat_x = True   # u wraps around the horizon
    tex.repeat_y = False  # v clamps at the poles
    return tex


def copy_level0(src, dst, data: np.ndarray) -> None:
    """Level 0 of ``dst`` = level 0 of ``src`` (same size; ``data`` is what ``src`` holds, uploaded
    where the GL copy is not available)."""
    gl = _gl()
    if gl is None:
        h, w = data.shape[:2]
        dst.write(np.concatenate([data[..., :3], np.ones((h, w, 1), np.float32)],
                                 axis=2).astype(np.float32).tobytes(), level=0)
        return
    gl["glCopyImageSubData"](src.glo, _GL_TEXTURE_2D, 0, 0, 0, 0, dst.glo, _GL_TEXTURE_2D, 0, 0, 0,
                             0, src.width, src.height, 1)


def read_rgb(tex, level: int) -> np.ndarray:
    """Level ``level`` of an RGBA32F texture as ``[h, w, 3]`` float32."""
    w, h = max(1, tex.width >> level), max(1, tex.height >> level)
    return np.frombuffer(tex.read(level=level), np.float32).reshape(h, w, 4)[..., :3].copy()


def patch_level0(tex, env: np.ndarray, patch: tuple) -> None:
    """Write ``patch = (rows, columns, rgb [n, 3])`` into level 0 of ``tex`` (whose level 0 holds
    ``env``): the bounding rows and columns of the texels, from ``env`` with the patch applied."""
    ys, xs, values = patch
    if len(ys) == 0:
        return
    y0, y1 = int(ys.min()), int(ys.max()) + 1
    x0, x1 = int(xs.min()), int(xs.max()) + 1
    crop = env[y0:y1, x0:x1, :3].astype(np.float32, copy=True)
    crop[ys - y0, xs - x0] = values
    rgba = np.concatenate([crop, np.ones(crop.shape[:2] + (1,), np.float32)], axis=2)
    tex.write(np.ascontiguousarray(rgba).tobytes(), viewport=(x0, y0, x1 - x0, y1 - y0),
              level=0)


@dataclass
class EnvironmentIBLs:
    """One environment's IBLs and the textures they share (owned here, not by the IBLs)."""

    plain: IBL                  # the whole environment
    sunless: IBL | None         # without its compact sun (IBL.sun set), or None: it has none
    textures: list = field(default_factory=list)  # radiance, the chain(s): freed by release()
    parts: dict = field(default_factory=dict)     # what the disk cache keeps (see module doc)

    @property
    def nbytes(self) -> int:
        return sum(texture_bytes(t) for t in self.textures)

    def take_textures(self) -> list:
        """Hand the textures over to a new owner (build_ibl's IBL); this bundle frees none."""
        out, self.textures = self.textures, []
        return out

    def release(self) -> None:
        for tex in self.textures:
            tex.release()
        self.textures = []
        for ibl in (self.plain, self.sunless):
            if ibl is not None:
                ibl.release()


def compose_level(programs, dst, level: int, work: np.ndarray, points: np.ndarray,
                  a2: float) -> None:
    """``ibl_compose.comp``: level ``level`` of ``dst`` (an RGBA32F chain) = ``work [h, w, 3]``
    resampled to its size + the sun ``points [P, 6]`` (:func:`viewer.environment.prefilter.sun_points`)."""
    ctx = programs.ctx
    h, w = work.shape[:2]
    if len(points) > SUN_MAX_POINTS:
        raise ValueError(f"{len(points)} sun points, at most {SUN_MAX_POINTS}")
    block = np.zeros((2 * SUN_MAX_POINTS, 4), np.float32)  # the shader's uniform block
    block[0:2 * len(points):2, :3] = points[:, :3]
    block[1:2 * len(points):2, :3] = points[:, 3:6]
    src = ctx.texture((w, h), 3, np.ascontiguousarray(work, np.float32), dtype="f4")
    buf = ctx.buffer(block.tobytes())
    try:
        src.filter = (moderngl.LINEAR, moderngl.LINEAR)
        src.repeat_x = True
        src.repeat_y = False
        prog = programs.compute("passes/ibl_compose.comp")
        src.use(location=0)
        prog["u_work"].value = 0
        prog["u_points"].value = int(len(points))
        prog["u_a2"].value = float(a2)
        buf.bind_to_uniform_block(1)
        prog["Points"].binding = 1
        dst.bind_to_image(0, read=False, write=True, level=level)
        dw, dh = max(1, dst.width >> level), max(1, dst.height >> level)
        prog.run(_groups(dw), _groups(dh))
        ctx.memory_barrier()
    finally:
        src.release()
        buf.release()


def build_environment_ibls(programs, env: np.ndarray, options: IBLOptions = IBLOptions(),
                           residual: np.ndarray | None = None, sun=None, luts=None,
                           cached: dict | None = None, progress=None,
                           sun_patch: tuple | None = None, keep: bool = False,
                           sunless: bool = True, lights: tuple = ()) -> EnvironmentIBLs:
    """The IBLs of ``env [H, W, 3]`` (and, with a ``sun`` from :func:`viewer.environment.sun.extract_sun` and
    its ``residual`` - or ``sun_patch = (rows, columns, residual rgb)``, the residual's texels
    that differ from ``env`` -, the sun-less one) by the convolution method.

    ``luts``: ``(dfg, dominant)`` shared by the caller (else built here and owned by the result).
    ``cached``: the ``parts`` of an earlier build of the same environment and options (the
    convolved levels, the SH, the whole environment's levels): no convolution, no SH pass, no sun
    to add. ``keep``: read the whole environment's levels back into ``parts`` (for the disk
    cache). ``sunless=False``: the whole environment's IBL only (its chain still made from the
    residual's convolution plus the sun). ``progress(step)`` is called after each step
    ("radiance", "convolution", "chains", "sh"). ``lights``: every light taken out
    (:func:`viewer.environment.sun.extract_lights`, ``sun`` their first; default ``(sun,)``): the residual
    leaves them all out, and each is added back to the whole environment's chain as points."""
    want_sunless = sunless
    if sun is not None and not lights:
        lights = (sun,)
    ctx = programs.ctx
    env = _validate(env)
    h, w = env.shape[:2]
    if (residual is not None or sun_patch is not None) and sun is None:
        raise ValueError("a residual without its sun")
    if residual is not None:
        residual = _validate(residual)
        if residual.shape != env.shape:
            raise ValueError(f"residual {residual.shape} differs from the environment {env.shape}")
        ys, xs = np.nonzero((env != residual).any(axis=-1))
        sun_patch = (ys, xs, residual[ys, xs])
    if sun is not None and sun_patch is None:
        raise ValueError("a sun without its residual")
    texels = None
    if sun_patch is not None:
        ys, xs, values = sun_patch
        excess = env[ys, xs].astype(np.float64) - np.asarray(values, np.float64)
        texels = (ys, xs, np.maximum(excess, 0.0))

    def residual_map():
        out = env.copy()
        out[sun_patch[0], sun_patch[1]] = sun_patch[2]
        return out

    work_width = int(options.prefilter_width)
    width = max(w, work_width)
    sizes = mip_sizes(width, width // 2)
    levels = max(1, min(int(options.prefilter_levels), len(sizes)))
    rough = [prefilter_roughness(k, levels) for k in range(levels)]
    widths = level_widths(width, work_width, levels)
    parts = dict(cached or {})

    def step(name):
        if progress is not None:
            progress(name)

    textures: list = []
    owned_luts: list = []
    try:
        radiance = mip_texture(ctx, w, h, len(mip_sizes(w, h)), env)
        textures.append(radiance)
        _downsample_chain(programs, radiance, mip_sizes(w, h))
        step("radiance")
        if "levels" not in parts:
            if w > work_width:  # the radiance chain's level at the working width, minus the sun
                k = (w // work_width).bit_length() - 1
                work = read_rgb(radiance, k)
                if texels is not None:
                    ys, xs, vals = box_down_sparse(texels, h, w, k)
                    work[ys, xs] = np.maximum(work[ys, xs] - vals, 0.0)
            else:
                work = working_map(env if texels is None else residual_map(), work_width)
            parts["levels"] = prefilter_levels(work, rough, widths)
        step("convolution")
        work_levels = parts["levels"]
        shapes = [(max(1, x // 2), x, 3) for x in widths]
        if [tuple(np.shape(x)) for x in work_levels] != shapes:
            raise ValueError(f"convolved levels {[np.shape(x) for x in work_levels]} are not "
                             f"the {shapes} of a {levels}-level chain {width} wide")
        full_levels = parts.get("full_levels") if texels is not None else None
        full = mip_texture(ctx, width, width // 2, levels,
                           None if width == w else working_map(env, width),
                           level_data=dict(enumerate(full_levels or [], start=1)))
        textures.append(full)
        if width == w:  # level 0 is the radiance's
            copy_level0(radiance, full, env)
        sunless = None
        if texels is not None and want_sunless:
            if width == w:  # level 0: the environment with the sun's texels replaced
                sunless = mip_texture(ctx, width, width // 2, levels)
                copy_level0(radiance, sunless, env)
                patch_level0(sunless, env, sun_patch)
            else:
                sunless = mip_texture(ctx, width, width // 2, levels,
                                      working_map(residual_map(), width))
            textures.append(sunless)
        for k in range(1, levels):
            a2 = rough[k] ** 4
            if sunless is not None:
                compose_level(programs, sunless, k, work_levels[k - 1], np.zeros((0, 6)), a2)
            if full_levels is None:
                pts = (np.zeros((0, 6), np.float32) if texels is None
                       else light_points(texels, lights, h, w, rough[k] ** 2))
                compose_level(programs, full, k, work_levels[k - 1], pts, a2)
        if keep and texels is not None and full_levels is None:
            parts["full_levels"] = [read_rgb(full, k) for k in range(1, levels)]
        step("chains")
        if "sh" not in parts:
            parts["sh"] = sh_project(programs, radiance)
        if sunless is not None and "sh_sunless" not in parts:
            if width == w:  # the sun-less chain's level 0 is the residual itself
                parts["sh_sunless"] = sh_project(programs, sunless)
            else:
                tmp = mip_texture(ctx, w, h, 1, residual_map())
                try:
                    parts["sh_sunless"] = sh_project(programs, tmp)
                finally:
                    tmp.release()
        if "irradiance" not in parts:  # both maps from one convolution
            iw = max(4, min(IRRADIANCE_WIDTH, w))
            if texels is None:
                parts["irradiance"] = irradiance_map(env, iw)
            else:
                parts["irradiance"], parts["irradiance_sunless"] = irradiance_map(
                    env, iw, texels=texels)
        irr = irradiance_texture(ctx, parts["irradiance"])
        textures.append(irr)
        irr_sunless = None
        if sunless is not None:
            irr_sunless = irradiance_texture(ctx, parts["irradiance_sunless"])
            textures.append(irr_sunless)
        if luts is None:
            owned_luts = list(build_luts(programs, options))
            luts = tuple(owned_luts)
        step("sh")
    except BaseException:
        for tex in textures + owned_luts:
            tex.release()
        raise
    dfg, dominant = luts
    plain = IBL(radiance, full, dfg, np.asarray(parts["sh"], np.float32), levels, options,
                dominant, owned=(), irradiance=irr, env_below=env_below(parts["irradiance"]))
    other = None
    if sunless is not None:
        other = IBL(radiance, sunless, dfg, np.asarray(parts["sh_sunless"], np.float32), levels,
                    options, dominant, sun=sun, owned=(), irradiance=irr_sunless, lights=lights,
                    env_below=env_below(parts["irradiance_sunless"], lights))
        other.full_prefiltered = full
    return EnvironmentIBLs(plain, other, textures + owned_luts, parts)
