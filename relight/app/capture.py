"""The viewer's output: screenshots (the view as shown, the linear radiance, or the whole window
with its panel) and the window's framebuffer read back. A mixin of
:class:`~relight.app.window.Viewer`."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from viewer.errors import SceneError
from viewer.gl.context import make_current
from viewer.frame import read_texture


class Capture:
    """Reading back what the viewer shows; mixed into :class:`~relight.app.window.Viewer`."""

    def screenshot(self, path: str, ui: bool = False) -> Path:
        """``.png``: the current view exactly as shown, at the render's size, without the UI.
        ``.exr``: the linear radiance (before exposure), as ``relight render --out x.exr``.
        ``ui=True`` (``.png`` only): the window's whole framebuffer as the next frame draws it,
        the panel and overlay included (at the window's framebuffer size)."""
        from viewer.imageio import write_exr, write_png

        path = Path(path)
        suffix = path.suffix.lower()
        if suffix not in (".png", ".exr"):
            raise SceneError("a screenshot is .png (the view) or .exr (linear radiance)",
                             where=path)
        if ui and suffix != ".png":
            raise SceneError("a screenshot with the UI is a .png", where=path)
        if not path.resolve().parent.is_dir():
            raise SceneError("output folder does not exist", where=path.parent)
        if ui:
            self._want_grab = True
            self.frame()
            write_png(path, self._grab[..., :3])
            self._grab = None
            return path
        if self._targets is None:
            self._render()
        make_current(self.ctx)
        scene = self.current_scene()
        transparent = scene.render.display.background == "transparent"
        if suffix == ".exr":
            rgba = read_texture(self._targets.radiance, "f4")
            write_exr(path, rgba if transparent else rgba[..., :3],
                      ["R", "G", "B", "A"][: 4 if transparent else 3])
            return path
        size = tuple(self._targets.display.size)
        if size not in self._shot:
            tex = self.ctx.texture(size, 4, dtype="f1")
            self._shot[size] = (tex, self.ctx.framebuffer(color_attachments=[tex]))
        tex, fbo = self._shot[size]
        fbo.use()
        self.ctx.viewport = (0, 0, *size)
        self._draw_view()
        pixels = read_texture(tex, "f1")
        if transparent and self.state.view == "display":
            pixels[..., 3] = read_texture(self._targets.display, "f1")[..., 3]
            write_png(path, pixels)
        else:
            write_png(path, pixels[..., :3])
        return path

    def read_framebuffer(self) -> np.ndarray:
        """The window's default framebuffer as ``[H, W, 4]`` uint8, row 0 at the top (tests)."""
        make_current(self.ctx)
        fw, fh = self.window.framebuffer_size()
        data = self.ctx.screen.read(viewport=(0, 0, fw, fh), components=4)
        return np.frombuffer(data, np.uint8).reshape(fh, fw, 4)[::-1].copy()
