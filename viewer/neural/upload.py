"""GL upload of a generated network's weight data: the buffer or texture its storage reads
(``viewer.neural.glsl.WEIGHT_STORAGES``)."""
from __future__ import annotations

import numpy as np

from .glsl import WEIGHT_TEXTURE_WIDTH, NetworkCode


class NeuralWeights:
    """The GL side of one :class:`NetworkCode`: uploads its weight data once (a buffer for
    ``ubo``/``ssbo``, an RGBA32F texture for ``texture``, nothing for ``const``);
    :meth:`bind` before every draw or dispatch of a program built from ``code.glsl``."""

    def __init__(self, ctx, code: NetworkCode):
        self.code = code
        self._buffer = self._texture = None
        if code.binding in ("ubo", "ssbo"):
            self._buffer = ctx.buffer(np.ascontiguousarray(code.data, "<f4").tobytes())
        elif code.binding == "texture":
            w = WEIGHT_TEXTURE_WIDTH
            rows = -(-len(code.data) // w)
            texels = np.zeros((rows * w, 4), np.float32)
            texels[:len(code.data)] = code.data
            self._texture = ctx.texture((w, rows), 4, texels.tobytes(), dtype="f4")
            self._texture.filter = (ctx.NEAREST, ctx.NEAREST)
            self._texture.repeat_x = self._texture.repeat_y = False

    def bind(self, prog, unit: int) -> int:
        """Bind the data for ``prog``; returns the next free texture unit."""
        if self.code.binding == "ubo":
            self._buffer.bind_to_uniform_block(self.code.point)
        elif self.code.binding == "ssbo":
            self._buffer.bind_to_storage_buffer(self.code.point)
        elif self.code.binding == "texture" and self.code.symbol in prog:
            self._texture.use(unit)
            prog[self.code.symbol].value = unit
            return unit + 1
        return unit

    @property
    def nbytes(self) -> int:
        """GPU bytes of the uploaded weight data."""
        if self._buffer is not None:
            return int(self._buffer.size)
        if self._texture is not None:
            w, h = self._texture.size
            return w * h * 16  # RGBA32F
        return 0

    def release(self) -> None:
        for r in (self._buffer, self._texture):
            if r is not None:
                r.release()
        self._buffer = self._texture = None

