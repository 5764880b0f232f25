"""Anti-aliasing passes: FXAA 3.11 on the display image (``passes/fxaa.frag``, ``[render] aa =
"fxaa"``) and the box resolve of supersampled radiance (``passes/ssaa_resolve.frag``, ``[render]
ssaa = N``: the frame is rendered at N times the size and averaged in linear radiance before tone
mapping)."""
from __future__ import annotations

from . import FullscreenDraw


class AntialiasPass:
    def __init__(self, programs):
        self.programs = programs
        self.ctx = programs.ctx
        self._draw = FullscreenDraw(self.ctx)

    def fxaa(self, display_texture, out_fbo) -> None:
        """FXAA of ``display_texture`` (RGBA8, tone-mapped sRGB) into ``out_fbo`` (same size)."""
        prog = self.programs.graphics("passes/fullscreen.vert", "passes/fxaa.frag")
        display_texture.use(0)
        prog["u_display"].value = 0
        out_fbo.use()
        self.ctx.viewport = (0, 0) + tuple(out_fbo.size)
        self._draw(prog)

    def resolve(self, radiance_texture, out_fbo, n: int) -> None:
        """The mean of each ``n`` x ``n`` block of ``radiance_texture`` into ``out_fbo`` (1/n the
        size)."""
        prog = self.programs.graphics("passes/fullscreen.vert", "passes/ssaa_resolve.frag",
                                      defines={"SSAA": int(n)})
        radiance_texture.use(0)
        prog["u_radiance"].value = 0
        out_fbo.use()
        self.ctx.viewport = (0, 0) + tuple(out_fbo.size)
        self._draw(prog)

    def release(self) -> None:
        self._draw.release()
