"""relight.bench.shadows: every timed frame of a shadowed row draws one shadow pass per light
(the rows are whole frames; ``ratio_maps_kept`` takes those passes' fenced times out, and that a
single map is kept on a camera move is tests/viewer/test_shadow_cascades.py's); the suite is
registered in ``relight bench``."""
import math

import pytest


@pytest.fixture(scope="module")
def rows(ctx):
    from relight.bench.run import BenchConfig
    from relight.bench.scenes import demo_scene
    from relight.bench.shadows import shadow_rows
    from viewer.renderer import Renderer

    r = Renderer(ctx=ctx)
    config = BenchConfig(quick=True, frames=2, warmup=1)
    try:
        yield shadow_rows(r, demo_scene().with_render(sun=False), config, counts=(1, 3),
                          size=(48, 48), map_sizes=(256, 128), env_counts=(2,))
    finally:
        r.release()


def test_rows_draw_one_pass_per_light_every_frame(rows):
    from relight.bench.run import SUITES

    assert "shadows" in SUITES
    assert [(r["lights"], r["shadow_size"], r["budget"], r["map_size"], r["env_shadows"],
             r["lod_error"]) for r in rows] == [
        (1, 256, 1.0, 256, 0, 0.5), (1, 128, 1.0, 128, 0, 0.5),
        (3, 256, 1.0, 144, 0, 0.5), (3, 128, 1.0, 64, 0, 0.5),  # the budget's share of a map
        (3, 256, 0.0, 256, 0, 0.5),  # without the budget: every map at the set size
        (1, 256, 1.0, 256, 0, 0.0), (3, 256, 1.0, 144, 0, 0.0),  # whole meshes
        (0, 512, 1.0, 512, 2, 0.5)]
    assert rows[-1]["shadow_passes"] == 1  # the environment's directions: one atlas pass
    # the spheres' levels of detail: fewer triangles than the whole meshes, a floor left out
    by_case = {(r["lights"], r["map_size"], r["lod_error"]): r["map_triangles"] for r in rows}
    assert 0 < by_case[(1, 256, 0.5)] < by_case[(1, 256, 0.0)]
    assert by_case[(3, 144, 0.0)] == 3 * by_case[(1, 256, 0.0)]
    # coarser maps draw coarser levels: the budget's 144-texel maps fewer triangles a map
    assert by_case[(3, 144, 0.5)] < by_case[(3, 256, 0.5)]
    for r in rows[:-1]:
        assert r["shadow_passes"] == r["lights"], r
        assert r["shadow_pass_ms"] > 0.0, r
        assert all(math.isfinite(r[k]) and r[k] > 0 for k in ("ms_shadows", "ms_without")), r

