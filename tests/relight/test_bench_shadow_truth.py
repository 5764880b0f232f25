"""relight.bench.penumbra and relight.bench.shadow_truth: the penumbra width measure against the
closed form it is derived from, and the shadow_truth suite's rows on a committed reference
(plumbing and scoring; the path tracer itself is tested in tests/reference)."""
import math

import numpy as np
import pytest

from relight.bench.penumbra import transition_width, transition_width_noise


@pytest.fixture(scope="module")
def renderer(ctx):
    from viewer.renderer import Renderer

    r = Renderer(ctx=ctx)
    yield r
    r.release()


def _disc_profile(width_px: float, n: int = 128, centre: float = 60.3) -> np.ndarray:
    """The visibility of a uniform disc source behind a straight edge, full penumbra ``width_px``
    wide: the uncovered fraction of the disc (a circular segment's area)."""
    s = np.clip((np.arange(n) - centre) / (width_px / 2.0), -1.0, 1.0)
    return (np.arccos(-s) + s * np.sqrt(1.0 - s * s)) / math.pi


@pytest.mark.parametrize("width", [6.0, 13.0, 50.0])
def test_transition_width_of_a_disc_is_0687_of_its_penumbra(width):
    """10-90 % of a uniform disc's penumbra spans 0.687 of its full width (the module's closed
    form); linear interpolation between pixels costs < 3 % at 6 px (2.3 % here). Either direction
    of the row."""
    p = _disc_profile(width)
    assert transition_width(p) == pytest.approx(0.687 * width, rel=0.03)
    assert transition_width(p[::-1]) == pytest.approx(0.687 * width, rel=0.03)
    assert not transition_width(p) == pytest.approx(0.5 * width, rel=0.03)


def test_transition_width_noise_follows_the_slope():
    """The width's standard error is the profile's over its slope at each crossing, in
    quadrature: twice as steep, half the error; no crossing, NaN."""
    e = np.full(128, 0.01)
    wide, narrow = transition_width_noise(_disc_profile(40.0), e), \
        transition_width_noise(_disc_profile(20.0), e)
    assert narrow == pytest.approx(wide / 2.0, rel=0.1)
    assert math.isnan(transition_width(np.ones(16)))


def test_shadow_truth_row_on_a_committed_reference(renderer):
    """park_sphere_on_plane (the park sun casts the sphere's shadow): one row with the best of two
    cases, finite scores, and shadows on scoring above shadows off (the reference has the
    shadow); the same case with a 64-texel map (15 cm texels under a 0.5 m sphere) scores
    lower than with the default map."""
    from relight.bench.shadow_truth import shadow_truth_rows

    rows = shadow_truth_rows(renderer, names=("park_sphere_on_plane",),
                             candidates=(("ggx_split_sum", "default", {}),
                                         ("unlit", "default", {})), map_sizes=(64,))
    assert len(rows) == 1
    row = rows[0]
    assert row["model"] == "ggx_split_sum" and row["casters"].startswith("sun")
    assert all(math.isfinite(row[k]) for k in ("psnr_shadows", "psnr_without", "gain_db",
                                               "gain_vs_best_without_db"))
    assert row["gain_vs_best_without_db"] <= row["gain_db"] + 1e-9  # its baseline is the best
    assert row["gain_db"] > 0.0, row
    assert math.isfinite(row["psnr_map64"]) and row["psnr_map64"] < row["psnr_shadows"], row


def test_bench_unknown_suite_is_one_line_error(tmp_path, capsys):
    from relight.cli import main

    assert main(["bench", "--suite", "shadow_truht", "--out", str(tmp_path / "b")]) == 2
    err = capsys.readouterr().err.strip()
    assert "shadow_truht" in err and "shadow_truth" in err and "\n" not in err, err
