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
from ..scene import RenderSettings
from . import FullscreenDraw


def shade_defines(model: str, settings: RenderSettings) -> dict[str, int]:
    defines = {"BACKGROUND_ENVIRONMENT": int(settings.background == "environment")}
    if model in ("ggx_split_sum", "blinn_phong"):
        defines["USE_AO"] = int(settings.ao)
    if model == "ggx_split_sum":
        defines["MULTISCATTER"] = int(settings.multiscatter)
    return defines


class ShadePass:
    def __init__(self, programs, layout: GBufferLayout):
        self.programs = programs
        self.ctx = programs.ctx
        self.layout = layout
        self._draw = FullscreenDraw(self.ctx)

    def _program(self, model: str, settings: RenderSettings):
        info = model_info(model)
        return self.programs.graphics("passes/fullscreen.vert", info.pass_file,
                                      defines=shade_defines(model, settings),
                                      virtual=self.layout.virtual_files())

    def run(self, gbuffer_textures: dict, out_fbo, camera: Camera, ibl, environment,
            settings: RenderSettings) -> None:
        """Shade into ``out_fbo`` (an RGBA32F target of the camera's size)."""
        prog = self._program(settings.model, settings)
        unit = 0
        for index, tex in gbuffer_textures.items():
            name = f"u_gbuffer{index}"
            if name in prog:
                tex.use(unit)
                prog[name].value = unit
                unit += 1
        unit = ibl.bind(prog, unit)
        basis = camera.basis()  # rows: right, up, back
        _set(prog, "u_camera_to_world", np.ascontiguousarray(basis.astype(np.float32)).tobytes())
        _set(prog, "u_tan_half_fov", camera.tan_half_fov())
        _set(prog, "u_resolution", (float(camera.width), float(camera.height)))
        _set(prog, "u_env_intensity", float(environment.intensity))
        _set(prog, "u_env_rotation", math.radians(environment.rotation_deg))
        out_fbo.use()
        self._draw(prog)

    def release(self) -> None:
        self._draw.release()


def _set(prog, name: str, value) -> None:
    if name not in prog:
        return
    if isinstance(value, bytes):
        prog[name].write(value)
    else:
        prog[name].value = value
