"""Screen-space ambient occlusion and one-bounce indirect light (``passes/ssao.frag``; thesis
eqs. 6.19-6.22).

:meth:`SSAOPass.occlusion` writes the visibility O(x) of every pixel to an RGBA32F texture that the
lighting passes multiply into their diffuse term (``USE_SSAO``); :meth:`SSAOPass.indirect` marches
the same rays again and adds the diffuse one-bounce light gathered from the direct-lighting buffer
(the lighting pass's output for this frame) at each ray's hit pixel.
"""
from __future__ import annotations

import numpy as np

from ..camera import Camera
from ..gbuffer import GBufferLayout
from ..settings import RenderSettings
from . import FullscreenDraw, bind_gbuffer
from . import set_uniform as _set


class SSAOPass:
    def __init__(self, programs, layout: GBufferLayout):
        self.programs = programs
        self.ctx = programs.ctx
        self.layout = layout
        self._draw = FullscreenDraw(self.ctx)

    def _run(self, indirect: bool, gbuffer_textures: dict, out_fbo, camera: Camera,
             settings: RenderSettings, direct=None) -> None:
        prog = self.programs.graphics("passes/fullscreen.vert", "passes/ssao.frag",
                                      defines={"SSAO_INDIRECT": int(indirect),
                                               "BACKGROUND_ENVIRONMENT": 0},
                                      virtual=self.layout.virtual_files())
        unit = bind_gbuffer(prog, gbuffer_textures)
        if direct is not None and "u_direct" in prog:
            direct.use(unit)
            prog["u_direct"].value = unit
            unit += 1
        basis = camera.basis()
        _set(prog, "u_camera_to_world", np.ascontiguousarray(basis.astype(np.float32)).tobytes())
        _set(prog, "u_tan_half_fov", camera.tan_half_fov())
        _set(prog, "u_resolution", (float(camera.width), float(camera.height)))
        _set(prog, "u_rays", int(settings.ssao.rays))
        _set(prog, "u_steps", int(settings.ssao.steps))
        _set(prog, "u_radius", float(settings.ssao.radius))
        _set(prog, "u_thickness", float(settings.ssao.thickness))
        _set(prog, "u_seed", int(settings.mc.seed))
        out_fbo.use()
        self.ctx.viewport = (0, 0, camera.width, camera.height)
        self._draw(prog)

    def occlusion(self, gbuffer_textures: dict, out_fbo, camera: Camera,
                  settings: RenderSettings) -> None:
        """O(x) (eq. 6.19) into all four channels of ``out_fbo`` (1 on the background)."""
        self._run(False, gbuffer_textures, out_fbo, camera, settings)

    def indirect(self, gbuffer_textures: dict, direct, out_fbo, camera: Camera,
                 settings: RenderSettings) -> None:
        """``direct`` (RGBA32F texture, L_dir) plus L_ind of eq. 6.22 into ``out_fbo``."""
        self._run(True, gbuffer_textures, out_fbo, camera, settings, direct=direct)

    def release(self) -> None:
        self._draw.release()
