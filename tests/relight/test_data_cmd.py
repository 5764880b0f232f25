"""`relight data OUT --preset NAME`: the presets are the configurations the shipped weights and the
README's held-out scores were made with (learned/data/presets.py), the command line maps onto
them, a tiny real run writes a dataset the reader loads and a re-run keeps, and a missing Mitsuba
is one line that writes nothing. The tiny run is skipped without Mitsuba or a libLLVM >= 19."""
import json
import os
from dataclasses import asdict, replace

import pytest

from learned.data import DatasetError, list_samples, load_sample
from learned.data import generator as gen
from learned.data.presets import PRESETS, preset_config
from relight.cli import build_parser, main
from relight.commands import _data_config, _truth_config

# the configurations in dataset.json of the stored sets (runs/truth2, runs/heldout-kinds,
# runs/heldout-env, runs/shadow-*; count aside), as JSON: a preset that drifts from them (a changed default of
# GeneratorConfig included) no longer regenerates those sets
_COMMON = {"size": 64, "samples": 256, "env_width": 128, "meshes": True, "gbuffer_fraction": 0.0,
           "gbuffers": [], "targets": "reference", "reference_spp": 256, "reference_depth": 4,
           "degrade": 0.0,
           # added since (the defaults reproduce the stored sets: the fixed split pattern, no
           # sunless samples)
           "split": "", "sunless_fraction": 0.0, "ground_fraction": 0.0}
_TRUTH_KINDS = ["random", "sphere_on_plane", "cluster", "random", "touching_spheres", "concave",
                "random", "cluster", "gltf"]
STORED = {
    # runs/truth3g (half the samples sunless, a quarter over a bright ground; runs/truth2-sun50,
    # the student's before, had no ground; runs/truth2, the one before it, no sunless sample)
    "truth-train": _COMMON | {
        "count": 480, "seed": 0, "scene_kinds": _TRUTH_KINDS, "sunless_fraction": 0.5,
        "ground_fraction": 0.25,
        "env_paths": ["assets/environments/sky.exr", "assets/environments/park.exr"],
        "env_procedural": ["sky", "sky", "studio"]},
    "heldout-kinds": _COMMON | {
        "count": 40, "seed": 1, "scene_kinds": ["nested", "convex"],
        "env_paths": ["assets/environments/esplanade.exr"], "env_procedural": []},
    "heldout-env": _COMMON | {
        "count": 40, "seed": 7, "scene_kinds": _TRUTH_KINDS,
        "env_paths": ["assets/environments/esplanade.exr"], "env_procedural": []},
    # the neural shadow estimator's extra training and second validation sets (issue 38)
    "shadow-extra": _COMMON | {
        "count": 160, "size": 96, "reference_spp": 64, "seed": 300, "scene_kinds": _TRUTH_KINDS,
        "env_paths": [f"assets/environments/training/{n}.exr"
                      for n in ("bridge", "dawn", "night", "sunrise", "venice")],
        "env_procedural": [], "split": "train"},
    "shadow-val": _COMMON | {
        "count": 60, "size": 96, "reference_spp": 64, "seed": 400, "scene_kinds": _TRUTH_KINDS,
        "env_paths": [f"assets/environments/training/{n}.exr"
                      for n in ("city", "forest", "sunset")],
        "env_procedural": [], "split": "val"},
    # made objects for the estimator (runs/shadow-blocks, runs/shadow-blocks-val)
    "shadow-blocks": _COMMON | {
        "count": 160, "size": 96, "reference_spp": 64, "seed": 302, "scene_kinds": ["blocks"],
        "env_paths": [f"assets/environments/training/{n}.exr"
                      for n in ("bridge", "dawn", "night", "sunrise", "venice")],
        "env_procedural": [], "split": "train"},
    "shadow-blocks-val": _COMMON | {
        "count": 40, "size": 96, "reference_spp": 64, "seed": 402, "scene_kinds": ["blocks"],
        "env_paths": [f"assets/environments/training/{n}.exr"
                      for n in ("city", "forest", "sunset")],
        "env_procedural": [], "split": "val"},
}


@pytest.mark.parametrize("name", sorted(STORED))
def test_preset_is_the_stored_configuration(name):
    assert set(PRESETS) == set(STORED)
    assert json.loads(json.dumps(asdict(PRESETS[name]()))) == STORED[name]


def test_presets_are_the_documented_recipe():
    """The recipe assets/weights/README.md documented (a training config, held_out_config of it,
    and the training kinds under esplanade at seed 7), and what makes the held-out sets held out:
    no environment of the training set, and (heldout-kinds) no scene kind of it either."""
    train = gen.GeneratorConfig(count=480, size=64, samples=256, seed=0, gbuffer_fraction=0.0,
                                targets="reference", reference_spp=256,
                                scene_kinds=gen.TRUTH_KINDS, env_paths=gen.TRUTH_ENV_PATHS,
                                sunless_fraction=0.5, ground_fraction=0.25)
    assert PRESETS["truth-train"]() == train
    assert PRESETS["heldout-kinds"]() == replace(gen.held_out_config(train, count=40),
                                                 sunless_fraction=0.0, ground_fraction=0.0)
    assert PRESETS["heldout-env"]() == replace(train, count=40, seed=7,
                                                env_paths=gen.HELD_OUT_ENV_PATHS,
                                                env_procedural=(), sunless_fraction=0.0,
                                                ground_fraction=0.0)
    envs = {gen._env_identity(e) for e in (*train.env_procedural, *train.env_paths)}
    for name in ("heldout-kinds", "heldout-env"):
        held = PRESETS[name]()
        assert held.env_paths and not held.env_procedural
        assert not envs & {gen._env_identity(e) for e in held.env_paths}
        assert held.seed != train.seed
    assert not set(PRESETS["heldout-kinds"]().scene_kinds) & set(train.scene_kinds)
    assert PRESETS["heldout-env"]().scene_kinds == train.scene_kinds


def test_shadow_presets_share_no_environment_with_each_other_or_the_protocol():
    """shadow-extra and shadow-val: files that exist, no environment (resolved) or seed in common
    with each other, with the protocol's val (esplanade) and test (park) splits, or with the
    other presets; every sample in the preset's one split."""
    from learned.protocol.data import SPLIT_ENVIRONMENTS

    ids = lambda paths: {gen._env_identity(e) for e in paths}
    extra, val = PRESETS["shadow-extra"](), PRESETS["shadow-val"]()
    for cfg in (extra, val):
        assert cfg.env_paths and not cfg.env_procedural
        assert all(gen.config.env_file(e).is_file() for e in cfg.env_paths), cfg.env_paths
    assert len(ids(extra.env_paths)) == 5 and len(ids(val.env_paths)) == 3
    assert not ids(extra.env_paths) & ids(val.env_paths)
    held = ids(SPLIT_ENVIRONMENTS["val"][1] + SPLIT_ENVIRONMENTS["test"][1])
    others = ids(e for n in ("truth-train", "heldout-kinds", "heldout-env")
                 for e in PRESETS[n]().env_paths)
    assert len(held) == 2 and held <= others
    for cfg in (extra, val):
        assert not ids(cfg.env_paths) & others
    assert len({PRESETS[n]().seed for n in PRESETS}) == len(PRESETS)
    assert [gen.split_of(i, extra) for i in (0, 8, 9)] == ["train"] * 3
    assert [gen.split_of(i, val) for i in (0, 8, 9)] == ["val"] * 3


def test_train_targets_reference_uses_the_truth_preset():
    """`relight train --targets reference` generates the truth-train preset with its --count
    (default the quick dataset's 40) and --reference-spp: the recipe it had before the preset,
    now with the preset's sunless half and bright-ground quarter (the shipped student's data)."""
    from learned.train.config import QUICK_DATA

    args = build_parser().parse_args(["train", "--targets", "reference"])
    old = gen.GeneratorConfig(**(dict(QUICK_DATA) | {
        "gbuffer_fraction": 0.0, "targets": "reference", "reference_spp": 256,
        "scene_kinds": gen.TRUTH_KINDS, "env_paths": gen.TRUTH_ENV_PATHS,
        "sunless_fraction": 0.5, "ground_fraction": 0.25}))
    assert _truth_config(args) == old == replace(PRESETS["truth-train"](), count=40)
    args = build_parser().parse_args(["train", "--targets", "reference", "--count", "480",
                                      "--reference-spp", "64"])
    assert _truth_config(args) == replace(PRESETS["truth-train"](), reference_spp=64)


def _config(*argv):
    return _data_config(build_parser().parse_args(["data", "out", *argv]))


def test_cli_builds_the_preset_config():
    for name in PRESETS:
        assert _config("--preset", name) == PRESETS[name]()
    cfg = _config("--preset", "heldout-env", "--count", "3", "--size", "16", "--spp", "8",
                  "--seed", "11")
    assert cfg == replace(PRESETS["heldout-env"](), count=3, size=16, reference_spp=8, seed=11)
    assert _config("--preset", "heldout-kinds", "--count", "2") == replace(
        PRESETS["heldout-kinds"](), count=2)  # the rest stays the preset's (seed 1)
    # every preset is named in the option's help (the parser does not import learned)
    helps = {a.dest: a.help for a in build_parser()._subparsers._group_actions[0]
             .choices["data"]._actions}
    assert all(name in helps["preset"] for name in PRESETS)


def test_cli_rejects_bad_options(tmp_path, capsys):
    with pytest.raises(DatasetError, match="unknown preset 'heldout'"):
        _config("--preset", "heldout")
    with pytest.raises(DatasetError, match="at least 2"):  # the standard error needs 2 samples
        _config("--preset", "heldout-env", "--spp", "1")
    with pytest.raises(DatasetError, match="cannot be overridden"):
        preset_config("heldout-env", env_paths=())
    out = tmp_path / "d"
    assert main(["data", str(out), "--preset", "nope"]) == 2
    err = capsys.readouterr().err.strip()
    assert "unknown preset 'nope'" in err and "truth-train" in err and "\n" not in err
    for argv in (["--preset", "heldout-env", "--count", "0"],
                 ["--preset", "heldout-env", "--size", "-4"], []):  # --preset is required
        with pytest.raises(SystemExit) as exc:
            main(["data", str(out), *argv])
        assert exc.value.code == 2
    assert not out.exists()


def test_missing_mitsuba_is_one_line_and_writes_nothing(tmp_path, monkeypatch, capsys):
    import importlib.util

    real = importlib.util.find_spec
    monkeypatch.setattr(importlib.util, "find_spec",
                        lambda name, *a: None if name == "mitsuba" else real(name, *a))
    out = tmp_path / "d"
    assert main(["data", str(out), "--preset", "heldout-env", "--count", "1"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("relight: error: relight data:") and "\n" not in err
    assert "pip install -e '.[reference]'" in err
    assert not out.exists()


@pytest.fixture(scope="module")
def tiny(tmp_path_factory, ctx, mitsuba_llvm):
    """heldout-kinds, 2 samples of 8x8 at 4 spp (a nested scene and the convex control)."""
    root = tmp_path_factory.mktemp("data") / "hk"
    argv = ["data", str(root), "--preset", "heldout-kinds", "--count", "2", "--size", "8",
            "--spp", "4", "-q"]
    assert main(argv) == 0
    return root, argv


def test_tiny_run_is_a_readable_dataset(tiny):
    root, _ = tiny
    info = json.loads((root / "dataset.json").read_text())
    assert info["config"] == json.loads(json.dumps(asdict(replace(
        PRESETS["heldout-kinds"](), count=2, size=8, reference_spp=4))))
    samples = list_samples(root, "train")
    assert [p.name for p in samples] == ["000000", "000001"]
    kinds = []
    for folder in samples:
        s = load_sample(folder)
        assert s.target.shape == (8, 8, 3) and s.target_source == "reference"
        assert s.target_stderr.shape == (8, 8, 3) and s.unoccluded.shape == (8, 8, 3)
        meta = json.loads((folder / "meta.json").read_text())
        assert meta["seed"] == 1 and meta["target"]["spp"] == 4
        assert meta["environment"]["source"] == "assets/environments/esplanade.exr"
        kinds.append(meta["geometry"]["kind"])
    assert kinds == ["nested", "convex"]
    assert not (root / "val").exists() and not (root / "test").exists()


def test_rerun_keeps_finished_samples(tiny, capsys):
    """A re-run writes nothing it has (same files, untouched); a larger --count adds the rest;
    another configuration in the same folder is refused."""
    root, argv = tiny
    files = sorted(p for p in root.rglob("*") if p.is_file() and p.name != "dataset.json"
                   and "_checkpoints" not in p.parts)
    stamps = {p: os.stat(p).st_mtime_ns for p in files}
    capsys.readouterr()
    assert main([a for a in argv if a != "-q"]) == 0
    out = capsys.readouterr().out
    assert "0 written, 2 kept" in out and f"relight eval {root} --split all" in out
    assert "--size 8, --spp 4: not the preset's dataset" in out
    assert {p: os.stat(p).st_mtime_ns for p in files} == stamps
    more = list(argv)
    more[more.index("--count") + 1] = "3"
    assert main(more) == 0
    assert [p.name for p in list_samples(root, "train")] == ["000000", "000001", "000002"]
    assert {p: os.stat(p).st_mtime_ns for p in files} == stamps
    other = list(argv)
    other[other.index("--spp") + 1] = "8"
    assert main(other) == 2
    assert "another configuration" in capsys.readouterr().err
