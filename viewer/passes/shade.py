"""The lighting pass: G-buffer + environment -> linear radiance, one program per shading model.

The program variant is a :class:`~viewer.models.ShadeVariant`: prepended defines from the model's
record, the render settings (multiscatter, AO, background, sampling) and the scene's content, so
toggles cost a cached program switch, not a branch per pixel.
"""
from __future__ import annotations

import math

import numpy as np

from ..cache import BoundedCache, CacheStats
from ..camera import Camera
from ..cascades import MAX_CASCADES, ShadowCascades
from ..gbuffer import GBufferLayout
from ..models import ShadeVariant, model_info
from ..neural import NeuralWeights, model_network, virtual_files
from ..lights import Light, as_lights, light_uniforms
from ..settings import RenderSettings
from ..shadows import SHADOW_ORTHO
from . import FullscreenDraw, bind_gbuffer
from . import set_uniform as _set


def shade_defines(model: str, settings: RenderSettings,
                  light: Light | tuple[Light, ...] | None = None) -> dict[str, int]:
    """The lighting pass's defines for ``model`` (no specialisation: every lobe on); see
    :meth:`viewer.models.ShadingModel.variant`."""
    return model_info(model).variant(settings, light).defines


def set_view_and_lighting(prog, camera, environment, light) -> None:
    """The view and lighting uniforms of ``passes/deferred.glsl`` and ``passes/lights.glsl``
    (camera frame and position, resolution, environment intensity and rotation, the punctual
    lights' arrays: ``light`` is a :class:`~viewer.lights.Light`, a tuple of them or None), for
    every pass that includes them: the lighting passes and the forward pass of transparent
    surfaces."""
    basis = camera.basis()  # rows: right, up, back
    _set(prog, "u_camera_to_world", np.ascontiguousarray(basis.astype(np.float32)).tobytes())
    _set(prog, "u_tan_half_fov", camera.tan_half_fov())
    _set(prog, "u_resolution", (float(camera.width), float(camera.height)))
    _set(prog, "u_env_intensity", float(environment.intensity))
    _set(prog, "u_env_rotation", math.radians(environment.rotation_deg))
    _set(prog, "u_camera_position", tuple(float(x) for x in camera.position))
    # world space: the environment's rotation does not turn them
    for name, data in light_uniforms(light).items():
        _set(prog, name, data)


def shadow_lens(frame, size: float) -> tuple[float, float, float, float]:
    """``lib/shadow.glsl``'s lens of a shadow ``frame`` (kind, light-size scale, near, depth
    range; see ``shadow_penumbra_uv``): ``size`` is a directional light's angular radius
    (radians) or a point or spot light's radius (world units)."""
    if frame.kind == SHADOW_ORTHO:
        return (float(SHADOW_ORTHO), math.tan(min(max(size, 0.0), 0.3)) / max(frame.extent),
                0.0, float(frame.depth_range))
    # perspective: uv per unit of tangent is 1 / (2 tan(half-angle)) = 1 / extent
    return (float(frame.kind), float(size) / max(frame.extent), float(frame.near),
            float(frame.depth_range))


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
        self._empty_shadow = None  # the 1x1 map bound for lights without a shadow

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
            sun_shadow: tuple | None = None) -> None:
        """Shade into ``out_fbo`` (an RGBA32F target of the camera's size).

        ``env_sampling``: the :class:`~viewer.envsampling.EnvSampling` of sampling models;
        ``ssao``: the occlusion texture when ``settings.ssao.enabled``; ``sample_range``: (first index,
        count) of the Monte-Carlo samples this call averages (sampling models only);
        ``variant``: the program (:func:`viewer.specialize.specialise`; default: the model's
        unspecialised variant); ``light``: the lights to shade (``Scene.light``: a tuple, or ``None``);
        ``shadows``: light index -> (shadow map texture, :class:`~viewer.shadows.ShadowFrame` or
        :class:`~viewer.shadows.ShadowCube` or :class:`~viewer.cascades.ShadowCascades`, the
        light's size (angular radius in radians, or radius in world units), normal offset (world units; per unit of distance for perspective
        and cube maps)) for the lights that cast one;
        ``sun_shadow``: the same for the environment's sun (SUN_SHADOW)."""
        if variant is None:
            variant = model_info(settings.model).variant(settings, light)
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
        unit = self._bind_shadows(prog, light, shadows or {}, unit)
        unit = self._bind_env_light_shadows(prog, shadows or {}, unit)
        if "u_sun_shadow_map" in prog:
            if sun_shadow is None:  # nothing casts one (an image stack alone): a map of depth 1
                self._no_shadow().use(unit)
                # every point maps to (-1, -1, -1): outside the map, so lit (shadow_visibility)
                matrix = np.zeros((4, 4))
                matrix[3] = (-1.0, -1.0, -1.0, 1.0)  # the translation column (column-major)
                normal, params = np.eye(3), (0.0, 1.0, 1.0, 0.0)
            else:
                tex, frame, angle, offset = sun_shadow
                tex.use(unit)
                matrix, normal = frame.matrix.T, np.linalg.inv(frame.matrix[:3, :3])
                params = (float(angle), float(frame.depth_range), float(max(frame.extent)),
                          float(offset))
            prog["u_sun_shadow_map"].value = unit
            unit += 1
            _set(prog, "u_sun_shadow_matrix", np.ascontiguousarray(matrix, np.float32).tobytes())
            _set(prog, "u_sun_shadow_normal_matrix",
                 np.ascontiguousarray(normal, np.float32).tobytes())
            _set(prog, "u_sun_shadow_params", params)
            if "u_sun_shadow_cascade_count" in prog:  # SUN_CASCADES: the sun's map is cascaded
                frame = sun_shadow[1]
                _set(prog, "u_sun_shadow_cascades", frame.uniforms().tobytes())
                _set(prog, "u_sun_shadow_cascade_count", int(frame.count))
        _set(prog, "u_sample_start", int(sample_range[0]))
        _set(prog, "u_sample_count", int(sample_range[1]))
        _set(prog, "u_seed", int(settings.mc.seed))
        _set(prog, "u_contact_length", float(settings.shadow.contact_length))
        set_view_and_lighting(prog, camera, environment, light)
        out_fbo.use()
        self._draw(prog)

    def _bind_shadows(self, prog, light, shadows: dict, unit: int) -> int:
        """The shadow maps of ``lights.glsl`` (LIGHT_SHADOWS): one sampler per light, a 1x1 map
        of depth 1 where a light has none (its lens then says so)."""
        if "u_shadow_lens" not in prog:
            return unit
        n = len(as_lights(light))
        matrices = np.zeros((n, 4, 4), np.float32)
        lenses = np.zeros((n, 4), np.float32)
        offsets = np.zeros(n, np.float32)
        units = np.zeros(n, np.int32)
        cascades = np.zeros((n, MAX_CASCADES, 4), np.float32)
        counts = np.zeros(n, np.int32)  # 0: one map (shadow_light_visibility)
        for i in range(n):
            entry = shadows.get(i)
            tex = self._no_shadow() if entry is None else entry[0]
            tex.use(unit)
            units[i] = unit
            unit += 1
            if entry is not None:
                _, frame, size, offset = entry
                matrices[i] = frame.matrix.T  # column-major for GLSL
                lenses[i] = shadow_lens(frame, size)
                offsets[i] = offset
                if isinstance(frame, ShadowCascades):
                    cascades[i], counts[i] = frame.uniforms(), frame.count
        _set(prog, "u_shadow_map", units.tobytes())
        _set(prog, "u_shadow_matrix", matrices.tobytes())
        _set(prog, "u_shadow_lens", lenses.tobytes())
        _set(prog, "u_shadow_offset", offsets.tobytes())
        if "u_shadow_cascade_count" in prog:  # LIGHT_CASCADES
            _set(prog, "u_shadow_cascades", cascades.tobytes())
            _set(prog, "u_shadow_cascade_count", counts.tobytes())
        return unit

    def _bind_env_light_shadows(self, prog, shadows: dict, unit: int) -> int:
        """The environment's other lights' maps (passes/env_lights.glsl, ``shadows["env<k>"]``,
        as ``sun_shadow``); a map of depth 1 mapped outside (lit) where one is missing."""
        if "u_env_light_shadow_params" not in prog:
            return unit
        n = prog["u_env_light_shadow_params"].array_length
        matrices = np.zeros((n, 4, 4), np.float32)
        matrices[:, 3] = (-1.0, -1.0, -1.0, 1.0)  # no map: every point outside it, lit
        normals = np.tile(np.eye(3, dtype=np.float32), (n, 1, 1))
        params = np.tile(np.array([0.0, 1.0, 1.0, 0.0], np.float32), (n, 1))
        units = np.zeros(n, np.int32)
        for k in range(n):
            entry = shadows.get(f"env{k}")
            (self._no_shadow() if entry is None else entry[0]).use(unit)
            units[k], unit = unit, unit + 1
            if entry is not None:
                _, frame, angle, offset = entry
                matrices[k] = frame.matrix.T
                normals[k] = np.linalg.inv(frame.matrix[:3, :3])
                params[k] = (angle, frame.depth_range, max(frame.extent), offset)
        _set(prog, "u_env_light_shadow_map", units.tobytes())
        _set(prog, "u_env_light_shadow_matrix", matrices.tobytes())
        _set(prog, "u_env_light_shadow_normal_matrix", normals.tobytes())
        _set(prog, "u_env_light_shadow_params", params.tobytes())
        return unit

    def _no_shadow(self):
        if self._empty_shadow is None:
            self._empty_shadow = self.ctx.texture((1, 1), 1, np.ones(1, np.float32).tobytes(),
                                                  dtype="f4")
            self._empty_shadow.filter = (self.ctx.NEAREST, self.ctx.NEAREST)
        return self._empty_shadow

    def stats(self) -> dict[str, CacheStats]:
        """Each cache of this pass (``Renderer.memory`` gathers them)."""
        return {"neural weights": self.weights.stats(),
                "shade vertex arrays": self._draw.stats()}

    def release(self) -> None:
        self._draw.release()
        self.weights.clear()
        if self._empty_shadow is not None:
            self._empty_shadow.release()
            self._empty_shadow = None
