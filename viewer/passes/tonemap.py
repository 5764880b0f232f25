"""Exposure, tone mapping and sRGB encoding of the linear radiance target."""
from __future__ import annotations

from . import FullscreenDraw

TONEMAP_IDS = {"none": 0, "aces": 1, "reinhard": 2, "pbr_neutral": 3, "agx": 4}


class TonemapPass:
    def __init__(self, programs):
        self.programs = programs
        self.ctx = programs.ctx
        self._draw = FullscreenDraw(self.ctx)

    def run(self, radiance_texture, out_fbo, exposure: float, tonemap: str) -> None:
        prog = self.programs.graphics("passes/fullscreen.vert", "passes/tonemap.frag",
                                      defines={"TONEMAP": TONEMAP_IDS[tonemap]})
        radiance_texture.use(0)
        prog["u_radiance"].value = 0
        prog["u_exposure"].value = float(exposure)
        out_fbo.use()
        self._draw(prog)

    def release(self) -> None:
        self._draw.release()
