"""Progressive accumulation of Monte-Carlo batches (``passes/accumulate.frag``).

An :class:`Accumulator` keeps the running mean of every batch rendered since the last
:meth:`~Accumulator.reset` in a float32 history texture, so a still view converges frame after
frame; the renderer resets it whenever anything that changes the radiance changes.
"""
from __future__ import annotations

from . import FullscreenDraw


class Accumulator:
    """Running mean of batches for one image size. ``count`` is the samples accumulated so far,
    ``key`` what they were rendered for (the renderer compares it to restart)."""

    def __init__(self, programs, size: tuple[int, int]):
        ctx = programs.ctx
        self.programs = programs
        self.ctx = ctx
        self.size = tuple(size)
        self.batch = ctx.texture(self.size, 4, dtype="f4")   # the shading pass renders into this
        self.history = ctx.texture(self.size, 4, dtype="f4")
        for t in (self.batch, self.history):
            t.filter = (ctx.NEAREST, ctx.NEAREST)
        self.batch_fbo = ctx.framebuffer(color_attachments=[self.batch])
        self.history_fbo = ctx.framebuffer(color_attachments=[self.history])
        self._draw = FullscreenDraw(ctx)
        self.count = 0
        self.key = None

    def reset(self, key=None) -> None:
        self.count = 0
        self.key = key

    def add(self, samples: int, out_fbo) -> int:
        """Fold the batch texture (the mean of ``samples`` samples) into the mean and write the
        mean to ``out_fbo`` (an RGBA32F target of this size). Returns the new sample count."""
        total = self.count + int(samples)
        prog = self.programs.graphics("passes/fullscreen.vert", "passes/accumulate.frag")
        self.batch.use(0)
        self.history.use(1)
        prog["u_batch"].value = 0
        if "u_history" in prog:
            prog["u_history"].value = 1
        prog["u_weight"].value = 1.0 if self.count == 0 else float(samples) / float(total)
        out_fbo.use()
        self.ctx.viewport = (0, 0, *self.size)
        self._draw(prog)
        self.ctx.copy_framebuffer(dst=self.history_fbo, src=out_fbo)
        self.count = total
        return total

    def release(self) -> None:
        self._draw.release()
        for obj in (self.batch_fbo, self.history_fbo, self.batch, self.history):
            obj.release()
