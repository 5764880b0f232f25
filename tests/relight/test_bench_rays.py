"""``relight bench --suite rays``'s timing rows on a tiny frame: the baseline and the tier timed in
the same run, both modes, and the tier costing more than the baseline (it adds passes)."""
import pytest


@pytest.fixture(scope="module")
def renderer(ctx):
    from viewer.renderer import Renderer

    r = Renderer(ctx=ctx)
    yield r
    r.release()


def test_timing_rows_compare_the_tier_with_its_baseline(renderer):
    from relight.bench.rays import rays_timing

    (row,) = rays_timing(renderer, quick=True, size=(48, 48))
    assert row["kind"] == "time"
    for mode in ("viewer_frame", "headless"):
        assert row[f"{mode}_base_ms"] > 0 and row[f"{mode}_rays_ms"] > 0
        assert row[f"{mode}_ratio"] == pytest.approx(row[f"{mode}_rays_ms"]
                                                     / row[f"{mode}_base_ms"])
    # a headless render accumulates STILL_FRAMES frames of rays: more than one viewer frame's
    assert row["headless_rays_ms"] > row["viewer_frame_rays_ms"]
