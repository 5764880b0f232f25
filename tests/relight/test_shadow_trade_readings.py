"""``relight.bench.shadow_trade``'s equal-time and equal-accuracy readings of the rays' curve
(:func:`matched`), its table and plot, on made-up rows whose answers are known, and the bench
suite's refusal without a dataset."""
import math

import pytest

from relight.bench.shadow_trade import RAY_OPTIONS, markdown, matched, plot

RAYS = [(3.0, 26.0), (5.0, 27.0), (9.0, 27.5), (17.0, 28.0)]  # (frame / SSAO's, PSNR), 1-8 frames


def _rows(*others):
    rows = [{"option": name, "psnr": q, "ratio_frame": c, "vs_ssao": 0.0, "vs_ssao_lo": 0.0,
             "vs_ssao_hi": 0.0} for name, (c, q) in zip(RAY_OPTIONS, RAYS)]
    return [{"option": n, "psnr": q, "ratio_frame": c, "vs_ssao": 0.0, "vs_ssao_lo": 0.0,
             "vs_ssao_hi": 0.0} for n, c, q in others] + rows


def test_readings_interpolate_in_log_cost_and_say_their_bounds():
    rows = _rows(("cheap", 1.3, 25.0), ("between", math.sqrt(3.0 * 5.0), 26.5),
                 ("beyond", 20.0, 29.0))
    matched(rows)
    cheap, between, beyond = rows[:3]
    # cheaper than one frame of rays: no equal-time reading; the first frame already beats it
    assert cheap["rays_psnr_equal_time"] is None
    assert cheap["rays_ratio_equal_psnr"] == 3.0 and cheap["rays_ratio_bound"] == "<="
    # halfway between 1 and 2 frames in log cost: halfway in PSNR; 26.5 dB halfway in cost too
    assert between["rays_psnr_equal_time"] == pytest.approx(26.5)
    assert between["rays_ratio_equal_psnr"] == pytest.approx(math.sqrt(15.0))
    assert between["rays_ratio_bound"] == "="
    # dearer than 8 frames: the last point's PSNR; more accurate than every ray point: none
    assert beyond["rays_psnr_equal_time"] == 28.0
    assert beyond["rays_ratio_equal_psnr"] is None and beyond["rays_ratio_bound"] is None
    assert all("rays_ratio_bound" not in r for r in rows[3:])
    table = markdown(rows, "t")
    assert "| cheap | 25.00 |" in table and "≤ 3.00" in table
    from relight.bench.report import suite_table  # the bench suite's table: no "None"

    assert "None" not in "\n".join(suite_table(rows)) and "| – |" in "\n".join(suite_table(rows))
    assert "no ray point reaches it" in table and "cheaper than one frame of rays" in table


def test_without_costs_there_is_no_reading_and_no_plot(tmp_path):
    rows = [{k: v for k, v in r.items() if k != "ratio_frame"} for r in _rows(("x", 1.0, 25.0))]
    matched(rows)
    assert all("rays_ratio_bound" not in r for r in rows)
    assert "equal time" not in markdown(rows, "t")
    assert plot(rows, tmp_path / "p.png", "t") is False and not (tmp_path / "p.png").exists()


def test_the_plot_is_written(tmp_path):
    pytest.importorskip("matplotlib")
    rows = _rows(("x", 1.3, 25.0))
    assert plot(rows, tmp_path / "p.png", "t") and (tmp_path / "p.png").stat().st_size > 1000


def test_the_suite_without_a_dataset_is_left_out_with_a_warning():
    from relight.bench.run import BenchConfig
    from relight.bench.suites import SUITES

    with pytest.warns(UserWarning, match="--trade"):
        assert SUITES["shadow_trade"](None, {}, BenchConfig(), None) == []
