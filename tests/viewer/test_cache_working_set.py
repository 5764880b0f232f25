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


def test_older_entries_go_first_and_the_bound_returns():
    c, released = _cache()
    with c.frame():
        c.put("a", "A", 60)
    with c.frame():
        c.put("b", "B", 60)  # a, not used in this frame, makes room
    assert c.keys() == ["b"] and released == ["A"]
    with c.frame():
        c.put("c", "C", 30)
    assert c.bytes <= 100 and set(c.keys()) == {"c"} | ({"b"} if c.bytes == 90 else set())


def test_pinned_keys_stay_after_the_pin_and_go_when_something_new_needs_room():
    c, released = _cache()
    c.put("env1", "E1", 150)
    with c.pinned("env1"):
        pass
    assert "env1" in c  # the environment in use stays although it exceeds the budget
    c.put("env2", "E2", 40)  # a new one: the old, no longer in use, is freed
    assert c.keys() == ["env2"] and released == ["E1"]
