"""relight.bench.clamps: every clamp's cost is measured, finite, and (for the roughness clamp)
real but small; the suite is registered in ``relight bench``."""
import math

import pytest


@pytest.fixture(scope="module")
def rows(ctx):
    from relight.bench.clamps import clamp_costs
    from relight.bench.run import BenchConfig
    from viewer.renderer import Renderer

    r = Renderer(ctx=ctx)
    try:
        yield clamp_costs(r, BenchConfig(quick=True), size=(40, 40))
    finally:
        r.release()


def _get(rows, clamp, metric_start, scene_has=""):
    found = [r for r in rows if r["clamp"].startswith(clamp) and r["metric"].startswith(metric_start)
             and scene_has in r["scene"]]
    assert found, (clamp, metric_start)
    return found


def test_rows_are_complete_and_finite(rows):
    from relight.bench.run import SUITES

    assert "clamps" in SUITES
    assert {r["clamp"].split()[0] for r in rows} == {"perceptual", "n.v", "radiance", "dfg.y"}
    for r in rows:
        assert set(r) == {"clamp", "value", "scene", "metric", "error", "note"}
        assert math.isfinite(r["error"]), r


def test_roughness_clamp_is_real_but_small(rows):
    for r in _get(rows, "perceptual", "roughness 0 (clamped to 0.045): relative RMSE"):
        assert r["error"] > 0.0, r
    for r in _get(rows, "perceptual", "roughness 0 (clamped to 0.045): relative RMSE", "studio"):
        assert r["error"] < 0.2, r  # measured 0.068 at 256^2 (the sky's sun: 0.2 at 256^2, ~2 at 40^2)
    for r in _get(rows, "perceptual", "roughness 0 (clamped to 0.045): PSNR", "studio"):
        assert 15.0 < r["error"] < 60.0, r  # measured 29.9 dB at 128^2 (23.3 with a linear lod)
    # asking for 0.045 explicitly renders the same image: the clamp costs nothing there
    for r in _get(rows, "perceptual", "max abs: roughness 0 render"):
        assert r["error"] == 0.0
    # the reference is right: through the split sum's mip blend it matches the render
    for r in _get(rows, "perceptual", "roughness 0 render vs mirror through the mip blend"):
        assert r["error"] > 50.0, r


def test_other_clamps_cost_little_or_nothing(rows):
    for r in _get(rows, "n.v", "max relative error"):
        assert r["error"] < 1e-2, r  # measured 1.7e-4 and 2.8e-4
    for r in _get(rows, "radiance", "max abs"):
        assert r["error"] == 0.0, r
    assert _get(rows, "dfg.y", "min dfg.y")[0]["error"] > 1e-4
    assert _get(rows, "dfg.y", "max relative change")[0]["error"] == 0.0
