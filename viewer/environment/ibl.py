"""Image-based lighting precomputation (compute shaders in ``shaders/passes/ibl_*.comp``).

:func:`build_ibl` turns an equirect environment ``[H, W, 3]`` (from
:func:`viewer.environment.maps.load_environment`) into what the shading passes sample:

* ``radiance``: RGBA32F equirect texture with a box-filtered mip chain made by our own
  ``ibl_downsample.comp`` (level k is ``W >> k`` by ``max(H >> k, 1)``, down to 1x1).
* ``prefiltered``: RGBA32F chain of ``levels`` mips; level k >= 1 holds the radiance prefiltered
  with the GGX lobe at alpha = ``2^(k - (levels - 1))`` (:func:`prefilter_roughness`; level 0
  is the radiance itself). ``IBLOptions.prefilter_method`` says how: ``"convolution"`` (the
  default) sums every texel exactly on the CPU (:mod:`viewer.environment.prefilter`) at a working width and
  composes the levels on the GPU with the sun added at full resolution (:mod:`viewer.environment.ibl_build`);
  a map narrower than ``prefilter_width`` gets a chain that wide. ``"fis"`` (the method before)
  is filtered importance sampling (Krivanek & Colbert 2008) with Hammersley points
  (``ibl_prefilter``), in compute, one full chain per IBL.
* ``sh``: 9 radiance SH coefficients ``[9, 3]`` float32 (``ibl_sh.comp`` tile sums weighted by the
  exact texel solid angle, reduced on the CPU in float64): kept for analyses; the passes read
  ``irradiance`` instead.
* ``irradiance``: RGBA32F equirect map of the exact cosine convolution of the environment (the
  residual's with a sun), :func:`viewer.environment.irradiance.irradiance_map`, looked up per normal by
  ``irradiance_lookup`` in ``lib/ibl.glsl``: the diffuse term of every model.
* ``dfg``: RG32F split-sum LUT, x = n.v, y = perceptual roughness (``ibl_dfg.comp``).
* ``dominant``: R32F LUT on the same grid, the specular dominant direction's lerp factor
  (``ibl_dfg.comp``; ``specular_dominant_direction`` in ``lib/ibl.glsl``).

All sampled textures use GL_REPEAT in u and CLAMP_TO_EDGE in v (the DFG LUT clamps both) and
linear(-mipmap-linear) filtering. Environment intensity and rotation are *not* baked: they are
shader uniforms. Torch twins of every pass are in :mod:`learned.twins.ibl_precompute`, of
``lib/ibl.glsl`` in :mod:`learned.twins.ibl`.
"""
from __future__ import annotations

import math

import numpy as np

from .ibl_build import build_environment_ibls
from .ibl_core import (  # noqa: F401 - re-exported: viewer.environment.ibl is the public module
    _GROUP,
    _SH_RUN,
    IBL,
    PREFILTER_METHODS,
    IBLOptions,
    _downsample_chain,
    _env_texture,
    _groups,
    _validate,
    build_luts,
    irradiance_texture,
    mip_sizes,
    prefilter_lod,
    prefilter_roughness,
    prefilter_samples,
    sh_project,
)
from .irradiance import IRRADIANCE_WIDTH, env_below, irradiance_map
from .sun import extract_lights


def build_ibl(programs, env: np.ndarray, options: IBLOptions = IBLOptions(),
              sun=None, residual: np.ndarray | None = None, lights: tuple = ()) -> IBL:
    """Precompute the IBL resources of ``env`` (``[H, W, 3]`` float32 linear radiance, H = W / 2,
    W a power of two) on the GPU of ``programs.ctx``; the IBL owns its textures.

    With ``sun`` and ``residual`` (:func:`viewer.environment.sun.extract_sun` of ``env``), the prefiltered
    chain and the SH are computed from ``residual``, the environment without its sun, which the
    passes then shade analytically; the radiance chain (background, Monte-Carlo models) keeps
    ``env``. With the ``"convolution"`` method that IBL also owns the whole environment's chain
    (``full_prefiltered``), made from the same convolution with the sun added back; without
    ``residual`` the environment's compact sun is found here (the chain is the residual's
    convolution plus the sun, as :class:`viewer.environment.store.EnvironmentStore` builds it).
    ``lights``: every light ``residual`` leaves out (:func:`viewer.environment.sun.extract_lights`; default
    ``(sun,)``)."""
    if options.prefilter_method == "convolution":
        plain_only = residual is None
        if plain_only:
            residual, lights = extract_lights(_validate(env))
            sun = lights[0] if lights else None
            if sun is None:
                residual = None
        built = build_environment_ibls(programs, env, options, residual=residual, sun=sun,
                                       sunless=not plain_only, lights=lights)
        ibl = built.plain if plain_only or built.sunless is None else built.sunless
        ibl._owned = built.take_textures()
        return ibl
    return _build_ibl_fis(programs, env, options, sun, residual, lights)


def _build_ibl_fis(programs, env: np.ndarray, options: IBLOptions, sun=None,
                   residual: np.ndarray | None = None, lights: tuple = ()) -> IBL:
    """``build_ibl`` with ``prefilter_method = "fis"``: filtered importance sampling in compute."""
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
    irradiance = None
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

        # (c) SH projection, (d) the LUTs
        sh = sh_project(programs, source)
        irr = irradiance_map(env if residual is None else res, max(4, min(IRRADIANCE_WIDTH, w)))
        irradiance = irradiance_texture(ctx, irr)
        dfg, dominant = build_luts(programs, options)
    except BaseException:
        for tex in (radiance, prefiltered, dfg, dominant, irradiance):
            if tex is not None:
                tex.release()
        raise
    finally:
        if source is not None and source is not radiance:
            source.release()
    taken = lights if residual is not None else ()
    return IBL(radiance, prefiltered, dfg, sh, levels, options, dominant,
               sun=sun if residual is not None else None, irradiance=irradiance,
               lights=taken, env_below=env_below(irr, taken))
