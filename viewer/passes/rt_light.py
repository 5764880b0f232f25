"""The real-time tier's rays (``passes/rt_light.frag``), their temporal accumulation
(``passes/rt_accumulate.frag``) and edge-avoiding a-trous filter (``passes/rt_filter.frag``): what
``[render] raytrace`` gives the rasterised models (RT_LIGHT: the environment's visibility and one
bounce, ``passes/rt_light.glsl``). The frame graph declares the passes
(:mod:`viewer.graph.raytrace`) and owns the targets; this module draws."""
from __future__ import annotations

from ..gbuffer import GBufferLayout
from . import FullscreenDraw, bind_gbuffer, set_deferred_camera
from . import set_uniform as _set
from .shade import set_view_and_lighting

# the shading variant's defines the ray pass compiles with (the rest do not change its rays)
TRACE_DEFINES = ("SPECULAR_LOBE", "SUN_LIGHT", "RT_SUN", "ENV_LIGHTS", "LIGHT_COUNT",
                 "LIGHT_POSITIONAL", "MULTISCATTER")
# a-trous iterations: a 29-pixel footprint, whatever the history's age (widening it for a young
# history made the first frames of a still view jump: 5 % flicker against 3 %)
FILTER_STEPS = (1, 2, 4)

SIGMA_Z = 0.02  # relative depth difference per pixel of step that weighs a tap down by 1/e
SIGMA_N = 64.0  # the normals' agreement exponent


class RTLightPass:
    """Draws the ray pass, the accumulation and the filter for one G-buffer layout."""

    def __init__(self, programs, layout: GBufferLayout):
        self.programs = programs
        self.ctx = programs.ctx
        self.layout = layout
        self._draw = FullscreenDraw(self.ctx)

    def _program(self, frag: str, defines: dict | None = None):
        return self.programs.graphics("passes/fullscreen.vert", frag, defines=defines or {},
                                      virtual=self.layout.virtual_files())

    def _target(self, out_fbo) -> None:
        out_fbo.use()
        self.ctx.viewport = (0, 0) + tuple(out_fbo.size)  # low resolution at ray_scale > 1

    def trace(self, gbuffer_textures: dict, out_fbo, camera, ibl, sampling, environment,
              settings, variant_defines: dict, light, trace, frame_index: int,
              sun_only: bool = False) -> None:
        """This frame's rays into ``out_fbo`` (three RGBA32F attachments; at ``ray_scale`` k > 1
        one texel per k x k pixels); ``sampling``: the environment's distribution
        (:class:`~viewer.environment.sampling.EnvSampling`). ``sun_only``: only the sun's ray,
        for every pixel of the frame, into ``out_fbo``'s first attachment (``RT_SUN_PASS``)."""
        defines = {k: v for k, v in variant_defines.items() if k in TRACE_DEFINES}
        defines["RT_SCALE"] = 1 if sun_only else int(settings.raytrace.scale)
        if sun_only:
            defines["RT_SUN_PASS"] = 1
        defines.update(trace.defines)  # what the traced materials use (RT_MASKS, RT_MAPS)
        prog = self._program("passes/rt_light.frag", defines)
        unit = bind_gbuffer(prog, gbuffer_textures)
        unit = ibl.bind(prog, unit)
        unit = sampling.bind(prog, unit)
        trace.bind(prog, unit)
        _set(prog, "u_frame", int(frame_index))
        _set(prog, "u_seed", int(settings.mc.seed))
        _set(prog, "u_rt_rays", int(settings.raytrace.rays))
        set_view_and_lighting(prog, camera, environment, light)
        self._target(out_fbo)
        self._draw(prog)

    def accumulate(self, new: list, old: list, out_fbo, weight: float) -> None:
        """The running mean: ``out = mix(old, new, weight)`` for each of the three targets."""
        prog = self._program("passes/rt_accumulate.frag")
        for k in range(3):
            new[k].use(k)
            _set(prog, f"u_new{k}", k)
            old[k].use(3 + k)
            _set(prog, f"u_old{k}", 3 + k)
        _set(prog, "u_weight", float(weight))
        self._target(out_fbo)
        self._draw(prog)

    def filter(self, gbuffer_textures: dict, source: list, out_fbo, step: int, camera,
               scale: int = 1) -> None:
        """One a-trous iteration of hole size ``step`` from ``source`` into ``out_fbo`` (at
        ``scale`` k > 1 the low-resolution targets, a texel per k x k pixels)."""
        prog = self._program("passes/rt_filter.frag", {"RT_SCALE": int(scale)})
        unit = bind_gbuffer(prog, gbuffer_textures)
        set_deferred_camera(prog, camera)
        for k in range(3):
            source[k].use(unit + k)
            _set(prog, f"u_in{k}", unit + k)
        _set(prog, "u_step", int(step))
        _set(prog, "u_sigma_z", SIGMA_Z)
        _set(prog, "u_sigma_n", SIGMA_N)
        self._target(out_fbo)
        self._draw(prog)

    def upsample(self, gbuffer_textures: dict, low: list, out_fbo, camera, scale: int,
                 sun=None) -> None:
        """The three low-resolution targets ``low`` (``scale`` k > 1) to full resolution in
        ``out_fbo`` (``passes/rt_upsample.frag``: SSAO's joint bilateral upsampling); ``sun``: the
        full-resolution texture of the sun's visibility, target 1's alpha instead of the
        upsampled one."""
        prog = self._program("passes/rt_upsample.frag", {"RT_SCALE": int(scale),
                                                         "RT_SUN": int(sun is not None)})
        unit = bind_gbuffer(prog, gbuffer_textures)
        for k in range(3):
            low[k].use(unit + k)
            _set(prog, f"u_low{k}", unit + k)
        if sun is not None:
            sun.use(unit + 3)
            _set(prog, "u_sun", unit + 3)
        set_deferred_camera(prog, camera)
        self._target(out_fbo)
        self._draw(prog)

    def stats(self) -> dict:
        return {"rt vertex arrays": self._draw.stats()}

    def release(self) -> None:
        self._draw.release()
