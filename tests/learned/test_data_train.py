"""Datasets (generator, reader) and training (loss decreases, resume, DDP)."""
import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import torch

from learned.data import DatasetError, list_samples, load_sample
from learned.data.generator import GeneratorConfig, generate
from viewer.errors import InputError

TINY = GeneratorConfig(count=10, size=16, samples=4, seed=3, env_width=32)


@pytest.fixture(scope="module")
def dataset(tmp_path_factory, ctx):
    from viewer.renderer import Renderer

    root = tmp_path_factory.mktemp("data") / "d"
    r = Renderer(ctx=ctx)
    try:
        generate(root, TINY, renderer=r, progress=False)
    finally:
        r.release()
    return root


def test_generator_layout_splits_and_targets(dataset):
    assert [len(list_samples(dataset, s)) for s in ("train", "val", "test")] == [8, 1, 1]
    s = load_sample(list_samples(dataset, "val")[0])
    assert s.size == (16, 16) and s.target.shape == (16, 16, 3)
    assert s.foreground().any() and np.isfinite(s.target).all()
    n = s.channels["normal"][s.foreground()]
    assert np.allclose(np.linalg.norm(n, axis=-1), 1.0, atol=1e-4)


def test_generator_writes_the_unoccluded_teacher_target(dataset):
    """rgb_unoccluded (the teacher's phase-1 target, issue 14): the same render without AO, SSAO
    and indirect light, so it is never darker than rgb by more than MC noise and strictly brighter
    where the material AO (0.6-1.0 on every primitive) darkens the diffuse term."""
    for folder in list_samples(dataset, "train"):
        s = load_sample(folder)
        assert s.unoccluded is not None and s.unoccluded.shape == s.target.shape
        fg = s.foreground()
        assert s.unoccluded[fg].mean() > s.target[fg].mean(), folder.name


def test_generator_is_deterministic_and_resumable(dataset, tmp_path, ctx):
    from viewer.renderer import Renderer

    other = tmp_path / "again"
    shutil.copytree(dataset, other)
    victim = list_samples(other, "train")[2]
    shutil.rmtree(victim)
    (victim.parent / (victim.name + ".tmp")).mkdir()  # an interrupted write
    r = Renderer(ctx=ctx)
    try:
        res = generate(other, TINY, renderer=r, progress=False)
    finally:
        r.release()
    assert res == {"written": 1, "kept": 9, "root": str(other)}
    a = load_sample(list_samples(dataset, "train")[2])
    b = load_sample(victim)
    assert np.array_equal(a.target, b.target)
    for k in a.channels:
        assert np.array_equal(a.channels[k], b.channels[k]), k
    assert not (victim.parent / (victim.name + ".tmp")).exists()


def test_generator_refuses_another_config(dataset):
    with pytest.raises(DatasetError, match="another configuration"):
        generate(dataset, GeneratorConfig(count=10, size=32), progress=False)


def test_reader_errors_name_the_file(dataset, tmp_path):
    src = list_samples(dataset, "test")[0]
    bad = tmp_path / "s"
    shutil.copytree(src, bad)
    (bad / "rgb.exr").unlink()
    with pytest.raises(DatasetError, match="missing the target image"):
        load_sample(bad)
    (bad / "albedo.exr").unlink()
    with pytest.raises(InputError, match="missing required channel 'albedo'") as info:
        load_sample(bad)
    assert str(bad) in str(info.value)
    shutil.rmtree(bad)
    shutil.copytree(src, bad)
    from viewer.imageio import write_exr

    write_exr(bad / "roughness.exr", np.zeros((8, 16, 1), np.float32), ["Y"])
    with pytest.raises(InputError, match="size mismatch"):
        load_sample(bad)


def _cfg(dataset, out, **kw):
    from learned.train import TrainConfig

    base = dict(teacher_steps=40, shadow_steps=30, student_steps=120, batch_pixels=256,
                light_samples=8, teacher_hidden=16, teacher_freqs=1, student_hidden=(16, 16),
                shadow_width=4, distill_samples=8, lr=3e-3, checkpoint_every=10, log_every=10)
    return TrainConfig(data=str(dataset), out=str(out), **(base | kw))


def test_training_losses_decrease_and_export(dataset, tmp_path):
    from learned.train import train
    from viewer.neural import load_network

    res = train(_cfg(dataset, tmp_path / "run"), quiet=True)
    for stage in ("teacher_loss", "shadow_loss", "student_loss"):
        losses = res[stage]
        assert np.mean(losses[-8:]) < np.mean(losses[:8]), stage
    student = load_network(res["student"], "student")
    assert student.training["distilled_from"] == res["teacher_checkpoint"]
    assert "train.log" in os.listdir(tmp_path / "run")


def test_training_a_student_with_the_indirect_factor(dataset, tmp_path, ctx):
    """``student_indirect="factor"``: the training images carry the indirect pass's L_ind from the
    renderer's GL pass (zero where nothing is gathered, never negative), the student trains
    direct + factor x L_ind on the dataset's targets and exports the ``indirect`` network, which
    moved off its zero start (factor 1)."""
    from learned.export import load_model
    from learned.train import load_images, train
    from viewer.neural import load_network
    from viewer.renderer import Renderer

    r = Renderer(ctx=ctx)
    try:
        images = load_images(str(dataset), "train", r)
    finally:
        r.release()
    ind = torch.cat([img.indirect for img in images])
    assert ind.shape[1] == 3 and ind.min() >= 0.0 and ind.max() > 0.0
    res = train(_cfg(dataset, tmp_path / "run", student_target="target", student_features="vis",
                     student_output="split3", student_indirect="factor", teacher_steps=5,
                     shadow_steps=3, student_steps=60), quiet=True)
    losses = res["student_loss"]
    assert np.mean(losses[-8:]) < np.mean(losses[:8])
    net = load_network(res["student"], "student")
    assert net.indirect == "factor" and "indirect" in net.architecture["networks"]
    assert np.abs(net.tensors["indirect.1.weight"]).max() > 0.0
    assert load_model(res["student"]).learns_indirect


def test_training_resumes_from_checkpoint(dataset, tmp_path):
    from learned.train import train

    out = tmp_path / "run"
    first = train(_cfg(dataset, out, teacher_steps=20), stages="teacher", quiet=True)
    again = train(_cfg(dataset, out, teacher_steps=30), stages="teacher", quiet=True)
    assert again["teacher_loss"][:20] == first["teacher_loss"]
    assert len(again["teacher_loss"]) == 30
    assert "resuming at step 20/30" in (out / "train.log").read_text()


def test_relight_train_options_reach_the_config(dataset, tmp_path, capsys):
    """``relight train`` is the one training CLI: the stage and the config overrides."""
    from relight.cli import main

    out = tmp_path / "cli"
    assert main(["train", "--data", str(dataset), "--out", str(out), "--quick", "--stage",
                 "teacher", "--teacher-steps", "3", "--batch-pixels", "64", "--light-samples",
                 "2", "--strategy", "cosine"]) == 0
    printed = capsys.readouterr().out.splitlines()
    assert printed[-1] == f"teacher: {out / 'neural_teacher.safetensors'}"
    ck = torch.load(out / "teacher.pt", weights_only=False)
    assert ck["step"] == 3 and not (out / "neural_student.safetensors").exists()
    assert {k: ck["config"][k] for k in ("teacher_steps", "batch_pixels", "light_samples",
                                         "strategy", "teacher_hidden")} == {
        "teacher_steps": 3, "batch_pixels": 64, "light_samples": 2, "strategy": "cosine",
        "teacher_hidden": 32}  # --quick's network
    with pytest.raises(SystemExit):
        main(["train", "--teacher-steps", "0"])
    assert main(["train", "--compare-students", "--stage", "teacher", "--out", str(out)]) == 2


def test_relight_train_teacher_and_shadow_stage_without_the_light_input(dataset, tmp_path,
                                                                      capsys):
    """``--stage shadow`` trains eq. 4.3's two phases and no student; ``--teacher-light-input
    off`` reaches the config and the exported file (``"light_input": false``)."""
    from learned.export import load_model
    from learned.neural.shadow import load_shadow
    from relight.cli import main
    from viewer.neural import load_network

    out = tmp_path / "shadow"
    assert main(["train", "--data", str(dataset), "--out", str(out), "--quick", "--stage",
                 "shadow", "--teacher-steps", "3", "--shadow-steps", "2", "--batch-pixels", "64",
                 "--light-samples", "2", "--teacher-light-input", "off"]) == 0
    printed = capsys.readouterr().out.splitlines()
    assert printed[-1] == f"shadow: {out / 'shadow_final.pt'}"
    assert torch.load(out / "teacher.pt", weights_only=False)["config"]["teacher_light_input"] \
        is False
    assert load_network(out / "neural_teacher.safetensors").architecture["light_input"] is False
    assert not load_model(out / "neural_teacher.safetensors").light_input
    assert load_shadow(out / "shadow_final.pt").width == 8  # --quick's UNet
    assert not (out / "neural_student.safetensors").exists()


def test_relight_train_student_stage_alone(dataset, tmp_path, capsys):
    """``--stage student`` trains no teacher and no shadow UNet: the student learns the dataset's
    own targets (it needs ``--student-target target``, else a one-line error before any work),
    and ``--install`` would install the student alone."""
    from learned.export import load_model
    from relight.cli import main
    from viewer.neural import load_network

    out = tmp_path / "student"
    assert main(["train", "--data", str(dataset), "--out", str(out), "--quick", "--stage",
                 "student", "--student-steps", "20"]) == 2
    assert "--student-target target" in capsys.readouterr().err and not out.exists()
    assert main(["train", "--data", str(dataset), "--out", str(out), "--quick", "--stage",
                 "student", "--student-target", "target", "--student-steps", "20",
                 "--batch-pixels", "64", "--student-features", "vis", "--student-output",
                 "split3", "--student-multiscatter", "--student-gain-penalty", "1"]) == 0
    printed = capsys.readouterr().out.splitlines()
    assert printed[-1] == f"student: {out / 'neural_student.safetensors'}"
    assert not (out / "teacher.pt").exists() and not (out / "neural_teacher.safetensors").exists()
    net = load_network(out / "neural_student.safetensors", "student")
    assert net.multiscatter and load_model(out / "neural_student.safetensors").multiscatter
    assert net.training["config"]["student_gain_penalty"] == 1.0


@pytest.mark.slow
def test_torchrun_ddp_two_cpu_processes(dataset, tmp_path):
    out = tmp_path / "ddp"
    cmd = [sys.executable, "-m", "torch.distributed.run", "--standalone", "--nproc_per_node", "2",
           "--tee", "3", "-m", "relight", "train", "--data", str(dataset), "--out", str(out),
           "--quick", "--stage", "teacher", "--teacher-steps", "6", "--batch-pixels", "128",
           "--light-samples", "4", "--quiet"]
    env = dict(os.environ, OMP_NUM_THREADS="1")

    def launch():
        return subprocess.run(cmd, capture_output=True, text=True, timeout=240, env=env,
                              cwd=os.path.dirname(os.path.dirname(os.path.dirname(__file__))))

    p = launch()
    # A rank killed by SIGABRT inside the C++ runtime (seen 3 times in ~40 CI-like runs on shared
    # 2-core machines, never reproduced in 25 runs under load; no Python error in the ranks'
    # output) is relaunched once; the run resumes from its checkpoint. A Python error (exit code
    # 1), a wrong world size or a second abort still fails. --tee 3 keeps both ranks' output for
    # the message.
    if p.returncode != 0 and "(SIGABRT)" in p.stderr:
        p = launch()
    assert p.returncode == 0, (p.stdout[-2000:], p.stderr[-2000:])
    log = (out / "train.log").read_text()
    assert "world 2" in log and "teacher step 6/6" in log
    ck = torch.load(out / "teacher.pt", weights_only=False)
    assert ck["step"] == 6


# ---- image G-buffers as geometry --------------------------------------------------------------

IMAGE = GeneratorConfig(count=3, size=16, samples=4, seed=5, env_width=32, gbuffer_fraction=1.0)


def _generate(root, cfg, ctx):
    from viewer.renderer import Renderer

    r = Renderer(ctx=ctx)
    try:
        return generate(root, cfg, renderer=r, progress=False)
    finally:
        r.release()


def test_image_gbuffer_samples_are_deterministic_resumable_and_varied(tmp_path, ctx):
    import json

    root = tmp_path / "img"
    assert _generate(root, IMAGE, ctx)["written"] == 3
    folders = list_samples(root, "train")
    for f in folders:
        meta = json.loads((f / "meta.json").read_text())
        assert meta["geometry"]["kind"] == "gbuffer" and meta["objects"][0]["type"] == "gbuffer"
        assert not (f / "_source").exists()
        s = load_sample(f)
        fg = s.foreground()
        assert fg.sum() > 10 and np.isfinite(s.target).all() and s.target[fg].max() > 0
    # per-pixel materials: one rendered object (one material) became a spatially varying field
    s = load_sample(folders[0])
    assert s.channels["roughness"][s.foreground()].std() > 0.02
    before = {k: v.copy() for k, v in s.channels.items()} | {"rgb": s.target.copy()}
    shutil.rmtree(folders[0])
    (folders[0].parent / (folders[0].name + ".tmp")).mkdir()
    assert _generate(root, IMAGE, ctx) == {"written": 1, "kept": 2, "root": str(root)}
    again = load_sample(folders[0])
    for k, v in again.channels.items():
        assert np.array_equal(v, before[k]), k
    assert np.array_equal(again.target, before["rgb"])


def test_image_gbuffer_from_a_12_channel_stack(dataset, tmp_path, ctx):
    from viewer.geometry.imagespace import ImageGBuffer, save_stack_exr

    src = load_sample(list_samples(dataset, "val")[0])
    stack = tmp_path / "stack.exr"
    save_stack_exr(stack, ImageGBuffer(channels=src.channels, fov_y=src.fov_y))
    cfg = GeneratorConfig(count=1, size=16, samples=4, seed=1, env_width=32,
                          gbuffer_fraction=1.0, gbuffers=(str(stack),))
    _generate(tmp_path / "d", cfg, ctx)
    out = load_sample(list_samples(tmp_path / "d", "train")[0])
    fg = out.foreground()
    assert np.array_equal(fg, src.foreground())  # the stack's geometry ...
    assert np.allclose(out.channels["normal"][fg], src.channels["normal"][fg], atol=1e-3)
    # ... with new materials
    assert not np.allclose(out.channels["albedo"][fg], src.channels["albedo"][fg])


def test_datasets_from_before_the_gbuffer_options_still_resume(dataset, tmp_path, ctx):
    import json

    other = tmp_path / "old"
    shutil.copytree(dataset, other)
    info = json.loads((other / "dataset.json").read_text())
    for k in ("gbuffer_fraction", "gbuffers"):
        info["config"].pop(k)
    (other / "dataset.json").write_text(json.dumps(info))
    assert _generate(other, TINY, ctx)["kept"] == 10


def test_compare_students_writes_the_table_and_bench_rows(dataset, tmp_path, ctx):
    import json

    from relight.bench.neural import student_designs
    from relight.bench.students import compare_students
    from viewer.renderer import Renderer

    designs = {"a": {"hidden": (4,)}, "b": {"hidden": (4, 4), "features": "dfg"}}
    kw = dict(teacher_steps=10, shadow_steps=5, student_steps=20, batch_pixels=128,
              light_samples=4, teacher_hidden=8, teacher_freqs=1, shadow_width=4,
              distill_samples=4, checkpoint_every=10, log_every=10)
    res = compare_students(str(tmp_path / "c"), str(dataset), designs, quiet=True, repeats=1, **kw)
    rows = {r["design"]: r for r in res["rows"]}
    assert rows["a"]["macs_per_pixel"] == 8 * 4 + 4 * 6 and rows["b"]["features"] == "dfg"
    for r in rows.values():
        assert np.isfinite([r["psnr_vs_teacher"], r["psnr_vs_mc"], r["ms_256"],
                            r["shade_ms_256"]]).all()
    folder = tmp_path / "c" / "students"
    assert json.loads((folder / "compare.json").read_text())["rows"] == res["rows"]
    assert "| b | 4-4 | 0 | dfg |" in (folder / "compare.md").read_text()
    r = Renderer(ctx=ctx)
    try:
        bench = student_designs(r, size=32, reference_samples=4, repeats=1, folder=folder)
    finally:
        r.release()
    assert [b["variant"] for b in bench] == ["a", "b"]
    assert all(b["model"] == "neural" and b["samples"] == 1 and b["size"] == "32x32"
               and b["psnr_test_vs_mc"] == rows[b["variant"]]["psnr_vs_mc"] for b in bench)


def test_eval_breaks_the_means_down_by_scene_kind(dataset, tmp_path, ctx):
    """``relight eval --by kind``: one row per (kind, model), each the mean over that kind's
    samples; the "all" rows are the plain means, and the count-weighted means of the groups
    equal them (exact up to float rounding of the means)."""
    import json as _json

    from learned.evaluate import evaluate, format_table
    from viewer.renderer import Renderer

    root = tmp_path / "d"
    shutil.copytree(dataset, root)
    relabelled = list_samples(root, "train")[:2]
    for folder in relabelled:  # two of the three samples evaluated become another kind
        meta = _json.loads((folder / "meta.json").read_text())
        meta["geometry"]["kind"] = "other"
        (folder / "meta.json").write_text(_json.dumps(meta))
    r = Renderer(ctx=ctx)
    try:
        plain = evaluate(str(root), split="train", teacher_samples=1, limit=3, renderer=r)
        rows = evaluate(str(root), split="train", teacher_samples=1, limit=3, renderer=r, by="kind")
        by_env = evaluate(str(root), split="train", teacher_samples=1, limit=3, renderer=r,
                          by="environment")
    finally:
        r.release()
    sources = [load_sample(f).environment_source for f in list_samples(root, "train")[:3]]
    assert all(sources)  # the generator records each sample's environment
    envs = {Path(src).stem for src in sources}
    assert {row["group"] for row in by_env} == envs | {"all"}
    split_rows = [row for row in by_env if row["model"] == "ggx_split_sum" and not row["variant"]]
    assert sum(row["count"] for row in split_rows if row["group"] != "all") == 3
    assert "group" not in plain[0]
    groups = {row["group"] for row in rows}
    assert groups == {"all", "other", load_sample(list_samples(root, "train")[2]).kind}
    for p in plain:
        same = [r for r in rows if (r["model"], r["variant"]) == (p["model"], p["variant"])]
        by_group = {r["group"]: r for r in same}
        assert by_group["all"]["count"] == 3 and by_group["other"]["count"] == 2
        assert by_group["all"]["psnr"] == pytest.approx(p["psnr"], rel=1e-9)
        for key in ("psnr", "ssim", "flip", "bias"):
            weighted = sum(r[key] * r["count"] for g, r in by_group.items() if g != "all") / 3
            assert weighted == pytest.approx(by_group["all"][key], rel=1e-6, abs=1e-9)
    assert "other" in format_table(rows).splitlines()[1]
    with pytest.raises(ValueError, match="by='shape'"):
        evaluate(str(root), split="train", by="shape")


def test_eval_scores_a_given_teacher_and_the_teacher_times_shadow(dataset, tmp_path, ctx):
    """``relight eval --teacher-weights FILE --shadow-weights RUN/shadow_final.pt``: the GLSL
    teacher row renders the given file, and the torch row teacher x shadow map (eq. 4.3) is the
    same estimator: with a shadow map of 1 (sigmoid(30) = 1 in float32) its energy matches the
    GLSL teacher's to the Monte-Carlo noise of 64 samples on 16x16 images."""
    from learned.evaluate import SHADOW_VARIANT, evaluate
    from learned.export import export
    from learned.neural.shadow import ShadowUNet
    from learned.neural.teacher import Teacher
    from viewer.renderer import Renderer

    torch.manual_seed(3)
    teacher = tmp_path / "t.safetensors"
    export(Teacher(hidden=8, num_freqs=1, light_input=False), teacher)
    shadow = ShadowUNet(width=4)
    torch.nn.init.constant_(shadow.out.bias, 30.0)
    torch.save(shadow.state_dict(), tmp_path / "shadow_final.pt")
    r = Renderer(ctx=ctx)
    try:
        shipped = evaluate(str(dataset), split="train", teacher_samples=64, limit=2, renderer=r)
        rows = evaluate(str(dataset), split="train", teacher_samples=64, limit=2, renderer=r,
                        teacher_weights=teacher, shadow_weights=tmp_path / "shadow_final.pt")
    finally:
        r.release()
    by = {(row["model"], row["variant"]): row for row in rows}
    glsl = by[("neural_teacher", "64 spp env")]
    two = by[("neural_teacher", SHADOW_VARIANT.format(64))]
    assert two["count"] == 2 and np.isfinite(two["psnr"]) and two["samples"] == 64
    old = {(row["model"], row["variant"]): row for row in shipped}[("neural_teacher", "64 spp env")]
    assert old["psnr"] != glsl["psnr"]  # the given file, not the shipped one
    assert abs((1 + two["bias"]) / (1 + glsl["bias"]) - 1) < 0.05, (two, glsl)
