"""Time per render pass: GPU timer queries on GPUs, fenced wall clock on software rasterisers.

    timer = PassTimer(ctx)
    timer.enabled = True
    with timer.scope("gbuffer"):
        ...draw...
    timer.milliseconds()  # {"gbuffer": 0.42, ...}; reading waits for the GPU

Mesa's llvmpipe answers ``GL_TIME_ELAPSED`` with the time to *submit* the commands (measured here:
0.6 ms for a pass whose fenced wall time is 18 ms; the first query returns 2^32 - 1), so on a
software renderer each scope is fenced with ``glFinish`` and timed with ``perf_counter`` instead.
One query object per pass name is reused (no per-frame allocation). Scopes must not overlap.

An interactive loop uses ``deferred=True`` and calls :meth:`PassTimer.end_frame` once per frame:
queries are double-buffered and a frame's results are read at the end of the next one, when the
GPU has long finished them, so reading never stalls the pipeline; ``timer.ms`` holds the latest.
(On a software rasteriser the scopes are fenced either way: its query times are not GPU times.)
"""
from __future__ import annotations

import time
from contextlib import contextmanager

_INVALID_NS = 2**32 - 1


class PassTimer:
    def __init__(self, ctx, mode: str = "auto", deferred: bool = False):
        self.ctx = ctx
        self.enabled = False
        if mode == "auto":
            renderer = str(ctx.info.get("GL_RENDERER", "")).lower()
            mode = "wall" if ("llvmpipe" in renderer or "softpipe" in renderer) else "query"
        if mode not in ("wall", "query"):
            raise ValueError(f"timer mode must be 'auto', 'wall' or 'query', not {mode!r}")
        self.mode = mode
        self.deferred = deferred
        self.ms: dict[str, float] = {}  # the latest finished frame's times (end_frame)
        self._slots: list[dict[str, object]] = [{}, {}]  # query per name; two with deferred
        self._slot = 0
        self._wall: dict[str, float] = {}
        self._order: list[str] = []
        self._active = None

    @property
    def _queries(self) -> dict[str, object]:
        return self._slots[self._slot]

    @contextmanager
    def scope(self, name: str):
        if not self.enabled:
            yield
            return
        if name not in self._order:
            self._order.append(name)
        if self.mode == "wall":
            self.ctx.finish()
            start = time.perf_counter()
            yield
            self.ctx.finish()
            self._wall[name] = (time.perf_counter() - start) * 1e3
            return
        query = self._queries.get(name)
        if query is None:
            query = self._queries[name] = self.ctx.query(time=True)
        with query:
            yield

    def begin(self, name: str | None) -> None:
        """Sequential form for render graphs: end the running scope (if any) and start ``name``
        (``None`` only ends). This is the ``Renderer.profiler`` protocol."""
        if self._active is not None:
            self._active.__exit__(None, None, None)
            self._active = None
        if name is not None and self.enabled:
            self._active = self.scope(name)
            self._active.__enter__()

    def milliseconds(self) -> dict[str, float]:
        """Time of the last run of every scope, in ms (waits for query results). A query whose
        result is not valid yet (its first use on some drivers) reports NaN."""
        if self.mode == "wall":
            return {name: self._wall[name] for name in self._order if name in self._wall}
        out = {}
        for name in self._order:
            ns = self._queries[name].elapsed
            out[name] = float("nan") if ns == _INVALID_NS else ns / 1e6
        return out

    def end_frame(self) -> None:
        """Close a frame of an interactive loop: ``ms`` gets this frame's times (wall mode, or
        queries without ``deferred``) or the previous frame's (deferred queries: read now that
        the GPU has finished them, then their slot is reused), and the scopes start afresh."""
        self.begin(None)
        if self.mode == "query" and self.deferred:
            self._slot ^= 1
            done = [n for n in self._order if n in self._queries]
            self.ms = {n: (float("nan") if self._queries[n].elapsed == _INVALID_NS
                           else self._queries[n].elapsed / 1e6) for n in done}
        else:
            self.ms = self.milliseconds()
        self.reset()

    def reset(self) -> None:
        self._order.clear()
        self._wall.clear()

    def release(self) -> None:
        self.begin(None)
        for slot in self._slots:  # moderngl frees query objects with their context
            slot.clear()
        self.reset()
