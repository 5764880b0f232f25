"""Training on the tiny dataset: losses decrease, resume from checkpoints, ``relight train``'s
options and stages, the learned indirect factor, DDP over two CPU processes."""
import json
import os
import subprocess
import sys

import numpy as np
import pytest
import torch


def _cfg(dataset, out, **kw):
    from learned.train import TrainConfig

    base = dict(teacher_steps=40, shadow_steps=30, student_steps=120, batch_pixels=256,
                light_samples=8, teacher_hidden=16, teacher_freqs=1, student_hidden=(16, 16),
                shadow_width=4, distill_samples=8, lr=3e-3, checkpoint_every=10, log_every=10,
                student_target="teacher")
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
    own targets (``--student-target teacher`` is a one-line error before any work),
    and ``--install`` would install the student alone."""
    from learned.export import load_model
    from relight.cli import main
    from viewer.neural import load_network

    out = tmp_path / "student"
    assert main(["train", "--data", str(dataset), "--out", str(out), "--quick", "--stage",
                 "student", "--student-target", "teacher", "--student-steps", "20"]) == 2
    assert "--student-target teacher" in capsys.readouterr().err and not out.exists()
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


def test_train_defaults_are_the_shipped_student_and_teacher_and_seed_reaches_the_config(
        dataset, tmp_path, capsys):
    """TrainConfig's defaults are the design and training the shipped weights files record in
    their metadata (student: stage student on the targets; teacher: no light input), and
    ``relight train --seed`` reaches the run's config."""
    from learned.train import TrainConfig
    from learned.train.config import SHIPPED_STUDENT
    from relight.cli import main
    from viewer.neural import default_weights, load_network

    cfg = TrainConfig.quick("d", "o")
    shipped = load_network(default_weights("student"), "student").training["config"]
    for key in SHIPPED_STUDENT:
        want = shipped[key]
        assert getattr(cfg, key) == (tuple(want) if isinstance(want, list) else want), key
    teacher = load_network(default_weights("teacher"), "teacher").training["config"]
    assert cfg.teacher_light_input == teacher["teacher_light_input"] is False
    out = tmp_path / "seeded"
    assert main(["train", "--data", str(dataset), "--out", str(out), "--quick", "--stage",
                 "student", "--student-steps", "2", "--batch-pixels", "32", "--seed", "7",
                 "--quiet"]) == 0
    assert torch.load(out / "student.pt", weights_only=True)["config"]["seed"] == 7
    # the file records its command, seed and dataset hash; relight info --weights shows them
    capsys.readouterr()
    assert main(["info", "--weights", str(out / "neural_student.safetensors"), "--json"]) == 0
    (info,) = json.loads(capsys.readouterr().out)
    assert info["seed"] == 7 and len(info["dataset_hash"]) == 64
    assert info["command"]  # sys.argv of the process (here pytest's)


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
