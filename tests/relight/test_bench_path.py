"""relight.bench.path (``relight bench --suite path``): on a tiny configuration (one 64 x 64
reference scene, 2 seeds x 1 spp, a 1000-triangle BVH) the rows carry the columns the tables
show; the bench's ray kernel finds what ``passes/parity_raytrace.comp`` finds; the block z-test
accepts noise and rejects a 20 % bias; Mitsuba's columns where its LLVM backend runs."""
import math

import numpy as np
import pytest

SCENE = "assets/scenes/reference/park_sphere_on_plane.toml"
SCENE_COLUMNS = ["kind", "scene", "triangles", "build_ms", "size", "spp", "blocks", "failing",
                 "max_z", "z_threshold", "bias_%", "bias_noise_%", "psnr_db", "ms_per_spp",
                 "path_Msps", "details"]
BVH_COLUMNS = ["kind", "scene", "triangles", "build_ms", "bvh_ms", "nodes", "bvh_MB", "gpu_MB",
               "sah_cost", "rays", "closest_Mrays_s", "any_Mrays_s", "details"]


@pytest.fixture(scope="module")
def rows(ctx):
    from relight.bench.path import PathBenchConfig, path_rows
    from viewer.renderer import Renderer

    r = Renderer(ctx=ctx)
    cfg = PathBenchConfig(seeds=2, spp=1, scenes=(SCENE,), mitsuba=False, triangles=(1000,),
                          shapes=("soup",), rays=512)
    try:
        yield path_rows(r, cfg)
    finally:
        r.release()


def test_rows_have_the_tables_columns(rows):
    from relight.bench.report import suite_table
    from relight.bench.suites import SUITES

    assert "path" in SUITES
    scene, bvh = rows
    assert list(scene) == SCENE_COLUMNS
    assert list(bvh) == BVH_COLUMNS
    assert scene["scene"] == "park_sphere_on_plane" and scene["size"] == [64, 64]
    assert scene["spp"] == 1 and scene["details"]["seeds"] == 2
    assert scene["triangles"] > 1000 and scene["build_ms"] > 0
    assert scene["blocks"] > 100 and 0 <= scene["failing"] <= scene["blocks"]
    assert scene["z_threshold"] > 3 and math.isfinite(scene["max_z"])
    assert abs(scene["bias_%"]) < 50 and scene["bias_noise_%"] > 0
    assert 5 < scene["psnr_db"] < 60
    assert scene["path_Msps"] == pytest.approx(64 * 64 / scene["ms_per_spp"] / 1e3)
    assert bvh["scene"] == "soup" and bvh["triangles"] == 1000 and bvh["rays"] == 512
    assert bvh["nodes"] > 1000 / 8 and 0 < bvh["bvh_MB"] < bvh["gpu_MB"]
    assert bvh["sah_cost"] > 1 and bvh["closest_Mrays_s"] > 0 and bvh["any_Mrays_s"] > 0
    assert 0 < bvh["bvh_ms"] <= bvh["build_ms"]
    header = suite_table(rows)[0]
    for key in ("failing", "bias_%", "path_Msps", "closest_Mrays_s"):
        assert f" {key} " in header
    assert "details" not in header  # nested: in the json only


def test_bench_kernel_traces_as_the_parity_kernel(programs):
    from relight.bench.path import bench_mesh, random_rays, trace
    from viewer.gl.kernels import run_kernel
    from viewer.raytrace.scene import build_trace_geometry
    from viewer.raytrace.upload import TraceBuffers

    mesh = bench_mesh("soup", 1000)
    buffers = TraceBuffers(programs.ctx, build_trace_geometry([mesh]))
    try:
        buffers.set_materials([mesh])
        rays = random_rays(256, seed=3)
        closest = trace(programs, buffers, rays)
        anyhit = trace(programs, buffers, rays, any_hit=True)
        parity = run_kernel(programs, "passes/parity_raytrace.comp", rays, 5,
                            lambda prog: buffers.bind(prog, 0))
    finally:
        buffers.release()
    assert np.array_equal(closest[:, 1], parity[:, 1])
    assert np.array_equal(closest[:, 0], parity[:, 0])
    assert np.array_equal(anyhit[:, 0], parity[:, 4])
    assert 0.2 < (closest[:, 1] >= 0).mean() < 1.0  # some rays hit, some miss


def test_block_test_accepts_noise_and_rejects_a_bias():
    from relight.bench.path import block_test, energy_bias
    from relight.reference.compare import Reference

    rng = np.random.default_rng(0)
    truth = rng.uniform(0.2, 1.0, (32, 32, 3))
    ref = Reference(radiance=np.concatenate([truth, np.ones((32, 32, 1))], -1).astype(np.float32),
                    stderr=np.full((32, 32, 3), 0.01, np.float32))

    def runs(scale):
        noisy = scale * truth + rng.normal(0.0, 0.1, (8, 32, 32, 3))
        return np.concatenate([noisy, np.ones((8, 32, 32, 1))], -1)
    good = block_test(runs(1.0), ref)
    assert good.passed and good.count == 8 * 8 * 3
    assert not block_test(runs(1.2), ref).passed
    bias, noise = energy_bias(runs(1.2), ref)
    assert bias == pytest.approx(0.2, abs=5 * noise) and 0 < noise < 0.01


def test_quick_configuration_and_scenes():
    from relight.bench.path import PathBenchConfig, reference_scenes
    from relight.bench.run import BenchConfig

    quick = PathBenchConfig.from_bench(BenchConfig(quick=True))
    assert quick.spp < PathBenchConfig().spp and 1_000_000 not in quick.triangles
    assert 1_000_000 in PathBenchConfig.from_bench(BenchConfig()).triangles
    pairs = reference_scenes()
    names = [s.stem for s, _ in pairs]
    assert "park_sphere_on_plane" in names and "studio_key_spheres" in names
    assert all(ref.stem == scene.stem and ref.is_file() for scene, ref in pairs)


def test_mitsuba_columns(mitsuba_llvm):
    from relight.bench.path import mitsuba_speed
    from viewer.scene.description import load_scene

    scene = load_scene(SCENE).with_camera(size=(16, 16))
    speed = mitsuba_speed(scene, 4, 6)
    assert set(speed) == {"mitsuba_spp", "mitsuba_Msps", "mitsuba_setup_s", "mitsuba_jit_s"}
    assert speed["mitsuba_spp"] == 4 and speed["mitsuba_Msps"] > 0
    assert speed["mitsuba_setup_s"] > 0 and speed["mitsuba_jit_s"] >= 0


def test_gpu_check_prints_the_renderer_and_stops_a_step_past_its_budget(tmp_path, capsys):
    """``python -m relight.bench.gpu_check``: ``relight info`` first, a summary of every step;
    a step that outlives the budget is stopped and recorded, the next one not run."""
    from relight.bench.gpu_check import STEPS, run_check, step_commands

    assert step_commands(tmp_path)["path"][:4] == ["bench", "--suite", "path", "--quick"]
    assert STEPS[0] == "info"
    summary = run_check(tmp_path / "a", steps=("info",))
    assert summary["complete"] and summary["renderer"]
    assert summary["renderer"] in capsys.readouterr().out
    assert (tmp_path / "a" / "info.json").is_file()
    assert summary["renderer"] in (tmp_path / "a" / "summary.md").read_text()
    summary = run_check(tmp_path / "b", budget=2.0, steps=("parity", "path"))
    assert [(e["step"], e["status"]) for e in summary["steps"]] == [
        ("parity", "timed out"), ("path", "not run (budget spent)")]
    assert not summary["complete"]


def test_gpu_check_writes_a_partial_main_table_from_the_rows_it_measured(tmp_path):
    """A main step stopped at the budget (an H200 lease, 2026-11-28: the rays suite ran past it)
    still leaves its measured rows as ``bench/bench.md``, headed as partial, with the card's name
    from ``info.json``; a finished table newer than the rows is left alone."""
    import json
    import os

    from relight.bench.gpu_check import partial_main_report

    (tmp_path / "bench").mkdir()
    assert partial_main_report(tmp_path) == 0  # no rows: nothing written
    (tmp_path / "info.json").write_text(json.dumps({"renderer": "Card X/PCIe"}))
    (tmp_path / "host.json").write_text(json.dumps({"cpus": 16, "platform": "Linux-test"}))
    row = {"scene": "mesh", "model": "unlit", "variant": "default", "samples": 1,
           "size": [160, 100], "ms": 0.17, "psnr": 15.7, "ssim": 0.67, "flip": 0.4,
           "rmse": 0.66, "passes": {"gbuffer": 0.14}}
    rows = tmp_path / "bench" / "rows.jsonl"
    rows.write_text("\n".join(json.dumps({**row, "model": m, "ms": ms})
                              for m, ms in (("unlit", 0.17), ("blinn_phong", 0.21))) + "\n")
    assert partial_main_report(tmp_path) == 2
    md = (tmp_path / "bench" / "bench.md").read_text()
    assert md.startswith("**Partial**") and "2 rows" in md
    assert "Card X/PCIe (16 CPUs, Linux-test)" in md
    assert "| mesh | blinn_phong | default | 1 | 160x100 | 0.21 |" in md
    t = rows.stat().st_mtime + 10
    os.utime(tmp_path / "bench" / "bench.md", (t, t))
    assert partial_main_report(tmp_path) == 0  # the table is newer than the rows
