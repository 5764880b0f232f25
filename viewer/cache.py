"""Bounded caches: every cache the renderer keeps (render targets, programs, environments,
geometry, uploads) is a :class:`BoundedCache` with a byte and/or item budget and least-recently-used
eviction. Evicting an entry calls its ``release`` (GL objects are freed at once, not when Python
collects them), so memory stays flat however many sizes, environments or meshes a process sees.

    cache = BoundedCache("targets", max_bytes=256 << 20, release=lambda v: v.release())
    tex = cache.get_or_create(key, lambda: ctx.texture(...), nbytes=texture_bytes)

Entries in use by the frame being drawn are pinned (:meth:`BoundedCache.pinned`, or everything
looked up inside :meth:`BoundedCache.frame`): the budget may be exceeded while they are held, never
by evicting what a pass still reads. ``stats()`` reports
items, bytes, hits, misses and evictions (``Renderer.memory()`` gathers them per cache).
"""
from __future__ import annotations

from collections import OrderedDict
from contextlib import contextmanager
from dataclasses import dataclass
from typing import Callable, Hashable

import numpy as np

_DTYPE_BYTES = {"f1": 1, "u1": 1, "i1": 1, "f2": 2, "u2": 2, "i2": 2, "f4": 4, "u4": 4, "i4": 4,
                "nu1": 1, "nu2": 2, "ni1": 1, "ni2": 2}


@dataclass(frozen=True)
class CacheStats:
    """What :meth:`BoundedCache.stats` reports."""

    name: str
    items: int
    bytes: int
    max_bytes: int | None
    max_items: int | None
    hits: int
    misses: int
    evictions: int

    def as_dict(self) -> dict:
        return dict(self.__dict__)

    @staticmethod
    def combine(name: str, stats) -> "CacheStats":
        """One line for several caches of one kind (each layout's pass, say): items, bytes and
        counters summed; a budget is the sum, or None where any of them is unbounded."""
        stats = list(stats)

        def budget(values):
            values = list(values)
            return None if not values or any(v is None for v in values) else sum(values)
        return CacheStats(name, sum(s.items for s in stats), sum(s.bytes for s in stats),
                          budget(s.max_bytes for s in stats), budget(s.max_items for s in stats),
                          sum(s.hits for s in stats), sum(s.misses for s in stats),
                          sum(s.evictions for s in stats))


class BoundedCache:
    """A least-recently-used map with a byte budget (``max_bytes``) and/or an item budget
    (``max_items``); ``None`` leaves that budget unbounded. ``release(value)`` runs when an entry is
    evicted, removed or the cache is cleared."""

    def __init__(self, name: str, max_bytes: int | None = None, max_items: int | None = None,
                 release: Callable[[object], None] | None = None, max_age: int | None = None):
        if max_bytes is not None and max_bytes < 0:
            raise ValueError(f"cache {name!r}: max_bytes must be >= 0, got {max_bytes}")
        if max_items is not None and max_items < 1:
            raise ValueError(f"cache {name!r}: max_items must be >= 1, got {max_items}")
        self.name = name
        # entries not used for more than max_age ticks (frames: :meth:`tick`) are evicted too, as
        # Filament's resource allocator ages out its cached textures
        self.max_age = max_age
        self.clock = 0
        self._used: dict[Hashable, int] = {}
        self.max_bytes = max_bytes
        self.max_items = max_items
        self._release = release
        self._entries: OrderedDict[Hashable, tuple[object, int]] = OrderedDict()
        self._bytes = 0
        self._pins: dict[Hashable, int] = {}
        # keys looked up or stored inside frame(): kept until the outermost frame ends
        self._frame_depth = 0
        self._in_frame: set = set()
        self.hits = self.misses = self.evictions = 0

    # ---- lookups ----------------------------------------------------------------------------
    def __contains__(self, key: Hashable) -> bool:
        return key in self._entries

    def __len__(self) -> int:
        return len(self._entries)

    def keys(self):
        return list(self._entries.keys())

    def values(self):
        return [v for v, _ in self._entries.values()]

    @property
    def bytes(self) -> int:
        return self._bytes

    def get(self, key: Hashable, default=None):
        """The value of ``key`` (now the most recently used), or ``default``."""
        entry = self._entries.get(key)
        if entry is None:
            return default
        self._mark(key)
        return entry[0]

    def peek(self, key: Hashable, default=None):
        """The value of ``key`` or ``default``, leaving its recency and the statistics alone."""
        entry = self._entries.get(key)
        return default if entry is None else entry[0]

    def nbytes(self, key: Hashable) -> int:
        """The bytes ``key`` was stored with (0 when absent)."""
        entry = self._entries.get(key)
        return 0 if entry is None else entry[1]

    def get_or_create(self, key: Hashable, factory: Callable[[], object],
                      nbytes: int | Callable[[object], int] = 0):
        """The value of ``key``; made by ``factory()`` on a miss and stored with ``nbytes``
        (a number, or a function of the value)."""
        entry = self._entries.get(key)
        if entry is not None:
            self.hits += 1
            self._mark(key)
            return entry[0]
        self.misses += 1
        value = factory()
        self.put(key, value, nbytes(value) if callable(nbytes) else nbytes)
        return value

    # ---- updates ----------------------------------------------------------------------------
    def put(self, key: Hashable, value, nbytes: int = 0) -> None:
        """Store ``value`` (replacing and releasing an older value of ``key``), then evict least
        recently used, unpinned entries other than ``key`` until the budgets hold."""
        old = self._entries.pop(key, None)
        if old is not None:
            self._bytes -= old[1]
            if old[0] is not value:
                self._free(old[0])
        self._entries[key] = (value, int(nbytes))
        self._mark(key)
        self._bytes += int(nbytes)
        self.trim(keep=(key,))

    def set_nbytes(self, key: Hashable, nbytes: int) -> None:
        """Count ``key`` as ``nbytes`` from now on (what it holds grew or shrank), evicting other
        entries if the budget no longer holds; its recency is unchanged."""
        entry = self._entries.get(key)
        if entry is None:
            return
        self._bytes += int(nbytes) - entry[1]
        self._entries[key] = (entry[0], int(nbytes))  # an existing key keeps its place
        if int(nbytes) > entry[1]:
            self.trim(keep=(key,))

    def pop(self, key: Hashable, release: bool = True):
        """Remove ``key`` (releasing its value unless ``release=False``); returns the value."""
        entry = self._entries.pop(key, None)
        if entry is None:
            return None
        self._used.pop(key, None)
        self._in_frame.discard(key)
        self._bytes -= entry[1]
        if release:
            self._free(entry[0])
        return entry[0]

    def trim(self, keep=()) -> int:
        """Evict least recently used entries (not pinned, not in ``keep``) until the budgets
        hold; returns how many were evicted."""
        evicted = 0
        if self.max_age is not None:
            for key in [k for k, t in self._used.items() if self.clock - t > self.max_age]:
                # (a release callback may have removed entries meanwhile)
                if key in self._entries and key not in keep and not self._held(key):
                    self.pop(key)
                    self.evictions += 1
                    evicted += 1
        if not self._over():
            return evicted
        for key in list(self._entries.keys()):
            if not self._over():
                break
            if key in keep or self._held(key) or key not in self._entries:
                continue
            self.pop(key)
            self.evictions += 1
            evicted += 1
        return evicted

    def tick(self) -> int:
        """Advance the clock by one (a frame) and age out entries unused for ``max_age`` ticks;
        returns how many were evicted."""
        self.clock += 1
        return self.trim()

    def touch(self, key: Hashable) -> None:
        """Mark ``key`` used now (and most recently used) without looking it up."""
        if key in self._entries:
            self._mark(key)

    def resize(self, max_bytes: int | None = None, max_items: int | None = None) -> None:
        """New budgets (evicting at once what no longer fits)."""
        self.max_bytes, self.max_items = max_bytes, max_items
        self.trim()

    def clear(self) -> None:
        entries = list(self._entries.values())
        self._entries.clear()
        self._used.clear()
        self._in_frame.clear()
        self._bytes = 0
        for value, _ in entries:  # after emptying: a release callback may look the cache up
            self._free(value)

    @contextmanager
    def pinned(self, *keys: Hashable):
        """Inside, ``keys`` are never evicted (the frame being drawn reads them)."""
        for k in keys:
            self._pins[k] = self._pins.get(k, 0) + 1
        try:
            yield self
        finally:
            for k in keys:
                n = self._pins.get(k, 0) - 1
                if n > 0:
                    self._pins[k] = n
                else:
                    self._pins.pop(k, None)
            # what was pinned stays (the last frame's working set, even above the budget:
            # evicting it would reload it next frame); older entries make room
            self.trim(keep=keys)

    @contextmanager
    def frame(self):
        """Inside (a frame being drawn), every entry looked up or stored is kept until the
        outermost ``frame()`` ends: a pass may hold what it looked up earlier in the frame. When
        it ends, older entries are evicted until the budgets hold, but never the frame's own
        working set (a scene larger than the budget would otherwise be reloaded every frame):
        the budgets hold except when one frame's content alone exceeds them."""
        self._frame_depth += 1
        try:
            yield self
        finally:
            self._frame_depth -= 1
            if self._frame_depth == 0:
                working = set(self._in_frame)
                self._in_frame.clear()
                self.trim(keep=working)

    def stats(self) -> CacheStats:
        return CacheStats(self.name, len(self._entries), self._bytes, self.max_bytes,
                          self.max_items, self.hits, self.misses, self.evictions)

    # ---- internals --------------------------------------------------------------------------
    def _mark(self, key: Hashable) -> None:
        self._entries.move_to_end(key)
        self._used[key] = self.clock
        if self._frame_depth:
            self._in_frame.add(key)

    def _held(self, key: Hashable) -> bool:
        return bool(self._pins.get(key)) or key in self._in_frame

    def _over(self) -> bool:
        return ((self.max_bytes is not None and self._bytes > self.max_bytes)
                or (self.max_items is not None and len(self._entries) > self.max_items))

    def _free(self, value) -> None:
        if self._release is not None:
            self._release(value)


# ---- sizes --------------------------------------------------------------------------------------
def texture_bytes(tex) -> int:
    """GPU bytes of a moderngl texture (a full mip chain adds a third when it has levels)."""
    if tex is None:
        return 0
    w, h = tex.size[:2]
    n = w * h * int(tex.components) * _DTYPE_BYTES.get(str(tex.dtype), 4)
    depth = tex.size[2] if len(tex.size) > 2 else 1
    n *= depth
    levels = getattr(tex, "_relight_levels", None)
    if levels is None:
        levels = 1
        try:  # moderngl keeps no mip count; a texture that built mipmaps has max_level set
            if tex.filter[0] in (0x2700, 0x2701, 0x2702, 0x2703):  # *_MIPMAP_* min filters
                levels = 2
        except Exception:  # noqa: BLE001 - a texture without a filter (depth/integer): one level
            levels = 1
    return n * 4 // 3 if levels > 1 else n


def array_bytes(*arrays) -> int:
    """Bytes of numpy arrays (``None`` counts 0; nested lists/tuples/dicts are walked)."""
    total = 0
    for a in arrays:
        if a is None:
            continue
        if isinstance(a, np.ndarray):
            total += a.nbytes
        elif isinstance(a, (list, tuple)):
            total += array_bytes(*a)
        elif isinstance(a, dict):
            total += array_bytes(*a.values())
    return total


def mib(n: int | None) -> str:
    """``n`` bytes as ``"12.3 MiB"`` (``"unbounded"`` for None)."""
    return "unbounded" if n is None else f"{n / (1 << 20):.1f} MiB"


@dataclass(frozen=True)
class Budgets:
    """The bounds of a renderer's caches (``Renderer(budgets=...)``; ``relight`` reads them from
    the scene's ``[render]`` table where it sets them). Bytes are GPU (or, on llvmpipe, host)
    memory; item counts bound caches whose entries are small but many."""

    targets_bytes: int = 1 << 30       # render targets and the transient pool: ~3 4K frames
    target_max_age: int = 4            # frames a pooled target may go unused before it is freed
    programs: int = 256                # compiled programs
    # environments: arrays, IBL chains, suns, sampling tables (the one in use is always kept)
    environment_bytes: int = 256 << 20
    # loaded and uploaded geometry: meshes, stacks, splats (the last frame's is always kept)
    geometry_bytes: int = 128 << 20
    # traced scenes: BVH, triangles, vertices, materials and maps on the GPU (viewer/raytrace)
    raytrace_bytes: int = 256 << 20
