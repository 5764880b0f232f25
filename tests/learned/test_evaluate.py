"""Evaluation on the tiny dataset: the comparison of student designs (table and bench rows) and
``relight eval`` (by scene kind and environment, a given teacher and teacher x shadow)."""
import shutil
from pathlib import Path

import numpy as np
import pytest
import torch

from learned.data import list_samples, load_sample


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


def _split_student(path, b_direct: float, b_indirect: float):
    """A split3 student with the shipped student's parts whose every output is a constant: its
    last layers' weights zero, their biases ``b_direct`` on k_b alone (k_d, k_a stay at
    sigmoid(0)) and ``b_indirect`` on the bounce gain."""
    from learned.export import export
    from learned.neural.student import Student

    s = Student(hidden=(8, 8), features="ssao", output="split3", indirect="factor", sun=True,
                multiscatter=True)
    with torch.no_grad():
        s.layers[-1].bias[2] = b_direct
        s.indirect_layers[-1].bias[0] = b_indirect
    export(s, path)
    return path


def test_eval_factors_reports_a_students_corrections(dataset, tmp_path, ctx, capsys):
    """``relight eval DATA --factors``: over the split's surface pixels the mean of each
    correction S k and the bounce gain's percentiles; for students whose outputs are constants
    these are 2 sigmoid(bias) exactly (1 where the bias is 0: ggx_split_sum), on every pixel.
    A free6 student is refused in one line."""
    from learned.factors import student_factors
    from viewer.renderer import Renderer

    a = _split_student(tmp_path / "a.safetensors", 0.0, 0.0)
    b = _split_student(tmp_path / "b.safetensors", -1.0, 0.7)
    r = Renderer(ctx=ctx)
    try:
        rows = student_factors(str(dataset), "val", {"a": str(a), "b": str(b)}, renderer=r)
    finally:
        r.release()
    ra, rb = rows
    assert ra["pixels"] == rb["pixels"] > 50
    two_sig = lambda x: 2.0 / (1.0 + np.exp(-x))  # noqa: E731
    assert [ra[k] for k in ("k_d", "k_a", "k_b", "k_i")] == pytest.approx([1, 1, 1, 1], abs=1e-6)
    assert ra["k_i_above_1"] == 0.0
    assert [rb["k_d"], rb["k_a"]] == pytest.approx([1, 1], abs=1e-6)
    assert rb["k_b"] == pytest.approx(two_sig(-1.0), abs=1e-6)
    for key in ("k_i", "k_i_p10", "k_i_p50", "k_i_p90"):
        assert rb[key] == pytest.approx(two_sig(0.7), abs=1e-6)
    assert rb["k_i_above_1"] == 1.0

    from relight.cli import main

    assert main(["eval", str(dataset), "--factors", "--weights", f"b={b}"]) == 0
    out = capsys.readouterr().out
    assert "k_b" in out and f"{two_sig(0.7):.4f}" in out and f"{two_sig(-1.0):.4f}" in out
    from learned.export import export
    from learned.neural.student import Student

    assert main(["eval", str(dataset), "--factors", "--by", "kind"]) == 2  # not ignored
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--by belongs to scoring" in err[0]
    export(Student(hidden=(4,)), tmp_path / "free6.safetensors")
    assert main(["eval", str(dataset), "--factors", "--weights",
                 f"f={tmp_path / 'free6.safetensors'}"]) != 0
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "free6" in err[0]
