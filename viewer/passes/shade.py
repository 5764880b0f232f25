"""The lighting pass: G-buffer + environment -> linear radiance, one program per shading model.

The program variant is chosen by prepended defines from the model and the render settings
(multiscatter, AO, background), so toggles cost a cached program switch, not a branch per pixel.
"""
from __future__ import annotations

import math

import numpy as np

from ..camera import Camera
from ..gbuffer import GBufferLayout
from ..models import model_info
from ..neural import NeuralWeights, model_network
from ..neural import virtual_files as neural_virtual_files
from ..scene import DirectionalLight, RenderSettings
from . import FullscreenDraw, bind_gbuffer, set_uniform as _set


SAMPLING_IDS = {"uniform": 0, "cosine": 1, "env": 2, "brdf": 3, "mis": 4}
MIS_POWERS = {"balance": 1, "power": 2}


def shade_defines(model: str, settings: RenderSettings,
                  light: DirectionalLight | None = None) -> dict[str, int]:
    """The lighting pass's defines. ``light``: the scene's ``[light]``; models that shade it get
    ``LIGHT_DIRECTIONAL`` 1 (0 without one compiles the term out); the others never see it
    (:attr:`viewer.models.ModelInfo.directional_light`)."""
    defines = {"BACKGROUND_ENVIRONMENT": int(settings.background == "environment")}
    if model_info(model).directional_light == "shaded":
        defines["LIGHT_DIRECTIONAL"] = int(light is not None)
    if model in ("ggx_split_sum", "blinn_phong", "ggx_mc", "neural"):
        defines["USE_AO"] = int(settings.ao)
        defines["USE_SSAO"] = int(settings.ssao)
    if model in ("ggx_split_sum", "ggx_mc"):
        defines["MULTISCATTER"] = int(settings.multiscatter)
    if model == "ggx_mc":
        defines["SAMPLING"] = SAMPLING_IDS[settings.sampling]
        defines["MIS_POWER"] = MIS_POWERS[settings.mis_heuristic]
    if model == "neural_teacher":  # the teacher has no BRDF pdf: brdf and mis sample the environment
        defines["SAMPLING"] = min(SAMPLING_IDS[settings.sampling], 2)
    return defines


class ShadePass:
    def __init__(self, programs, layout: GBufferLayout):
        self.programs = programs
        self.ctx = programs.ctx
        self.layout = layout
        self._draw = FullscreenDraw(self.ctx)
        self._weights: dict[tuple, NeuralWeights] = {}  # (checkpoint, storage) -> uploaded data

    def _bind_weights(self, prog, settings: RenderSettings, unit: int) -> int:
        """Upload (once) and bind the weight data of a neural model's buffered storage."""
        found = model_network(settings.model, settings)
        if found is None or found[1].data is None:
            return unit
        net, code = found
        key = (net.checkpoint, code.storage, code.symbol)
        if key not in self._weights:
            self._weights[key] = NeuralWeights(self.ctx, code)
        return self._weights[key].bind(prog, unit)

    def _program(self, model: str, settings: RenderSettings, extra: dict | None = None,
                 light: DirectionalLight | None = None):
        info = model_info(model)
        return self.programs.graphics("passes/fullscreen.vert", info.pass_file,
                                      defines={**shade_defines(model, settings, light),
                                               **(extra or {})},
                                      virtual={**self.layout.virtual_files(),
                                               **neural_virtual_files(model, settings)})

    def run(self, gbuffer_textures: dict, out_fbo, camera: Camera, ibl, environment,
            settings: RenderSettings, env_sampling=None, ssao=None,
            sample_range: tuple[int, int] = (0, 1), defines: dict | None = None,
            light: DirectionalLight | None = None) -> None:
        """Shade into ``out_fbo`` (an RGBA32F target of the camera's size).

        ``env_sampling``: the :class:`~viewer.envsampling.EnvSampling` of sampling models;
        ``ssao``: the occlusion texture when ``settings.ssao``; ``sample_range``: (first index,
        count) of the Monte-Carlo samples this call averages (sampling models only);
        ``defines``: the scene's specialisation (:mod:`viewer.specialize`), e.g. SPECULAR_LOBE;
        ``light``: the scene's directional light (``None``: none)."""
        prog = self._program(settings.model, settings, defines, light)
        unit = bind_gbuffer(prog, gbuffer_textures)
        unit = ibl.bind(prog, unit)
        unit = self._bind_weights(prog, settings, unit)
        if env_sampling is not None:
            unit = env_sampling.bind(prog, unit)
        if ssao is not None and "u_ssao" in prog:
            ssao.use(unit)
            prog["u_ssao"].value = unit
            unit += 1
        _set(prog, "u_sample_start", int(sample_range[0]))
        _set(prog, "u_sample_count", int(sample_range[1]))
        _set(prog, "u_seed", int(settings.seed))
        basis = camera.basis()  # rows: right, up, back
        _set(prog, "u_camera_to_world", np.ascontiguousarray(basis.astype(np.float32)).tobytes())
        _set(prog, "u_tan_half_fov", camera.tan_half_fov())
        _set(prog, "u_resolution", (float(camera.width), float(camera.height)))
        _set(prog, "u_env_intensity", float(environment.intensity))
        _set(prog, "u_env_rotation", math.radians(environment.rotation_deg))
        if light is not None:  # world space: the environment's rotation does not turn it
            _set(prog, "u_light_direction", tuple(float(x) for x in light.direction))
            _set(prog, "u_light_irradiance", tuple(float(x) for x in light.irradiance))
        out_fbo.use()
        self._draw(prog)

    def release(self) -> None:
        self._draw.release()
        for w in self._weights.values():
            w.release()
        self._weights.clear()
