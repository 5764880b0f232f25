"""The lighting pass: G-buffer + environment -> linear radiance, one program per shading model.

The program variant is a :class:`~viewer.models.ShadeVariant`: prepended defines from the model's
record, the render settings (multiscatter, AO, background, sampling) and the scene's content, so
toggles cost a cached program switch, not a branch per pixel.
"""
from __future__ import annotations

import math

from ..cache import BoundedCache, CacheStats
from ..gbuffer import GBufferLayout
from ..lighting.lights import Light, light_uniforms
from ..models import ShadeVariant, model_info
from ..neural import NeuralWeights, model_network, virtual_files
from ..scene.camera import Camera
from ..scene.settings import RenderSettings
from . import FullscreenDraw, bind_gbuffer, set_deferred_camera
from .ground import Catcher, ground_uniforms
from . import set_uniform as _set
from .shadow_bindings import ShadowBindings


def shade_defines(model: str, settings: RenderSettings,
                  light: Light | tuple[Light, ...] | None = None) -> dict[str, int]:
    """The lighting pass's defines for ``model`` (no specialisation: every lobe on); see
    :meth:`viewer.models.ShadingModel.variant`."""
    return model_info(model).variant(settings, light).defines


def set_view_and_lighting(prog, camera, environment, light) -> None:
    """The view and lighting uniforms of ``passes/deferred.glsl`` and ``passes/lights.glsl``
    (camera frame and position, resolution, environment intensity and rotation, the punctual
    lights' arrays: ``light`` is a :class:`~viewer.lighting.lights.Light`, a tuple of them or None), for
    every pass that includes them: the lighting passes and the forward pass of transparent
    surfaces."""
    set_deferred_camera(prog, camera)
    _set(prog, "u_env_intensity", float(environment.intensity))
    _set(prog, "u_env_rotation", math.radians(environment.rotation_deg))
    _set(prog, "u_camera_position", tuple(float(x) for x in camera.position))
    # world space: the environment's rotation does not turn them
    for name, data in light_uniforms(light).items():
        _set(prog, name, data)


class ShadePass:
    MAX_WEIGHTS = 4  # networks whose buffered weights stay uploaded (least recently used freed)

    def __init__(self, programs, layout: GBufferLayout):
        self.programs = programs
        self.ctx = programs.ctx
        self.layout = layout
        self._draw = FullscreenDraw(self.ctx)
        # (checkpoint, storage, symbol) -> uploaded weight data (bound right after the lookup)
        self.weights = BoundedCache("neural weights", max_items=self.MAX_WEIGHTS,
                                    release=lambda w: w.release())
        self.shadow_maps = ShadowBindings(self.ctx)

    def _bind_weights(self, prog, found, unit: int) -> int:
        """Upload (once) and bind the weight data of a neural model's buffered storage."""
        if found is None or found[1].data is None:
            return unit
        net, code = found
        weights = self.weights.get_or_create((net.checkpoint, code.storage, code.symbol),
                                             lambda: NeuralWeights(self.ctx, code),
                                             nbytes=lambda w: w.nbytes)
        return weights.bind(prog, unit)

    def _program(self, variant: ShadeVariant, found):
        """The variant's program; ``found``: the neural model's (network, generated code)."""
        virtual = {**self.layout.virtual_files(), **virtual_files(found)}
        return self.programs.graphics("passes/fullscreen.vert", model_info(variant.model).pass_file,
                                      defines=variant.defines, virtual=virtual)

    def run(self, gbuffer_textures: dict, out_fbo, camera: Camera, ibl, environment,
            settings: RenderSettings, env_sampling=None, ssao=None,
            sample_range: tuple[int, int] = (0, 1), variant: ShadeVariant | None = None,
            light: Light | tuple[Light, ...] | None = None, shadows: dict | None = None,
            sun_shadow: tuple | None = None, trace=None, rt_light=(),
            ground: Catcher | None = None) -> None:
        """Shade into ``out_fbo`` (an RGBA32F target of the camera's size).

        ``env_sampling``: the :class:`~viewer.environment.sampling.EnvSampling` of sampling models;
        ``ssao``: the occlusion texture when ``settings.ssao.enabled``; ``sample_range``: (first index,
        count) of the Monte-Carlo samples this call averages (sampling models only);
        ``variant``: the program (:func:`viewer.specialize.specialise`; default: the model's
        unspecialised variant); ``light``: the lights to shade (``Scene.light``: a tuple, or ``None``);
        ``shadows``: light index -> (shadow map texture, :class:`~viewer.lighting.shadow_frames.ShadowFrame` or
        :class:`~viewer.lighting.shadow_frames.ShadowCube` or :class:`~viewer.lighting.cascades.ShadowCascades`, the
        light's size (angular radius in radians, or radius in world units), normal offset (world units; per unit of distance for perspective
        and cube maps)) for the lights that cast one;
        ``sun_shadow``: the same for the environment's sun (SUN_SHADOW); ``trace``: the scene's
        :class:`~viewer.raytrace.upload.TraceBuffers` for models that trace rays; ``rt_light``:
        the real-time tier's three filtered textures (RT_LIGHT); ``ground``: the scene's
        shadow-catcher plane (:func:`viewer.passes.ground.scene_catcher`), or None."""
        if variant is None:
            variant = model_info(settings.model).variant(settings, light)
        if trace is not None and "RT_MASKS" in trace.defines:
            # a tracing model (path) compiles out the alpha test and the map lookups that no
            # traced material uses, as the rays pass does (TraceBuffers.defines)
            variant = variant.with_defines(trace.defines)
        found = model_network(settings.model, settings)  # the weights file, looked up once
        prog = self._program(variant, found)
        unit = bind_gbuffer(prog, gbuffer_textures)
        unit = ibl.bind(prog, unit)
        unit = self._bind_weights(prog, found, unit)
        if env_sampling is not None:
            unit = env_sampling.bind(prog, unit)
        if ssao is not None and "u_ssao" in prog:
            ssao.use(unit)
            prog["u_ssao"].value = unit
            unit += 1
        unit = self.shadow_maps.bind(prog, light, shadows or {}, sun_shadow, unit)
        if trace is not None:
            unit = trace.bind(prog, unit)
        for k, tex in enumerate(rt_light):
            if f"u_rt_light{k}" in prog:
                tex.use(unit)
                prog[f"u_rt_light{k}"].value = unit
                unit += 1
        _set(prog, "u_max_depth", int(settings.mc.max_depth))
        _set(prog, "u_sample_start", int(sample_range[0]))
        _set(prog, "u_sample_count", int(sample_range[1]))
        _set(prog, "u_seed", int(settings.mc.seed))
        _set(prog, "u_contact_length", float(settings.shadow.contact_length))
        set_view_and_lighting(prog, camera, environment, light)
        sunless = bool(variant.defines.get("SUN_LIGHT"))
        for name, value in ground_uniforms(ground, camera, ibl, environment, light,
                                           settings.model, sunless).items():
            _set(prog, name, value)
        out_fbo.use()
        self._draw(prog)

    def stats(self) -> dict[str, CacheStats]:
        """Each cache of this pass (``Renderer.memory`` gathers them)."""
        return {"neural weights": self.weights.stats(),
                "shade vertex arrays": self._draw.stats()}

    def release(self) -> None:
        self._draw.release()
        self.weights.clear()
        self.shadow_maps.release()
