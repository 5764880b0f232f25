"""Targets from truth (issue 14, item 1): the generator's rgb.exr path-traced by `relight
reference` (Mitsuba, our BSDF, pixel-centre rays) beside the rasteriser's G-buffer inputs and its
unoccluded ggx_mc target. Skipped, with the reason, without Mitsuba or a libLLVM >= 19."""
import json
import shutil

import numpy as np
import pytest

from learned.data import DatasetError, list_samples, load_sample
from learned.data import generator as gen
from learned.data.generator import GeneratorConfig, generate

# sample 0: one sphere alone (convex: truth = the unoccluded integral); sample 1: a sphere resting
# on a floor (contact shadow). ggx_mc at 1024 samples so its noise (~1/4 of the reference's per
# pixel at 64 spp, or less with MIS) barely widens the reference's error bars.
TRUTH = GeneratorConfig(count=2, size=16, samples=1024, seed=1, env_width=32,
                        scene_kinds=("convex", "sphere_on_plane"), targets="reference",
                        reference_spp=64, reference_depth=4)


@pytest.fixture(scope="module")
def truth(tmp_path_factory, generate_data, mitsuba_llvm):
    root = tmp_path_factory.mktemp("truth") / "d"
    assert generate_data(root, TRUTH)["written"] == 2
    return root


def _interior(fg):
    """Foreground pixels whose 4 neighbours are foreground (silhouette pixels differ by coverage)."""
    m = np.zeros_like(fg)
    m[1:-1, 1:-1] = (fg[1:-1, 1:-1] & fg[:-2, 1:-1] & fg[2:, 1:-1] & fg[1:-1, :-2]
                     & fg[1:-1, 2:])
    return m


def test_truth_dataset_layout_and_metadata(truth):
    info = json.loads((truth / "dataset.json").read_text())
    assert info["targets"]["source"] == "reference" and info["config"]["reference_spp"] == 64
    for folder in list_samples(truth, "train"):
        s = load_sample(folder)
        assert s.target_source == "reference"
        for img in (s.target, s.unoccluded, s.target_stderr):
            assert img.shape == (16, 16, 3) and np.isfinite(img).all()
        assert (s.target_stderr >= 0).all() and s.target_stderr.max() > 0
        meta = json.loads((folder / "meta.json").read_text())
        assert meta["target"]["spp"] == 64 and meta["target"]["max_depth"] == 4
        assert meta["target"]["rays"] == "pixel centre"
        # the path tracer ignores baked AO, so the inputs carry none either
        assert np.allclose(s.channels["ao"][s.foreground()], 1.0)
    assert not list((truth / "_checkpoints").iterdir())  # removed once each render completed


def test_truth_equals_unoccluded_on_a_convex_object(truth):
    """One sphere alone: no visibility, so the path-traced target and the rasteriser's unoccluded
    ggx_mc estimate the same integral. Per pixel: z-test with Bonferroni correction (false-alarm
    rate 1 %, the reference's standard error; ggx_mc's own noise is ignored, which only makes the
    test stricter). Mean level: the difference within 4 standard errors of the reference's mean."""
    from relight.reference import Reference
    from relight.reference.compare import z_test

    s = load_sample(truth / "train" / "000000")
    assert json.loads((s.folder / "meta.json").read_text())["geometry"]["kind"] == "convex"
    m = _interior(s.foreground())
    assert m.sum() >= 20
    ref = Reference(radiance=np.concatenate([s.target, np.ones_like(s.target[..., :1])], -1),
                    stderr=s.target_stderr)
    z = z_test(s.unoccluded, ref, mask=m, alpha=0.01)
    assert z.passed, z
    diff = float(s.target[m].mean() - s.unoccluded[m].mean())
    se = float(np.sqrt((s.target_stderr[m].astype(np.float64) ** 2).sum()) / s.target[m].size)
    assert abs(diff) < 4 * se, (diff, se)


def test_truth_has_the_contact_shadow(truth):
    """A sphere resting on a floor: on the floor within 0.7 radii (horizontally) of the contact
    point, where the sphere hides much of the sky, truth is darker than the unoccluded target by
    far more than the reference's noise (measured here: ~0.3-0.5 x)."""
    s = load_sample(truth / "train" / "000001")
    meta = json.loads((s.folder / "meta.json").read_text())
    assert meta["geometry"]["kind"] == "sphere_on_plane"
    sphere, plane = meta["objects"]
    c, r, y = np.array(sphere["center"]), sphere["radius"], plane["center"][1]
    assert c[1] - r == pytest.approx(y)  # resting on it
    v = s.view_dirs().astype(np.float64)
    p = v * (y / np.minimum(v[..., 1], -1e-9))[..., None]  # the ray's floor hit
    b = (v * c).sum(-1)
    misses_sphere = b * b - (c @ c - r * r) < 0
    near = (v[..., 1] < 0) & misses_sphere & (np.hypot(p[..., 0] - c[0], p[..., 2] - c[2]) < 0.7 * r)
    assert near.sum() >= 3
    t, u = s.target[near].mean(), s.unoccluded[near].mean()
    se = float(np.sqrt((s.target_stderr[near].astype(np.float64) ** 2).sum()) / s.target[near].size)
    assert t < 0.8 * u and u - t > 6 * se, (t, u, se)


def test_truth_resumes_and_skips_finished_samples(truth, tmp_path, generate_data):
    other = tmp_path / "again"
    shutil.copytree(truth, other)
    assert generate_data(other, TRUTH) == {"written": 0, "kept": 2, "root": str(other)}
    victim = other / "train" / "000001"
    before = load_sample(victim).target
    shutil.rmtree(victim)
    (victim.parent / "000001.tmp").mkdir()  # an interrupted write
    assert generate_data(other, TRUTH) == {"written": 1, "kept": 1, "root": str(other)}
    assert np.array_equal(load_sample(victim).target, before)  # deterministic for the seed
    assert not (victim.parent / "000001.tmp").exists()


def test_generation_shards_across_ranks(tmp_path, generate_data, monkeypatch):
    """Sample i belongs to rank i % WORLD_SIZE; each rank waits for the others' samples (here
    rank 1 runs first and gives up at once; rank 0 then finds rank 1's sample and returns)."""
    cfg = GeneratorConfig(count=3, size=16, samples=4, seed=2, env_width=32)
    root = tmp_path / "d"
    monkeypatch.setenv("WORLD_SIZE", "2")
    monkeypatch.setenv("RANK", "1")
    with pytest.raises(DatasetError, match="2 samples of other ranks still missing"):
        generate_data(root, cfg, shard=True, wait_s=0.0)
    assert [p.name for p in sorted((root / "train").iterdir())] == ["000001"]
    monkeypatch.setenv("RANK", "0")
    res = generate_data(root, cfg, shard=True, wait_s=5.0)
    assert res == {"written": 2, "kept": 0, "root": str(root), "rank": 0, "world_size": 2}
    assert [p.name for p in sorted((root / "train").iterdir())] == ["000000", "000001", "000002"]


def test_truth_configuration_errors(tmp_path, monkeypatch):
    with pytest.raises(DatasetError, match="no geometry to path-trace"):
        gen.check_config(GeneratorConfig(targets="reference", gbuffer_fraction=0.5))
    with pytest.raises(DatasetError, match="targets 'mitsuba' is not one of"):
        gen.check_config(GeneratorConfig(targets="mitsuba"))
    with pytest.raises(DatasetError, match="unknown scene kind 'cube'"):
        gen.check_config(GeneratorConfig(scene_kinds=("cube",)))
    with pytest.raises(DatasetError, match="needs a path tracer"):
        generate(tmp_path / "x", GeneratorConfig(targets="reference"), progress=False)
    assert not (tmp_path / "x").exists()  # nothing written


def test_reference_tracer_names_what_to_install(monkeypatch):
    """Without Mitsuba or a libLLVM >= 19: one line naming the package to install."""
    import importlib.util

    from relight.commands import reference_tracer
    from relight.reference import render
    from viewer.errors import RelightError

    real = importlib.util.find_spec
    monkeypatch.setattr(importlib.util, "find_spec",
                        lambda name, *a: None if name == "mitsuba" else real(name, *a))
    with pytest.raises(RelightError, match=r"pip install -e '.\[reference\]'"):
        reference_tracer()
    monkeypatch.setattr(importlib.util, "find_spec",  # Mitsuba "installed", no LLVM
                        lambda name, *a: object() if name == "mitsuba" else real(name, *a))
    monkeypatch.setattr(render, "find_libllvm", lambda: None)
    with pytest.raises(RelightError, match="apt-get install libllvm19") as err:
        reference_tracer()
    assert "\n" not in str(err.value)


def test_train_targets_flag(tmp_path, capsys):
    """`relight train --targets reference` makes its own dataset: with --data it is a one-line
    error; the recipe it generates is a valid configuration."""
    from learned.train.config import QUICK_DATA
    from relight.cli import main

    assert main(["train", "--targets", "reference", "--data", str(tmp_path),
                 "--out", str(tmp_path / "run")]) == 2
    err = capsys.readouterr().err.strip()
    assert "drop --data" in err and "\n" not in err
    gen.check_config(GeneratorConfig(**(QUICK_DATA | {"gbuffer_fraction": 0.0,
                                                      "scene_kinds": gen.TRUTH_KINDS})))
