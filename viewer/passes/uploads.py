"""GPU copies of CPU objects for one pass: meshes, texture images, image stacks, splat clouds.

An :class:`UploadCache` keys each copy by the identity of the object(s) it was made from (and a
variant), holding them only weakly, so

- a copy is never handed out for another object that reused a dead one's ``id()``: a lookup
  checks the referent is the very object asked about;
- when the object dies its copy is released (at the cache's next use, when its context is
  current: weakref callbacks may run anywhere);
- when the :class:`~viewer.geometry.cache.GeometryCache` entry holding the object is evicted, the
  copy is released at once (the entry was told about it: :func:`viewer.geometry.cache.owners_of`,
  and counts its bytes towards the geometry budget).
"""
from __future__ import annotations

import weakref
from dataclasses import dataclass, field
from typing import Callable, Hashable

from ..cache import BoundedCache, CacheStats
from ..geometry.cache import owners_of
# the calling thread's current EGL context, saved and restored around a release from elsewhere
from ..gl.context import _egl_current, _egl_make_current, make_current


class _Strong:
    """Stands in for a weak reference to an object that cannot have one (held instead)."""

    __slots__ = ("obj",)

    def __init__(self, obj):
        self.obj = obj

    def __call__(self):
        return self.obj


@dataclass(eq=False)
class _Copy:
    key: Hashable
    refs: tuple  # weak references to the parts it was made from
    value: object
    # weak references to the (GeometryCache, entry) pairs counting it
    owners: list = field(default_factory=list)


class UploadCache:
    """``(parts, variant) -> value`` made from ``parts`` (one object or a tuple of objects) for
    the pass of context ``ctx``; ``release(value)`` frees the GL objects of a value. Bounded by
    the life of the parts and the geometry budget of the entries holding them (module
    docstring); ``max_bytes`` adds a budget of its own."""

    def __init__(self, ctx, name: str, release: Callable[[object], None],
                 max_bytes: int | None = None, max_items: int | None = None):
        self.ctx = ctx
        self._release_value = release
        self._copies = BoundedCache(name, max_bytes=max_bytes, max_items=max_items,
                                    release=self._free)
        self._dead: list[tuple[Hashable, object]] = []  # (key, weakref) of parts that died
        self._self = weakref.ref(self)

    # ---- lookups --------------------------------------------------------------------------------
    def get(self, parts, variant: Hashable = None):
        """The copy of ``parts`` for ``variant``, or None."""
        self._drain()
        parts = _as_tuple(parts)
        key = _key(parts, variant)
        copy = self._copies.peek(key)
        if copy is not None and _alive(copy, parts):
            self._copies.get(key)  # most recently used
            self._copies.hits += 1
            return copy.value
        self._copies.misses += 1
        if copy is not None:  # an id reused by a new object: the old copy is stale
            self._copies.pop(key)
        return None

    def put(self, parts, variant: Hashable, value, nbytes: int, account=None):
        """Store ``value`` as the copy of ``parts`` for ``variant`` (``nbytes`` of GPU memory) and
        report it to the geometry entries holding the parts (or the objects ``account``: a copy
        made from something derived from them); returns ``value``."""
        self._drain()
        parts = _as_tuple(parts)
        key = _key(parts, variant)
        copy = _Copy(key=key, refs=tuple(self._ref(p, key) for p in parts), value=value)
        self._copies.put(key, copy, nbytes)
        seen = set()
        for part in (parts if account is None else _as_tuple(account)):
            for cache, entry in owners_of(part):
                if id(entry) not in seen:
                    seen.add(id(entry))
                    copy.owners.append((weakref.ref(cache), weakref.ref(entry)))
                    cache.adopt(entry, self, key, nbytes)
        return value

    def get_or_create(self, parts, variant: Hashable, factory: Callable[[], tuple[object, int]],
                      account=None):
        """The copy of ``parts`` for ``variant``; on a miss ``factory()`` returns
        ``(value, nbytes)`` (:meth:`put` with ``account``)."""
        value = self.get(parts, variant)
        if value is None:
            value, nbytes = factory()
            self.put(parts, variant, value, nbytes, account)
        return value

    def forget(self, parts, variant: Hashable = None) -> None:
        """Release the copy of ``parts`` for ``variant`` now, if there is one."""
        parts = _as_tuple(parts)
        copy = self._copies.peek(_key(parts, variant))
        if copy is not None and _alive(copy, parts):
            self._copies.pop(copy.key)

    def values(self) -> list:
        return [c.value for c in self._copies.values()]

    def __len__(self) -> int:
        return len(self._copies)

    @property
    def bytes(self) -> int:
        return self._copies.bytes

    def stats(self) -> CacheStats:
        return self._copies.stats()

    # ---- releasing ------------------------------------------------------------------------------
    def discard(self, key: Hashable) -> None:
        """Release the copy ``key`` (its geometry entry was evicted), with this cache's context
        current: the eviction may happen while another context is."""
        if key not in self._copies:
            return
        previous = _egl_current()
        make_current(self.ctx)
        try:
            self._copies.pop(key)
            self._copies.evictions += 1
        finally:
            if previous is not None:
                _egl_make_current(previous)

    def release(self) -> None:
        """Release every copy (the pass is released)."""
        self._dead.clear()
        self._copies.clear()

    # ---- internals ------------------------------------------------------------------------------
    def _ref(self, part, key):
        me = self._self

        def died(ref, key=key):
            cache = me()
            if cache is not None:
                cache._dead.append((key, ref))
        try:
            return weakref.ref(part, died)
        except TypeError:
            return _Strong(part)

    def _drain(self) -> None:
        """Release the copies whose parts died since the last call."""
        while self._dead:
            key, ref = self._dead.pop()
            copy = self._copies.peek(key)
            if copy is not None and any(r is ref for r in copy.refs):
                self._copies.pop(key)
                self._copies.evictions += 1

    def _free(self, copy: _Copy) -> None:
        owners, copy.owners = copy.owners, []
        for cache_ref, entry_ref in owners:
            cache, entry = cache_ref(), entry_ref()
            if cache is not None and entry is not None:
                cache.disown(entry, self, copy.key)
        self._release_value(copy.value)


def _as_tuple(parts) -> tuple:
    return parts if isinstance(parts, tuple) else (parts,)


def _key(parts: tuple, variant) -> tuple:
    return (tuple(id(p) for p in parts), variant)


def _alive(copy: _Copy, parts: tuple) -> bool:
    return len(copy.refs) == len(parts) and all(r() is p for r, p in zip(copy.refs, parts))
