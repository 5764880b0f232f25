"""Image-based lighting precomputation on the GPU (compute shaders in ``shaders/passes/ibl_*.comp``).

:func:`build_ibl` turns an equirect environment ``[H, W, 3]`` (from
:func:`viewer.environment.load_environment`) into what the shading passes sample:

* ``radiance``: RGBA32F equirect texture with a box-filtered mip chain made by our own
  ``ibl_downsample.comp`` (level k is ``W >> k`` by ``max(H >> k, 1)``, down to 1x1).
* ``prefiltered``: RGBA32F chain of ``levels`` mips; level k >= 1 holds the radiance prefiltered
  with the GGX lobe at alpha = ``2^(k - (levels - 1))`` (:func:`prefilter_roughness`; level 0
  is the radiance itself), by
  filtered importance sampling (Krivanek & Colbert 2008) with Hammersley points (``ibl_prefilter``).
* ``sh``: 9 radiance SH coefficients ``[9, 3]`` float32 (``ibl_sh.comp`` tile sums weighted by the
  exact texel solid angle, reduced on the CPU in float64); irradiance is ``sh_irradiance`` in GLSL.
* ``dfg``: RG32F split-sum LUT, x = n.v, y = perceptual roughness (``ibl_dfg.comp``).
* ``dominant``: R32F LUT on the same grid, the specular dominant direction's lerp factor
  (``ibl_dfg.comp``; ``specular_dominant_direction`` in ``lib/ibl.glsl``).

All sampled textures use GL_REPEAT in u and CLAMP_TO_EDGE in v (the DFG LUT clamps both) and
linear(-mipmap-linear) filtering. Environment intensity and rotation are *not* baked: they are
shader uniforms. Torch twins of every pass are in :mod:`learned.twins.ibl`.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import moderngl
import numpy as np

from .errors import InputError

_GROUP = 8  # local size of every ibl_*.comp (8 x 8)


@dataclass(frozen=True)
class IBLOptions:
    prefilter_levels: int = 6     # mips of the prefiltered chain (capped at the full chain length)
    prefilter_samples: int = 1024  # GGX samples per texel of level 1 (4x per level after it)
    dfg_size: int = 64            # DFG LUT is dfg_size x dfg_size
    dfg_samples: int = 4096       # GGX samples per DFG texel: E within 0.4% of the integral (256: 1.8%)


def prefilter_roughness(level: int, levels: int) -> float:
    """Perceptual roughness of prefiltered ``level``: alpha = 2^(level - (levels - 1)) for
    level >= 1, 0 for level 0 (the radiance itself): alpha doubles as the texel size does (see
    ``prefilter_lod`` in ``shaders/lib/ibl.glsl``, the inverse map)."""
    if level <= 0 or levels <= 1:
        return 0.0
    return math.sqrt(2.0 ** (level - (levels - 1)))


def prefilter_lod(perceptual_roughness: float, levels: int) -> float:
    """The level ``shaders/lib/ibl.glsl``'s ``prefilter_lod`` reads for ``perceptual_roughness``
    (float64 here, for analyses such as the bench's clamp table)."""
    last = max(levels - 1, 0)
    a = min(max(perceptual_roughness, 0.0), 1.0) ** 2
    a1 = 2.0 ** (1 - last)
    return a / a1 * min(last, 1) if a < a1 else last + math.log2(a)


def prefilter_samples(level: int, samples: int) -> int:
    """GGX samples per texel of prefiltered ``level`` (>= 1): ``samples`` at level 1, 4x more per
    level after it (capped at 2^16), as the level has 4x fewer texels: every level costs the same.
    A rough lobe sees a small sun through few of its samples; 64 at alpha = 1 left 25% median
    error per texel against the exact integral (park.exr), 16384 leave <1%. The default is 1024
    at level 1 (256 before): with 256 (and the lod bias of +1 ``ibl_prefilter.comp`` no longer
    adds) the levels r <= 0.3 reads blurred a small sun; now the split-sum is within 0.1-1.3 points
    of an exact prefilter against the path tracer (README "Split-sum accuracy")."""
    return int(min(samples * 4 ** max(level - 1, 0), 1 << 16))


def mip_sizes(width: int, height: int) -> list[tuple[int, int]]:
    """(w, h) of every level of a full mip chain, GL rules: ``max(1, size >> k)`` down to 1x1."""
    sizes = [(width, height)]
    while sizes[-1] != (1, 1):
        w, h = sizes[-1]
        sizes.append((max(1, w // 2), max(1, h // 2)))
    return sizes


class IBL:
    """GPU resources of one environment: textures, SH coefficients and the options used."""
    def __init__(self, radiance, prefiltered, dfg, sh: np.ndarray, levels: int,
                 options: IBLOptions, dominant=None, sun=None):
        self.radiance = radiance        # moderngl.Texture, RGBA32F, full box mip chain
        self.prefiltered = prefiltered  # moderngl.Texture, RGBA32F, `levels` mips
        self.dfg = dfg                  # moderngl.Texture, RG32F, [dfg_size, dfg_size]
        self.dominant = dominant        # moderngl.Texture, R32F, [dfg_size, dfg_size]
        self.sh = sh                    # [9, 3] float32 radiance SH coefficients
        self.levels = levels            # mips in `prefiltered`
        self.options = options
        # viewer.sun.Sun: taken out of the prefiltered chain and the SH (the radiance chain keeps
        # it), shaded analytically by passes with SUN_LIGHT; None: not taken out
        self.sun = sun
        # with a sun: the prefiltered chain of the whole environment (the plain IBL's, not owned),
        # which SUN_LIGHT passes read where the lobe is narrower than the sun
        self.full_prefiltered = None

    def bind(self, program, first_unit: int = 0) -> int:
        """Bind to the uniforms ``program`` has among ``u_env_radiance``, ``u_env_prefiltered``,
        ``u_env_dfg``, ``u_env_dominant`` (texture units from ``first_unit`` on), ``u_env_levels`` (float) and
        ``u_sh`` (vec3[9]). Returns the next free texture unit."""
        unit = first_unit
        for name, tex in (("u_env_radiance", self.radiance),
                          ("u_env_prefiltered", self.prefiltered),
                          ("u_env_dfg", self.dfg),
                          ("u_env_dominant", self.dominant)):
            if tex is not None and name in program:
                tex.use(location=unit)
                program[name].value = unit
                unit += 1
        if "u_env_levels" in program:
            program["u_env_levels"].value = float(self.levels)
        if "u_sh" in program:
            program["u_sh"].write(np.ascontiguousarray(self.sh, dtype=np.float32).tobytes())
        if self.sun is not None:  # SUN_LIGHT (a pass without a specular lobe reads no chain)
            for name, value in (("u_sun_direction", self.sun.direction),
                                ("u_sun_irradiance", self.sun.irradiance),
                                ("u_sun_radius", float(self.sun.angular_radius))):
                if name in program:
                    program[name].value = value
            if "u_env_prefiltered_full" in program:
                if self.full_prefiltered is None:
                    raise RuntimeError("an IBL without its sun needs full_prefiltered to bind")
                self.full_prefiltered.use(location=unit)
                program["u_env_prefiltered_full"].value = unit
                unit += 1
        return unit

    def read_level(self, texture: str, level: int = 0) -> np.ndarray:
        """Read back one mip of ``"radiance"``, ``"prefiltered"``, ``"dfg"`` or ``"dominant"`` as
        ``[h, w, C]`` float32 (C = 4, 4, 2, 1), row 0 first (for tests and parity checks)."""
        tex = getattr(self, texture)
        w, h = max(1, tex.width >> level), max(1, tex.height >> level)
        data = np.frombuffer(tex.read(level=level), dtype=np.float32)
        return data.reshape(h, w, tex.components).copy()

    def release(self) -> None:
        for name in ("radiance", "prefiltered", "dfg", "dominant"):
            tex = getattr(self, name)
            if tex is not None:
                tex.release()
                setattr(self, name, None)


def _groups(n: int) -> int:
    return max(1, (n + _GROUP - 1) // _GROUP)


def _env_texture(ctx, rgba: np.ndarray, max_level: int):
    """RGBA32F equirect texture with storage for levels 0..max_level (allocated by
    glGenerateMipmap; every level above 0 is then overwritten by our own passes)."""
    h, w = rgba.shape[:2]
    tex = ctx.texture((w, h), 4, np.ascontiguousarray(rgba, dtype=np.float32).tobytes(), dtype="f4")
    if max_level > 0:
        tex.build_mipmaps(0, max_level)
        tex.filter = (moderngl.LINEAR_MIPMAP_LINEAR, moderngl.LINEAR)
    else:
        tex.filter = (moderngl.LINEAR, moderngl.LINEAR)
    tex.repeat_x = True   # u wraps around the horizon
    tex.repeat_y = False  # v clamps at the poles
    return tex


def _validate(env: np.ndarray) -> np.ndarray:
    env = np.asarray(env, dtype=np.float32)
    if env.ndim != 3 or env.shape[2] not in (3, 4):
        raise InputError(f"environment must be [H, W, 3], got shape {env.shape}", where="environment")
    h, w = env.shape[:2]
    if w < 2 or w & (w - 1) or h != w // 2:
        raise InputError(f"environment must be 2:1 with a power-of-two width, got {w}x{h}",
                         where="environment")
    if not np.isfinite(env).all():
        raise InputError("environment has NaN or Inf texels", where="environment")
    return env[:, :, :3]


def _downsample_chain(programs, texture, sizes) -> None:
    """Fill mips 1.. of ``texture`` from mip 0 (``passes/ibl_downsample.comp``)."""
    down = programs.compute("passes/ibl_downsample.comp")
    for k in range(1, len(sizes)):
        texture.bind_to_image(0, read=True, write=False, level=k - 1)
        texture.bind_to_image(1, read=False, write=True, level=k)
        down.run(_groups(sizes[k][0]), _groups(sizes[k][1]))
        programs.ctx.memory_barrier()


def build_ibl(programs, env: np.ndarray, options: IBLOptions = IBLOptions(),
              sun=None, residual: np.ndarray | None = None) -> IBL:
    """Precompute the IBL resources of ``env`` (``[H, W, 3]`` float32 linear radiance, H = W / 2,
    W a power of two) on the GPU of ``programs.ctx``.

    With ``sun`` and ``residual`` (:func:`viewer.sun.extract_sun` of ``env``), the prefiltered
    chain and the SH are computed from ``residual``, the environment without its sun, which the
    passes then shade analytically; the radiance chain (background, Monte-Carlo models) keeps
    ``env``."""
    ctx = programs.ctx
    env = _validate(env)
    h, w = env.shape[:2]
    sizes = mip_sizes(w, h)
    levels = max(1, min(int(options.prefilter_levels), len(sizes)))
    rgba = np.concatenate([env, np.ones((h, w, 1), np.float32)], axis=2)

    res_rgba = None
    if residual is not None:
        res = _validate(residual)
        if res.shape != env.shape:
            raise ValueError(f"residual {res.shape} differs from the environment {env.shape}")
        res_rgba = np.concatenate([res, rgba[..., 3:]], axis=2)
    radiance = _env_texture(ctx, rgba, len(sizes) - 1)
    prefiltered = _env_texture(ctx, rgba if res_rgba is None else res_rgba, levels - 1)
    source = None  # the radiance chain the prefilter and the SH read: env's, or residual's
    dfg = None
    dominant = None
    try:
        # (a) box mip chain of the radiance, level by level
        _downsample_chain(programs, radiance, sizes)
        source = radiance
        if res_rgba is not None:
            source = _env_texture(ctx, res_rgba, len(sizes) - 1)
            _downsample_chain(programs, source, sizes)

        # (b) GGX-prefiltered chain; level 0 already holds the radiance
        pre = programs.compute("passes/ibl_prefilter.comp")
        source.use(location=0)
        pre["u_radiance"].value = 0
        pre["u_omega_p"].value = 4.0 * math.pi / (w * h)
        pre["u_max_lod"].value = float(len(sizes) - 1)
        for k in range(1, levels):
            pre["u_roughness"].value = prefilter_roughness(k, levels)
            pre["u_samples"].value = prefilter_samples(k, options.prefilter_samples)
            prefiltered.bind_to_image(0, read=False, write=True, level=k)
            pre.run(_groups(sizes[k][0]), _groups(sizes[k][1]))
            ctx.memory_barrier()

        # (c) SH projection: per-tile partial sums, reduced here in float64
        sh_prog = programs.compute("passes/ibl_sh.comp")
        gx, gy = _groups(w), _groups(h)
        partial = ctx.buffer(reserve=gx * gy * 27 * 4)
        try:
            source.bind_to_image(0, read=True, write=False, level=0)
            partial.bind_to_storage_buffer(1)
            sh_prog.run(gx, gy)
            ctx.memory_barrier()
            tiles = np.frombuffer(partial.read(), dtype=np.float32).reshape(gx * gy, 9, 3)
        finally:
            partial.release()
        sh = tiles.astype(np.float64).sum(axis=0).astype(np.float32)

        # (d) DFG LUT
        n = int(options.dfg_size)
        dfg = ctx.texture((n, n), 2, dtype="f4")
        dfg.repeat_x = False
        dfg.repeat_y = False
        dfg.filter = (moderngl.LINEAR, moderngl.LINEAR)
        dominant = ctx.texture((n, n), 1, dtype="f4")
        dominant.repeat_x = False
        dominant.repeat_y = False
        dominant.filter = (moderngl.LINEAR, moderngl.LINEAR)
        dfg_prog = programs.compute("passes/ibl_dfg.comp")
        dfg_prog["u_samples"].value = int(options.dfg_samples)
        dfg.bind_to_image(0, read=False, write=True, level=0)
        dominant.bind_to_image(1, read=False, write=True, level=0)
        dfg_prog.run(_groups(n), _groups(n))
        ctx.memory_barrier()
    except BaseException:
        for tex in (radiance, prefiltered, dfg, dominant):
            if tex is not None:
                tex.release()
        raise
    finally:
        if source is not None and source is not radiance:
            source.release()
    return IBL(radiance, prefiltered, dfg, sh, levels, options, dominant,
               sun=sun if residual is not None else None)
