"""The target pool: every render target the frame graph uses comes from here, and its bytes are
bounded.

* **Transient** targets are keyed by their descriptor: :meth:`TargetPool.acquire` takes a free one
  of the same descriptor (or makes one), :meth:`TargetPool.release` gives it back after its last
  reader, so passes whose lifetimes do not overlap share memory.
* **Kept** targets (:meth:`TargetPool.acquire_kept`) belong to a (scope, name) across frames, with
  the signature of what they were last drawn from (the graph's reuse test) and a small state dict.
  A kept target whose descriptor changes (a resized window), or that a frame no longer declares,
  goes back to the free list.
* Free targets unused for ``max_age`` frames are freed (as Filament's resource allocator ages
  out its cache), and least recently used free targets are freed whenever the pool's bytes (free,
  kept and in use) exceed ``max_bytes``. Freeing releases the GL objects at once.
"""
from __future__ import annotations

import itertools
from dataclasses import dataclass, field
from typing import Hashable

from ..cache import BoundedCache, CacheStats


@dataclass
class _Kept:
    desc: object
    handle: object
    signature: Hashable = None
    state: dict = field(default_factory=dict)


class TargetPool:
    def __init__(self, ctx, max_bytes: int | None = 1 << 30, max_age: int | None = 4):
        self.ctx = ctx
        self.max_bytes = max_bytes
        self._serial = itertools.count()
        # free targets: (desc, serial) -> target; LRU and aged; its budget is set every trim
        self._free = BoundedCache("pool", max_age=max_age, release=self._destroy)
        self._kept: dict[tuple, _Kept] = {}
        self._in_use: dict[int, tuple[object, object]] = {}  # id(handle) -> (desc, handle)
        self._mrt: dict[tuple, object] = {}  # texture glos -> framebuffer with them attached
        self.created = self.destroyed = 0

    # ---- transient ----------------------------------------------------------------------------
    def acquire(self, desc):
        """A target of ``desc`` for this frame (a free one if there is one)."""
        for key in self._free.keys():
            if key[0] == desc:
                handle = self._free.pop(key, release=False)
                break
        else:
            handle = self._create(desc)
        self._in_use[id(handle)] = (desc, handle)
        return handle

    def release(self, desc, handle) -> None:
        """Give ``handle`` back (its content is no longer needed)."""
        self._in_use.pop(id(handle), None)
        self._free.put((desc, next(self._serial)), handle, desc.bytes())
        self._trim()

    # ---- kept ---------------------------------------------------------------------------------
    def acquire_kept(self, scope: Hashable, name: str, desc):
        """The kept target ``name`` of ``scope``, made (or remade at a new descriptor) on demand."""
        entry = self._kept.get((scope, name))
        if entry is not None and entry.desc != desc:
            self._free.put((entry.desc, next(self._serial)), entry.handle, entry.desc.bytes())
            entry = None
        if entry is None:
            handle = None
            for key in self._free.keys():
                if key[0] == desc:
                    handle = self._free.pop(key, release=False)
                    break
            entry = self._kept[(scope, name)] = _Kept(desc, handle or self._create(desc))
            self._trim()
        return entry.handle

    def kept_signature(self, scope: Hashable, name: str, desc) -> Hashable:
        """What the kept target was last drawn from (None: nothing, or another descriptor)."""
        entry = self._kept.get((scope, name))
        return entry.signature if entry is not None and entry.desc == desc else None

    def set_kept_signature(self, scope: Hashable, name: str, signature: Hashable) -> None:
        self._kept[(scope, name)].signature = signature

    def kept_state(self, scope: Hashable, name: str) -> dict:
        return self._kept[(scope, name)].state

    def invalidate(self, scope: Hashable, name: str) -> None:
        """Forget what the kept target was drawn from (something else wrote it)."""
        entry = self._kept.get((scope, name))
        if entry is not None:
            entry.signature = None

    def kept(self, scope: Hashable, name: str):
        """The kept target ``name`` of ``scope`` as the last frame left it, or None."""
        entry = self._kept.get((scope, name))
        return None if entry is None else entry.handle

    def end_frame(self, scope: Hashable, names: set[str]) -> None:
        """A frame of ``scope`` declared the kept ``names``: the scope's other kept targets go
        back to the free list; the free list ages by one frame."""
        for key in [k for k in self._kept if k[0] == scope and k[1] not in names]:
            entry = self._kept.pop(key)
            self._free.put((entry.desc, next(self._serial)), entry.handle, entry.desc.bytes())
        self._free.tick()
        self._trim()

    # ---- framebuffers over several targets ------------------------------------------------------
    def framebuffer(self, textures: tuple):
        key = tuple(t.glo for t in textures)
        if key not in self._mrt:
            self._mrt[key] = self.ctx.framebuffer(color_attachments=list(textures))
        return self._mrt[key]

    # ---- accounting ---------------------------------------------------------------------------
    @property
    def bytes(self) -> int:
        return (self._free.bytes + sum(e.desc.bytes() for e in self._kept.values())
                + sum(d.bytes() for d, _ in self._in_use.values()))

    def stats(self) -> CacheStats:
        return CacheStats("targets", len(self._free) + len(self._kept) + len(self._in_use),
                          self.bytes, self.max_bytes, None, self._free.hits, self.created,
                          self._free.evictions)

    def clear(self) -> None:
        """Free every target (kept ones included)."""
        self._free.clear()
        for entry in self._kept.values():
            self._destroy(entry.handle)
        self._kept.clear()
        for _, handle in self._in_use.values():
            self._destroy(handle)
        self._in_use.clear()

    # ---- internals ----------------------------------------------------------------------------
    def _create(self, desc):
        self.created += 1
        return desc.create(self.ctx)

    def _destroy(self, handle) -> None:
        textures = ([handle.texture] if hasattr(handle, "texture")
                    else list(handle.textures.values()) + [handle.depth])
        glos = {t.glo for t in textures}
        for key in [k for k in self._mrt if glos & set(k)]:
            self._mrt.pop(key).release()
        handle.release()
        self.destroyed += 1

    def _trim(self) -> None:
        if self.max_bytes is None:
            return
        others = self.bytes - self._free.bytes
        self._free.resize(max_bytes=max(self.max_bytes - others, 0))
