"""relight.bench.environments: the environment-loading suite is registered and its rows are
complete and consistent (a benchmark: times are not asserted, only that every case was measured,
the disk-cache rows hit the cache and the others did not)."""
import math

import pytest


@pytest.fixture(scope="module")
def rows(ctx, tmp_path_factory):
    from relight.bench.environments import environment_rows

    return environment_rows(ctx, tmp_path_factory.mktemp("envbench"), width=64, runs=1,
                            legacy_runs=1, size=(32, 32))


def test_suite_is_registered():
    from relight.bench.run import SUITES

    assert "environments" in SUITES


def test_rows_cover_every_case_and_method(rows):
    from relight.bench.environments import METHODS

    got = {(r["case"], r["method"]) for r in rows}
    first, new = "warm process, new file, first frame", "new process, same file, environment part"
    assert got == {(first, METHODS["fis"]), (first, METHODS["convolution+disk"]),
                   (new, METHODS["fis"]), (new, METHODS["convolution"]),
                   (new, METHODS["convolution+disk"])}
    for r in rows:
        assert r["runs"] == 1 and r["map"] == "sky 64x32 EXR (sun)"
        assert math.isfinite(r["ms"]) and r["ms"] > 0 and 0 < r["env_ms"] <= r["ms"] + 1e-6
        assert math.isfinite(r["speedup"])
        # only the new process with the disk cache reads it (the IBL and the LUTs)
        hit = r["case"] == new and r["method"] == METHODS["convolution+disk"]
        assert (r["disk_hits"] >= 2) == hit, r


def test_report_has_the_section(rows, tmp_path):
    from relight.bench.report import write_reports

    report = {"machine": {"gl": {"renderer": "test"}, "cpus": 2, "platform": "test",
                          "date": "today"}, "results": [], "specialization": [],
              "environments": rows}
    write_reports(tmp_path, report)
    md = (tmp_path / "bench.md").read_text()
    assert "### environments" in md and "convolution + disk cache" in md


def test_diffuse_rows_compare_both_methods_with_the_exact_sum(tmp_path):
    """relight.bench.env_diffuse on a small map with a sun: one row per method, errors finite,
    the irradiance map's far below SH9's (measured here: 0.02 % vs 0.80 % at the floor, 0.48 % vs
    2.2 % at worst)."""
    pytest.importorskip("torch")
    from relight.bench.env_diffuse import diffuse_rows
    from viewer.environment.maps import sky_environment
    from viewer.imageio import write_exr

    path = tmp_path / "sky.exr"
    write_exr(path, sky_environment(256, sun_elevation_deg=20.0))
    rows = {r["method"]: r for r in diffuse_rows([path])}
    before, now = rows["SH9 + 1 sun (before)"], rows["irradiance map + lights"]
    assert before["lights"] == 1 and now["lights"] >= 1
    assert abs(now["floor_err_pct"]) < 0.5 < abs(before["floor_err_pct"])
    assert now["max_abs_err_pct"] < 1.0 < before["max_abs_err_pct"]
