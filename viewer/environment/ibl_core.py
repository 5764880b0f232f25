"""The IBL's data (:class:`IBLOptions`, :class:`IBL`, the level <-> roughness map) and the GPU
passes both prefilter methods share: the radiance chain's downsampling, the SH projection and the DFG /
dominant-direction LUTs. :mod:`viewer.environment.ibl` builds IBLs from them (and re-exports every name here);
:mod:`viewer.environment.ibl_build` is the convolution method's builder.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import moderngl
import numpy as np

from ..errors import InputError

_GROUP = 8  # local size of the 2D ibl_*.comp passes (8 x 8)
_SH_RUN = 64  # texels of a row one ibl_sh.comp invocation sums (SH_RUN there)


PREFILTER_METHODS = ("convolution", "fis")


@dataclass(frozen=True)
class IBLOptions:
    prefilter_levels: int = 6     # mips of the prefiltered chain (capped at the full chain length)
    # "convolution": exact sum over every texel on the CPU (viewer.environment.prefilter), one chain for an
    # environment and its sun-less IBL (the sun added as points); "fis": filtered importance
    # sampling in compute with prefilter_samples, one full chain per IBL (the method before)
    prefilter_method: str = "convolution"
    prefilter_samples: int = 1024  # "fis": GGX samples per texel of level 1 (4x per level after it)
    # "convolution": the width the levels are computed at (a power of two); a narrower map's
    # chain is this wide (its source upsampled), a wider map's levels are upsampled to its sizes
    prefilter_width: int = 512
    dfg_size: int = 64            # DFG LUT is dfg_size x dfg_size
    dfg_samples: int = 4096       # GGX samples per DFG texel: E within 0.4% of the integral (256: 1.8%)

    def __post_init__(self):
        if self.prefilter_method not in PREFILTER_METHODS:
            raise ValueError(f"IBLOptions.prefilter_method must be one of "
                             f"{', '.join(PREFILTER_METHODS)}, got {self.prefilter_method!r}")
        w = int(self.prefilter_width)
        if w < 16 or w & (w - 1):
            raise ValueError(f"IBLOptions.prefilter_width must be a power of two >= 16, got {w}")
        if int(self.prefilter_levels) < 1:
            raise ValueError(f"IBLOptions.prefilter_levels must be >= 1, "
                             f"got {self.prefilter_levels}")

    @classmethod
    def legacy(cls, **changes) -> "IBLOptions":
        """The method before (the bench's baseline): filtered importance sampling with 1024
        samples per level-1 texel, 4x per level after it, no minimum chain width."""
        return cls(prefilter_method="fis", **changes)


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
                 options: IBLOptions, dominant=None, sun=None, owned=None, irradiance=None,
                 lights: tuple = (), env_below: float | None = None):
        self.radiance = radiance        # moderngl.Texture, RGBA32F, full box mip chain
        self.prefiltered = prefiltered  # moderngl.Texture, RGBA32F, `levels` mips
        self.dfg = dfg                  # moderngl.Texture, RG32F, [dfg_size, dfg_size]
        self.dominant = dominant        # moderngl.Texture, R32F, [dfg_size, dfg_size]
        self.sh = sh                    # [9, 3] float32 radiance SH coefficients
        # moderngl.Texture, RGBA32F: the exact irradiance map (viewer.environment.irradiance; rows from pole
        # to pole), of the same environment as the prefiltered chain (the residual with a sun)
        self.irradiance = irradiance
        self.levels = levels            # mips in `prefiltered`
        self.options = options
        # viewer.environment.sun.Sun: taken out of the prefiltered chain and the SH (the radiance chain keeps
        # it), shaded analytically by passes with SUN_LIGHT; None: not taken out
        self.sun = sun
        # every light taken out (viewer.environment.sun.extract_lights), the sun first; () without a sun
        self.lights = tuple(lights) if lights else ((sun,) if sun is not None else ())
        # with a sun: the prefiltered chain of the whole environment (the plain IBL's, not owned),
        # which SUN_LIGHT passes read where the lobe is narrower than the sun
        self.full_prefiltered = None
        # viewer.environment.irradiance.env_below of the irradiance map and the lights taken out
        # (the builders compute it from the map's array: no readback); None: not computed
        self.env_below = env_below
        # the textures release() frees (default: radiance, prefiltered, dfg, dominant); an IBL of a
        # viewer.environment.store.EnvironmentStore owns none: the store frees them on eviction
        self._owned = (list(owned) if owned is not None else
                       [t for t in (radiance, prefiltered, dfg, dominant, irradiance)
                        if t is not None])

    def bind(self, program, first_unit: int = 0) -> int:
        """Bind to the uniforms ``program`` has among ``u_env_radiance``, ``u_env_prefiltered``,
        ``u_env_dfg``, ``u_env_dominant``, ``u_env_irradiance`` (texture units from ``first_unit``
        on), ``u_env_levels`` (float) and ``u_sh`` (vec3[9]); with a sun its uniforms and those of
        the other lights taken out (``u_env_light_*``). Returns the next free texture unit."""
        unit = first_unit
        for name, tex in (("u_env_radiance", self.radiance),
                          ("u_env_prefiltered", self.prefiltered),
                          ("u_env_dfg", self.dfg),
                          ("u_env_dominant", self.dominant),
                          ("u_env_irradiance", self.irradiance)):
            if tex is not None and name in program:
                tex.use(location=unit)
                program[name].value = unit
                unit += 1
        if "u_env_levels" in program:
            program["u_env_levels"].value = float(self.levels)
        if "u_sh" in program:
            program["u_sh"].write(np.ascontiguousarray(self.sh, dtype=np.float32).tobytes())
        if "u_env_below" in program:  # the ssao-env student's input (env_below)
            if self.env_below is None:
                raise RuntimeError("an IBL without env_below cannot bind u_env_below")
            program["u_env_below"].value = float(self.env_below)
        if self.sun is not None:  # SUN_LIGHT (a pass without a specular lobe reads no chain)
            # every light's specular share uses the widest light's radius: the chain mix
            # (ibl_specular_radiance_sun) holds one weight for all of them
            radius = max(float(li.angular_radius) for li in self.lights)
            for name, value in (("u_sun_direction", self.sun.direction),
                                ("u_sun_irradiance", self.sun.irradiance),
                                ("u_sun_radius", radius),
                                ("u_sun_disc_radius", float(self.sun.angular_radius))):
                if name in program:
                    program[name].value = value
            others = self.lights[1:]
            if others and "u_env_light_direction" in program:
                program["u_env_light_direction"].write(
                    np.array([li.direction for li in others], np.float32).tobytes())
                program["u_env_light_irradiance"].write(
                    np.array([li.irradiance for li in others], np.float32).tobytes())
                program["u_env_light_radius"].write(
                    np.array([li.angular_radius for li in others], np.float32).tobytes())
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
        """Free the textures this IBL owns (none for an IBL of an EnvironmentStore)."""
        for tex in self._owned:
            tex.release()
        self._owned = []
        for name in ("radiance", "prefiltered", "dfg", "dominant", "irradiance"):
            setattr(self, name, None)
        self.full_prefiltered = None


def irradiance_texture(ctx, irradiance: np.ndarray):
    """The RGBA32F texture of an irradiance map ``[h, w, 3]`` (:func:`viewer.environment.irradiance.
    irradiance_map`): LINEAR, REPEAT in u, CLAMP in v (``irradiance_lookup`` in lib/ibl.glsl)."""
    h, w = irradiance.shape[:2]
    rgba = np.concatenate([np.asarray(irradiance[..., :3], np.float32),
                           np.ones((h, w, 1), np.float32)], axis=2)
    tex = ctx.texture((w, h), 4, np.ascontiguousarray(rgba).tobytes(), dtype="f4")
    tex.filter = (moderngl.LINEAR, moderngl.LINEAR)
    tex.repeat_x = True
    tex.repeat_y = False
    return tex


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


def sh_project(programs, texture) -> np.ndarray:
    """9 radiance SH coefficients ``[9, 3]`` float32 of level 0 of the RGBA32F equirect
    ``texture`` (``ibl_sh.comp`` tile sums, reduced here in float64)."""
    ctx = programs.ctx
    w, h = texture.size
    sh_prog = programs.compute("passes/ibl_sh.comp")
    runs = h * ((w + _SH_RUN - 1) // _SH_RUN)  # one invocation per run of 64 texels of a row
    partial = ctx.buffer(reserve=runs * 27 * 4)
    try:
        texture.bind_to_image(0, read=True, write=False, level=0)
        partial.bind_to_storage_buffer(1)
        sh_prog.run((runs + 63) // 64)
        ctx.memory_barrier()
        tiles = np.frombuffer(partial.read(), dtype=np.float32).reshape(runs, 9, 3)
    finally:
        partial.release()
    return tiles.astype(np.float64).sum(axis=0).astype(np.float32)


def build_luts(programs, options: IBLOptions = IBLOptions()) -> tuple:
    """``(dfg, dominant)``: the split-sum DFG LUT (RG32F) and the dominant-direction LUT (R32F),
    ``options.dfg_size`` square, from ``ibl_dfg.comp`` (independent of the environment: an
    :class:`viewer.environment.store.EnvironmentStore` builds them once)."""
    ctx = programs.ctx
    n = int(options.dfg_size)
    dfg = ctx.texture((n, n), 2, dtype="f4")
    dominant = ctx.texture((n, n), 1, dtype="f4")
    try:
        for tex in (dfg, dominant):
            tex.repeat_x = False
            tex.repeat_y = False
            tex.filter = (moderngl.LINEAR, moderngl.LINEAR)
        dfg_prog = programs.compute("passes/ibl_dfg.comp")
        dfg_prog["u_samples"].value = int(options.dfg_samples)
        dfg.bind_to_image(0, read=False, write=True, level=0)
        dominant.bind_to_image(1, read=False, write=True, level=0)
        dfg_prog.run(_groups(n), _groups(n))
        ctx.memory_barrier()
    except BaseException:
        dfg.release()
        dominant.release()
        raise
    return dfg, dominant


