"""Counting the live GL objects of a context: every buffer, texture, framebuffer, sampler, vertex
array, program, ... made through it after :func:`track_objects` and not released since.

moderngl keeps no list of what a context made (``ctx.objects`` only queues objects for its
``context_gc`` mode) and, in its default mode, a Python wrapper that is garbage collected without
``release()`` leaks its GL object. The tracker wraps the context's factory methods (on this
context object only) and keeps every object made, so a leaked object is counted rather than lost:
an object is live until its ``release()`` (moderngl then swaps its ``mglo`` for an
``InvalidObject``).

    tracker = track_objects(ctx)
    before = tracker.live()
    ...                                   # render, evict, release
    assert tracker.live() == before       # Counter: type name -> live count
"""
from __future__ import annotations

from collections import Counter

_FACTORIES = ("buffer", "texture", "depth_texture", "texture_array", "texture3d", "texture_cube",
              "depth_texture_cube", "framebuffer", "renderbuffer", "depth_renderbuffer", "sampler",
              "program", "compute_shader", "_vertex_array", "query")


class ObjectTracker:
    """The objects a context made since tracking started (see the module docstring)."""

    def __init__(self, ctx):
        self.ctx = ctx
        self.made: list = []
        self._originals: dict[str, object] = {}

    def install(self) -> "ObjectTracker":
        for name in _FACTORIES:
            original = getattr(self.ctx, name, None)
            if original is None or name in self._originals:
                continue
            self._originals[name] = original

            def made(*args, _original=original, **kwargs):
                obj = _original(*args, **kwargs)
                self.made.append(obj)
                return obj
            setattr(self.ctx, name, made)
        return self

    def live(self) -> Counter:
        """Type name -> how many objects made since tracking started are not released."""
        self.made = [o for o in self.made if not _released(o)]
        return Counter(type(o).__name__ for o in self.made)

    def uninstall(self) -> None:
        for name in self._originals:
            try:
                delattr(self.ctx, name)  # the class's method again
            except AttributeError:
                pass
        self._originals.clear()


def _released(obj) -> bool:
    mglo = getattr(obj, "mglo", None)
    return type(mglo).__name__ == "InvalidObject"


def track_objects(ctx) -> ObjectTracker:
    """Start counting the GL objects ``ctx`` makes (:class:`ObjectTracker`)."""
    return ObjectTracker(ctx).install()
