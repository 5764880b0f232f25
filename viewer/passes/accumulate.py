"""Progressive accumulation of Monte-Carlo batches (``passes/accumulate.frag``).

The running mean of every batch rendered since the frame graph last restarted it lives in a kept
float32 history target (``mc_history`` of :mod:`viewer.graph.frame`, with its sample count as the
target's state), so a still view converges frame after frame; the graph restarts it whenever
anything that changes the radiance changes.
"""
from __future__ import annotations

from . import FullscreenDraw


class AccumulatePass:
    """Folds a batch into the running mean (stateless: the targets and count are the caller's)."""

    def __init__(self, programs):
        self.programs = programs
        self.ctx = programs.ctx
        self._draw = FullscreenDraw(self.ctx)

    def add(self, batch, history, count: int, samples: int, out_fbo) -> int:
        """Fold ``batch`` (a texture: the mean of ``samples`` samples) into the mean of ``count``
        samples held by ``history`` (a target: ``.texture``, ``.fbo``), write the new mean to
        ``out_fbo`` (an RGBA32F target of the same size) and into ``history``. Returns the new
        sample count."""
        total = int(count) + int(samples)
        prog = self.programs.graphics("passes/fullscreen.vert", "passes/accumulate.frag")
        batch.use(0)
        history.texture.use(1)
        prog["u_batch"].value = 0
        if "u_history" in prog:
            prog["u_history"].value = 1
        prog["u_weight"].value = 1.0 if count == 0 else float(samples) / float(total)
        out_fbo.use()
        self.ctx.viewport = (0, 0, *batch.size)
        self._draw(prog)
        self.ctx.copy_framebuffer(dst=history.fbo, src=out_fbo)
        return total

    def release(self) -> None:
        self._draw.release()
