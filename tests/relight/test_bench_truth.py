"""relight.bench.truth: the bench's rows against path-traced references are produced, finite,
resumable, reported, and rank a deliberately wrong image below the model's own (correctness only;
no timing is asserted).

The scene and its "reference" are written in tmp_path so the test needs neither Mitsuba nor the
committed references: a 32x32 sphere on a plane under the park HDRI, and as its reference a
``ggx_mc`` render with per-pixel standard errors (what is checked here is the bench's plumbing and
scoring; the path tracer itself is tested in tests/reference)."""
import io
import json
import math

import numpy as np
import pytest

from assets import ASSET_ROOT

SCENE = "tiny_sphere_on_plane"
CASES = [("ggx_split_sum", "single-scatter", {"multiscatter": False}),
         ("ggx_split_sum", "single-scatter +ssao", {"multiscatter": False, "ssao": True}),
         ("unlit", "default", {})]
TOML = """
[camera]
position = [0.0, 1.0, 3.0]
target = [0.0, 0.0, 0.0]
fov_y = 40
size = [32, 32]

[environment]
path = "{env}"

[render]
multiscatter = false
ao = false
tonemap = "none"
background = "transparent"

[[objects]]
type = "sphere"
radius = 0.6
[objects.material]
albedo = [0.8, 0.25, 0.2]
roughness = 0.35

[[objects]]
type = "plane"
center = [0.0, -0.6, 0.0]
size = [8.0, 8.0]
[objects.material]
albedo = [0.7, 0.7, 0.7]
roughness = 0.6
"""


@pytest.fixture(scope="module")
def measured(ctx, tmp_path_factory):
    from relight.bench.run import BenchConfig
    from relight.bench.truth import converged_mc, truth_row, truth_scenes
    from relight.reference import Reference, read_reference, write_reference
    from viewer.renderer import Renderer
    from viewer.scene.description import load_scene

    folder = tmp_path_factory.mktemp("reference")
    toml = TOML.format(env=ASSET_ROOT / "environments" / "park.exr")
    (folder / f"{SCENE}.toml").write_text(toml)
    (folder / "no_reference_yet.toml").write_text(toml)
    cache = tmp_path_factory.mktemp("cache")
    config = BenchConfig(quick=True, frames=1, warmup=0, truth_spp=32)
    r = Renderer(ctx=ctx)
    try:
        stand_in = load_scene(folder / f"{SCENE}.toml").with_render(model="ggx_mc", samples=128,
                                                                     seed=99)
        radiance = r.render(stand_in).radiance  # [H, W, 4]
        stderr = np.full(radiance.shape[:2] + (3,), 1e-3, np.float32)
        write_reference(Reference(radiance=radiance, stderr=stderr, meta={"spp": 128}),
                        folder / f"{SCENE}.exr")
        with pytest.warns(UserWarning, match="no stored reference for no_reference_yet"):
            found = truth_scenes(folder=folder, references=folder)
        ts = found[0]
        truth = read_reference(ts.reference)
        mc = converged_mc(r, ts, cache, config.truth_spp)
        rows = [truth_row(r, ts, case, truth, mc, config) for case in CASES]
        image = r.render(ts.scene.with_render(model="ggx_split_sum")).radiance
        again = converged_mc(r, ts, cache, config.truth_spp)
    finally:
        r.release()
    return {"found": found, "ts": ts, "truth": truth, "mc": mc, "again": again, "rows": rows,
            "image": image, "cache": cache}


def test_only_scenes_with_a_reference_are_benched(measured):
    assert [t.name for t in measured["found"]] == [SCENE]


def test_truth_rows_are_complete_and_finite(measured):
    from relight.bench.truth import TRUTH_KEYS

    for row, (model, variant, _) in zip(measured["rows"], CASES):
        assert (row["scene"], row["model"], row["variant"]) == (SCENE, model, variant)
        assert row["kind"] == "truth" and row["group"] == "occluded"
        assert row["size"] == [32, 32] and "note" not in row
        for k in TRUTH_KEYS + ("ms", "bias_noise_truth", "bias_noise_mc"):
            assert math.isfinite(row[k]), (k, row)
        assert row["pixels"] > 500
        json.dumps(row)  # what rows.jsonl stores


def test_converged_mc_is_cached_with_standard_errors(measured):
    mc, again = measured["mc"], measured["again"]
    assert mc.meta["spp"] == 32 and mc.meta["model"] == "ggx_mc"
    assert np.array_equal(mc.radiance, again.radiance)  # read back, not re-rendered
    assert np.all(np.isfinite(mc.stderr)) and mc.stderr.max() > 0
    assert mc.radiance.shape == measured["truth"].radiance.shape
    assert list(measured["cache"].glob("truth_*ggx_mc_32spp.stderr.exr"))


def test_a_wrong_image_scores_worse(measured):
    from relight.bench.truth import truth_errors

    good = truth_errors(measured["image"], measured["truth"], measured["mc"])
    wrong_image = measured["image"].copy()
    wrong_image[..., :3] *= 1.5
    wrong = truth_errors(wrong_image, measured["truth"], measured["mc"])
    for ref in ("truth", "mc"):
        assert wrong[f"median_rel_{ref}"] > good[f"median_rel_{ref}"]
        assert wrong[f"psnr_{ref}"] < good[f"psnr_{ref}"]
        assert wrong[f"bias_{ref}"] > good[f"bias_{ref}"] + 0.3
    # and an unlit render (albedo only) is further from the truth than the split sum
    split, _, unlit = measured["rows"]
    assert unlit["median_rel_truth"] > split["median_rel_truth"]
    assert unlit["psnr_truth"] < split["psnr_truth"]


def test_the_reference_scores_itself_perfectly(measured):
    from relight.bench.truth import truth_errors

    truth = measured["truth"]
    e = truth_errors(truth.radiance, truth, truth)
    assert e["median_rel_truth"] == 0.0 and e["bias_truth"] == 0.0 and e["psnr_truth"] == math.inf


def test_scene_lists_and_cases():
    from relight.bench.run import BenchConfig, _cases
    from relight.bench.truth import QUICK_SCENES, REFERENCE_SCENES, truth_cases
    from viewer.scene.description import load_scene

    committed = {p.stem for p in REFERENCE_SCENES.glob("*.toml")}
    assert set(QUICK_SCENES) < committed  # --quick is a proper subset of the committed scenes
    assert any(len(load_scene(REFERENCE_SCENES / f"{n}.toml").objects) > 1 for n in QUICK_SCENES)
    cases = _cases(BenchConfig(quick=True))
    tc = truth_cases(cases, quick=True)
    assert [c for c in tc if "ssao" not in c[1]] == cases
    assert ("ggx_split_sum", "single-scatter +ssao +indirect") in {(m, v) for m, v, _ in tc}
    assert len({(m, v) for m, v, _ in tc}) == len(tc)  # unique row keys


def test_truth_rows_resume_without_rendering(measured, monkeypatch):
    """Rows already logged are reused: nothing is rendered (the renderer is a sentinel)."""
    from relight.bench import run
    from relight.bench.run import BenchConfig

    monkeypatch.setattr(run, "truth_scenes", lambda quick: [measured["ts"]])
    monkeypatch.setattr(run, "truth_cases", lambda cases, quick: CASES)
    done = {run._row_key(r): r for r in measured["rows"]}
    log = io.StringIO()
    rows = run._truth_rows(object(), [], BenchConfig(quick=True), measured["cache"], done, log,
                           progress=False)
    assert rows == measured["rows"] and log.getvalue() == ""


def test_reports_carry_the_truth_columns(measured, tmp_path):
    from relight.bench.run import write_reports
    from relight.bench.truth import TRUTH_KEYS

    other = {"scene": "mesh", "model": "unlit", "variant": "default", "samples": 1,
             "size": [16, 16], "ms": 1.0, "psnr": 20.0, "ssim": 0.5, "flip": 0.3}
    rows = [other] + [dict(r) for r in measured["rows"]]
    rows.append({**rows[-1], "scene": "other_sphere", "group": "convex"})
    report = {"machine": {"gl": {"renderer": "test"}, "cpus": 2, "platform": "test",
                          "date": "today"},
              "results": rows, "specialization": []}
    write_reports(tmp_path, report)
    header = (tmp_path / "bench.csv").read_text().splitlines()[0].split(",")
    assert set(TRUTH_KEYS) <= set(header)
    md = (tmp_path / "bench.md").read_text()
    assert "### against truth" in md and f"**occluded scenes** ({SCENE})" in md
    assert "single-scatter +ssao" in md
    summary = json.loads((tmp_path / "bench.json").read_text())["truth_summary"]
    assert {"all", "convex", "occluded"} == set(summary)
    split = next(e for e in summary["occluded"] if e["variant"] == "single-scatter")
    assert split["ms_ratio"] == 1.0
    pytest.importorskip("matplotlib")
    assert (tmp_path / "pareto.png").stat().st_size > 0
