"""The evaluation protocol (learned.protocol): splits by seed and environment, degraded
G-buffers, the classical model given the student's evidence, the paired bootstrap, the test
ledger, and the whole run (trained, cached, resumed, counted), on a tiny rasteriser-target
protocol dataset."""
import json
from dataclasses import replace

import numpy as np
import pytest
import torch

from learned.data.reader import DatasetError, list_samples, load_sample


def _configs(**counts):
    from learned.protocol.data import protocol_configs, with_changes

    counts = {"train": 3, "val": 2, "test": 3} | counts
    return with_changes(protocol_configs(counts, size=16, targets="rasteriser", seed=5),
                       samples=4, env_width=32)


@pytest.fixture(scope="module")
def protocol(tmp_path_factory, ctx):
    from learned.protocol.data import generate_protocol
    from viewer.renderer import Renderer

    root = tmp_path_factory.mktemp("protocol") / "p"
    r = Renderer(ctx=ctx)
    try:
        generate_protocol(root, _configs(), progress=False, renderer=r)
    finally:
        r.release()
    return root


@pytest.fixture(scope="module")
def images(protocol, ctx):
    from learned.train import load_images
    from viewer.renderer import Renderer

    r = Renderer(ctx=ctx)
    try:
        return load_images(str(protocol), "val", r, sun=True, multiscatter=True)
    finally:
        r.release()


def test_splits_share_no_seed_and_no_environment(protocol):
    """Each split lands in its own folder with its own seed; the test split's environment is
    one no train or val sample was lit by (meta.json), and a configuration sharing one is
    refused before anything is written."""
    from learned.protocol.data import check_disjoint, load_protocol

    seen = {}
    for split in ("train", "val", "test"):
        metas = [json.loads((f / "meta.json").read_text()) for f in list_samples(protocol, split)]
        assert len(metas) == {"train": 3, "val": 2, "test": 3}[split]
        assert len({m["seed"] for m in metas}) == 1
        seen[split] = {m["environment"]["source"] for m in metas}
        assert (protocol / f"dataset.{split}.json").is_file()
    assert not seen["test"] & (seen["train"] | seen["val"])
    assert not seen["val"] & seen["train"]
    assert load_protocol(protocol)["hash"]
    from learned.protocol.data import generate_protocol

    with pytest.raises(DatasetError, match="another protocol"):  # nothing overwritten
        generate_protocol(protocol, _configs(test=4), progress=False)
    bad = _configs()
    bad["test"] = replace(bad["test"], env_paths=bad["val"].env_paths)
    with pytest.raises(DatasetError, match="share the environment"):
        check_disjoint(bad)
    bad = _configs()
    bad["val"] = replace(bad["val"], seed=bad["train"].seed)
    with pytest.raises(DatasetError, match="share the seed"):
        check_disjoint(bad)


def test_degraded_inputs_change_every_estimated_channel_not_the_targets(protocol):
    from learned.protocol.degrade import degraded_dataset

    assert degraded_dataset(protocol, 0.0) == protocol
    root = degraded_dataset(protocol, 0.5, splits=("val",))
    again = degraded_dataset(protocol, 0.5, splits=("val",))  # cached: the same folder
    assert again == root
    for folder in list_samples(protocol, "val"):
        clean, bad = load_sample(folder), load_sample(root / "val" / folder.name)
        fg = clean.foreground()
        assert np.array_equal(clean.target, bad.target)
        assert np.array_equal(fg, bad.foreground())
        for k in ("albedo", "normal", "roughness", "metallic", "depth"):
            assert np.abs(clean.channels[k] - bad.channels[k])[fg].mean() > 1e-3, k
        assert json.loads((root / "val" / folder.name / "meta.json").read_text())[
            "degrade"]["bits"] == 4


def test_two_writers_of_one_degraded_sample_do_not_collide(protocol, tmp_path):
    """Two trainings making the same degraded copy at once: each writes its own temporary
    folder, and the one that finds the sample already finished drops its own (both are the
    same seeded files), where one shared temporary folder failed ("Directory not empty")."""
    from learned.protocol.degrade import _degrade_sample

    folder = list_samples(protocol, "val")[0]
    first, final = tmp_path / "first", tmp_path / "copy" / folder.name
    _degrade_sample(folder, first, 0.5)
    final.parent.mkdir()
    import shutil

    shutil.copytree(first, final)  # the other writer finished first
    _degrade_sample(folder, final, 0.5)
    assert sorted(p.name for p in final.parent.iterdir()) == [folder.name]
    for name in ("meta.json", "albedo.exr"):
        if (first / name).is_file():
            assert (first / name).read_bytes() == (final / name).read_bytes()


def test_estimate_errors_grow_with_the_level_and_are_deterministic(protocol):
    from learned.protocol.degrade import estimate_errors

    s = load_sample(list_samples(protocol, "train")[0])
    fg = s.foreground()
    errs = []
    for level in (0.0, 0.25, 0.5):
        a, _ = estimate_errors(s.channels, s.unoccluded, 5, 0, level)
        b, _ = estimate_errors(s.channels, s.unoccluded, 5, 0, level)
        assert all(np.array_equal(a[k], b[k]) for k in a)
        errs.append(float(np.abs(a["normal"] - s.channels["normal"])[fg].mean()))
    assert errs[0] == 0.0 < errs[1] < errs[2]


def test_untrained_student_is_the_classical_model_given_the_same_evidence(images):
    """k = 0.5 everywhere (the shipped design, untrained) renders exactly the classical variant
    with the sun light, multiple scattering, SSAO and the indirect light; S(x) on the IBL
    darkens it where S < 1."""
    from learned.neural.student import Student
    from learned.protocol.classical import Classical, classical_radiance
    from learned.train.config import SHIPPED_STUDENT_DESIGN
    from learned.train.stages import design_features

    student = Student(**SHIPPED_STUDENT_DESIGN).eval()
    same = Classical(sun=True, multiscatter=True, ssao=True, vis="", indirect=True)
    for img, (x, irr, pre, sun) in zip(images, design_features(student, images)):
        with torch.no_grad():
            s = student(x, irr, pre, img.indirect, sun)
        c = classical_radiance(same, img)
        torch.testing.assert_close(s, c, rtol=1e-5, atol=1e-6)
        v = classical_radiance(replace(same, vis="dsl"), img)
        assert torch.all(v <= c + 1e-6)
        if (img.vis < 0.99).any():
            assert (v < c - 1e-6).any()


def test_psnr_is_relight_evals():
    from learned.evaluate import metrics
    from learned.protocol.scores import psnr

    g = np.random.default_rng(0)
    ref = g.random((8, 8, 3)).astype(np.float32) * 3
    pred = ref * g.uniform(0.7, 1.3, ref.shape).astype(np.float32)
    fg = g.random((8, 8)) > 0.3
    want = metrics(pred, ref, fg)["psnr"]
    assert psnr(torch.from_numpy(pred[fg]), torch.from_numpy(ref[fg])) == pytest.approx(want)


def test_paired_bootstrap_interval_contains_zero_only_without_a_difference():
    from learned.protocol.scores import paired_bootstrap

    g = np.random.default_rng(1)
    noise = g.standard_normal((3, 40))
    none = paired_bootstrap(noise - noise.mean(), 2000)
    assert none["lo"] < 0.0 < none["hi"]
    shifted = paired_bootstrap(noise - noise.mean() + 1.0, 2000)
    assert shifted["lo"] > 0.5 and shifted["mean"] == pytest.approx(1.0)
    # a seed that disagrees widens the interval over seeds, not the one over samples
    split = np.stack([np.full(40, 1.0), np.full(40, 1.0), np.full(40, -2.0)]) + 0.01 * noise
    assert paired_bootstrap(split, 2000)["lo"] < 0.0 < paired_bootstrap(split, 2000)["hi"]


def test_the_ledger_counts_every_scoring(tmp_path):
    from learned.protocol.scores import ledger, record_test

    assert record_test(tmp_path, "a", ["m"], 3, "h") == 1
    assert record_test(tmp_path, "b", ["m", "n"], 3, "h") == 2
    assert [e["what"] for e in ledger(tmp_path)] == ["a", "b"]


def test_protocol_run_trains_caches_resumes_and_counts(protocol, tmp_path, ctx, monkeypatch):
    """Two seeds, a few steps: the report has both seeds' val and test scores, the paired
    interval, the baseline picked on val; the weights record command, seed, dataset hash and
    their val score (test beside them); a second call retrains nothing and the ledger says 2;
    a third with another student design trains its own students (the cache is keyed by the
    design: it once loaded the students of the design before)."""
    from learned.protocol import run as protocol_run
    from learned.protocol.run import ProtocolConfig, design_key, format_report, run_protocol
    from viewer.neural import load_network
    from viewer.renderer import Renderer

    cfg = ProtocolConfig(data=str(protocol), out=str(tmp_path / "runs"), seeds=(0, 1),
                         student_steps=6, resamples=200)
    folder = tmp_path / "runs" / f"level-0-steps-6-{design_key()}"
    r = Renderer(ctx=ctx)
    try:
        first = run_protocol(cfg, quiet=True, renderer=r)
        w = folder / "seed-1" / "neural_student.safetensors"
        mtime = w.stat().st_mtime_ns
        second = run_protocol(cfg, quiet=True, renderer=r)
        # another student design keys another folder: its students are trained, not loaded
        other = dict(protocol_run.SHIPPED_STUDENT, student_features="ssao")
        monkeypatch.setattr(protocol_run, "SHIPPED_STUDENT", other)
        assert design_key() not in folder.name
        third = run_protocol(cfg, quiet=True, renderer=r)
    finally:
        r.release()
    assert w.stat().st_mtime_ns == mtime
    again = tmp_path / "runs" / f"level-0-steps-6-{design_key()}" / "seed-1"
    assert load_network(again / "neural_student.safetensors", "student").features == "ssao"
    assert load_network(w, "student").features == "ssao-env"
    assert third["test_scored"] == 3
    assert first["test_scored"] + 1 == second["test_scored"]
    assert first["test"]["students"] == second["test"]["students"]
    assert set(first["test"]["students"]) == {"0", "1"}
    d = first["test"]["diff_over_seeds_and_samples"]
    assert d["lo"] <= d["mean"] <= d["hi"] and d["seeds"] == 2 and d["samples"] == 3
    assert first["val"]["baseline"] == max(
        np.mean(v["psnr"]) for v in json.loads(
            (folder / "classical-val.json").read_text())["variants"])
    training = load_network(w, "student").training
    from learned.protocol.data import dataset_hash

    assert training["seed"] == 1 and training["dataset_hash"] == dataset_hash(protocol, ("train",))
    assert first["dataset_hash"] == dataset_hash(protocol) != training["dataset_hash"]
    assert "relight eval" in training["command"] and "val_psnr" in training["scores"]
    beside = json.loads(w.with_suffix(".json").read_text())
    assert beside["test_scored"] == 2 and beside["seed"] == 1
    text = format_report(second)
    assert "scored 2 times" in text and "student - baseline" in text


def test_protocol_cli_refuses_mixed_options(tmp_path):
    from relight.cli import main

    assert main(["eval", str(tmp_path), "--degrade", "0.5"]) == 2
    with pytest.raises(SystemExit) as exc:  # one dataset or the other
        main(["data", str(tmp_path / "d"), "--protocol", "--preset", "heldout-env"])
    assert exc.value.code == 2
    assert main(["eval", str(tmp_path), "--protocol"]) == 2  # not a protocol dataset


def test_shipped_weights_say_where_they_come_from(capsys):
    """The shipped files' provenance (metadata + the JSON beside them): command, seed, and the
    protocol's test scores with how often the test split had been scored."""
    from relight.cli import main
    from relight.commands.info import weights_provenance
    from viewer.neural import default_weights

    from viewer.neural import load_network

    student = weights_provenance(default_weights("student"))
    trained = load_network(default_weights("student"), "student").training
    assert "relight train" in student["command"] and student["seed"] == trained["seed"]
    assert f"--seed {trained['seed']}" in student["command"]  # the JSON names the file's seed
    assert any(v["test_scored"] >= 1 for v in student["test"].values())
    teacher = weights_provenance(default_weights("teacher"))
    assert "--teacher-light-input off" in teacher["command"]
    v = weights_provenance(default_weights("student_visibility"))
    assert "--student-visibility" in v["command"] and f"--seed {v['seed']}" in v["command"]
    assert main(["info", "--weights"]) == 0
    printed = capsys.readouterr().out
    assert "command" in printed and "neural_student_visibility" in printed
    assert main(["info", "--weights", "nope.safetensors"]) == 2


def test_the_shadow_estimator_is_scored_against_the_classical_pick(protocol, tmp_path, capsys):
    """learned.protocol.shadow_net: on val the classical variant is the best of all by mean PSNR,
    an estimator of V = 1 scores exactly the unshadowed frame; the test split needs the variant
    chosen on val and is counted in the ledger."""
    import shutil

    from learned.protocol import shadow_net as sn
    from learned.protocol.classical import variants
    from learned.protocol.run import classical_scores
    from learned.protocol.scores import ledger
    from learned.train import load_images
    from test_shadow_net_route import constant_weights
    from viewer.renderer import Renderer

    ones = str(constant_weights(tmp_path, (1.0, 1.0, 1.0)))
    r = sn.evaluate(str(protocol), "val", [ones])
    assert r["vs_frame"]["mean"] == 0.0 and r["estimator_psnr"] == [r["frame_psnr"]]
    renderer = Renderer()
    try:
        val = load_images(str(protocol), "val", renderer, sun=True, multiscatter=True)
    finally:
        renderer.release()
    assert r["classical_psnr"] == max(float(np.mean(classical_scores(m, val)))
                                      for m in variants())
    ranked = r["classical_ranking"]  # the choice's margin: the best variants, best first
    assert ranked[0] == {"name": r["classical_name"], "psnr": r["classical_psnr"]}
    assert len(ranked) == sn.RANKED and all(a["psnr"] >= b["psnr"]
                                            for a, b in zip(ranked, ranked[1:]))
    data = tmp_path / "copy"  # the module's dataset keeps its own ledger count
    shutil.copytree(protocol, data)
    before = len(ledger(data))  # the shared dataset's earlier test scorings (other tests)
    with pytest.raises(SystemExit):
        sn.main([str(data), ones, "--split", "test"])
    assert len(ledger(data)) == before  # refused: nothing counted
    sn.main([str(data), ones, "--split", "test", "--classical", json.dumps(r["classical"])])
    out = json.loads(capsys.readouterr().out)
    assert out["test_scored"] == before + 1 and len(ledger(data)) == before + 1
    assert out["classical_name"] == r["classical_name"]
