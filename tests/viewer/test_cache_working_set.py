"""BoundedCache keeps the working set of the last frame (or of what was pinned) even above its
budget, and evicts older entries first: a scene or environment larger than the budget is not
reloaded every frame, and memory stays bounded by max(budget, one frame's content)."""
from viewer.cache import BoundedCache


def _cache():
    released = []
    return BoundedCache("t", max_bytes=100, release=released.append), released


def test_a_frame_larger_than_the_budget_keeps_its_content():
    c, released = _cache()
    with c.frame():
        c.put("big", "B", 150)  # alone over the budget
        c.put("small", "s", 10)
    assert set(c.keys()) == {"big", "small"} and released == []
    with c.frame():  # the next frame uses only it: kept (no reload), the unused one goes
        assert c.get("big") == "B"
    assert c.keys() == ["big"] and released == ["s"]


def _lru_survivors(order, sizes, budget, working):
    """The survivors an LRU cache must keep, computed here from the known order of use (least
    recent first) and the known sizes: drop the least recently used entry outside the working
    set until the total fits the budget. Independent of BoundedCache's byte count."""
    kept = list(order)
    for key in list(order):
        if sum(sizes[k] for k in kept) <= budget:
            break
        if key not in working:
            kept.remove(key)
    return kept


def test_older_entries_go_first_and_the_bound_returns():
    c, released = _cache()
    with c.frame():
        c.put("a", "A", 60)
    with c.frame():
        c.put("b", "B", 60)  # a, not used in this frame, makes room
    assert c.keys() == ["b"] and released == ["A"]
    with c.frame():
        c.put("c", "C", 30)
    assert c.keys() == ["b", "c"] and released == ["A"] and c.bytes == 90  # 60 + 30 fit in 100


SIZES = {"a": 40, "b": 30, "c": 20, "d": 40}


def _fill(c):
    """a, b, c stored in frames of their own (90 of 100 bytes), then a looked up again: the use
    order is b, c, a (least recent first); then a frame stores d (40), 130 > 100 bytes."""
    for key in ("a", "b", "c"):
        with c.frame():
            c.put(key, key.upper(), SIZES[key])
    with c.frame():
        assert c.get("a") == "A"
    with c.frame():
        c.put("d", "D", SIZES["d"])


def test_the_least_recently_used_entry_is_evicted_not_the_most_recent():
    """The survivors are computed from the use order and sizes alone (:func:`_lru_survivors`):
    b (least recent, 30) goes and 100 bytes stay. A cache that evicted the most recently used
    entry first would drop a (40) and keep b, c, d; one that went by insertion order would drop
    a too (it was stored first); both fail here."""
    c, released = _cache()
    _fill(c)
    expected = _lru_survivors(["b", "c", "a", "d"], SIZES, 100, working={"d"})
    assert expected == ["c", "a", "d"]
    assert c.keys() == expected
    assert released == ["B"] and c.bytes == sum(SIZES[k] for k in expected) == 100


def test_the_eviction_check_fails_on_most_recently_used_eviction(monkeypatch):
    """The check above against a deliberately broken cache whose trim walks the entries most
    recent first: it keeps b and evicts a, and the expected survivors no longer match."""
    from collections import OrderedDict

    from viewer import cache

    real_trim = cache.BoundedCache.trim

    def mru_trim(self, keep=()):
        self._entries = OrderedDict(reversed(list(self._entries.items())))
        try:
            return real_trim(self, keep)
        finally:
            self._entries = OrderedDict(reversed(list(self._entries.items())))

    monkeypatch.setattr(cache.BoundedCache, "trim", mru_trim)
    c, released = _cache()
    _fill(c)
    assert released == ["A"] and c.keys() == ["b", "c", "d"]
    assert c.keys() != _lru_survivors(["b", "c", "a", "d"], SIZES, 100, working={"d"})


def test_pinned_keys_stay_after_the_pin_and_go_when_something_new_needs_room():
    c, released = _cache()
    c.put("env1", "E1", 150)
    with c.pinned("env1"):
        pass
    assert "env1" in c  # the environment in use stays although it exceeds the budget
    c.put("env2", "E2", 40)  # a new one: the old, no longer in use, is freed
    assert c.keys() == ["env2"] and released == ["E1"]
