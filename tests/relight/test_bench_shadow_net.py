"""relight.bench.shadow_net: every timed frame runs the estimator and SSAO, the row reports
their per-frame ratio and the architecture it timed; the suite is registered in
``relight bench``."""
import math


def test_the_row_times_the_estimator_beside_ssao_in_the_same_frames(ctx):
    from relight.bench.run import SUITES, BenchConfig
    from relight.bench.scenes import demo_scene
    from relight.bench.shadow_net import shadow_net_rows
    from viewer.renderer import Renderer

    assert "shadow_net" in SUITES
    r = Renderer(ctx=ctx)
    try:
        rows = shadow_net_rows(r, demo_scene(), BenchConfig(quick=True, frames=3, warmup=1),
                               size=(40, 32))
    finally:
        r.release()
    (row,) = rows
    assert row["frames"] == 3 and row["levels"] == 5 and row["receptive_field_px"] == 220
    assert row["shadow_net_ms"] > 0.0 and row["ssao_ms"] > 0.0
    assert row["ratio_ssao_blur"] < row["ratio_ssao"]
    assert all(math.isfinite(row[k]) and row[k] > 0.0
               for k in ("ratio_ssao", "frame_ms", "frame_without_ms", "ratio_frame"))
