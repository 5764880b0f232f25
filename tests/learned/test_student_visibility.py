"""A student for frames whose O(x) is the shadow estimator's V (``relight train
--student-visibility FILE``, ``learned.train.stages.estimator_visibility``): the training images
carry V's mean over the colours in place of SSAO's O(x) and S(x), as ``passes/deferred.glsl``
reads V under ``shadow_net_use = "visibility"``; the option reaches the config and the weights'
record, and a bad file is one line before any work."""
import numpy as np
import torch

from assets import ASSET_ROOT

MESH_ESTIMATOR = ASSET_ROOT / "weights" / "shadow_net_mesh.safetensors"


def test_the_training_images_carry_the_estimators_visibility(dataset, ctx):
    from learned.data.reader import list_samples, load_sample
    from learned.neural.shadow_net import load_shadow_net
    from learned.train import load_images
    from learned.train.shadow_net import shadow_net_image, visibility
    from learned.train.stages import estimator_visibility
    from viewer.neural.shadow_net import frame_settings, read_shadow_net
    from viewer.renderer import Renderer

    r = Renderer(ctx=ctx)
    try:
        plain = load_images(str(dataset), "train", r)
        with_v = load_images(str(dataset), "train", r, visibility=str(MESH_ESTIMATOR))
        sample = load_sample(list_samples(str(dataset), "train")[0])
        v = estimator_visibility(r, sample, str(MESH_ESTIMATOR))
        frame = frame_settings(read_shadow_net(MESH_ESTIMATOR).training)
        img = shadow_net_image(r, sample, frame["model"], frame["geometry"], frame["indirect"],
                               frame["specular_occlusion"])
    finally:
        r.release()
    assert frame["geometry"] == "mesh"  # the file's own frame, not the student's stack
    # V's mean over the colours, flipped to row 0 at the top (GL rows run bottom-up)
    with torch.no_grad():
        rgb = visibility(load_shadow_net(MESH_ESTIMATOR), img)[0]
    np.testing.assert_allclose(v, rgb.mean(0).numpy()[::-1], rtol=0, atol=0)
    first = with_v[0]
    assert first.name == sample.name
    np.testing.assert_array_equal(first.ssao.numpy(), v[first.fg.numpy()])
    assert torch.equal(first.ssao, first.vis)  # V's mean stands for O(x) and S(x)
    o = torch.cat([i.ssao for i in plain])
    vv = torch.cat([i.ssao for i in with_v])
    print(f"O(x) mean {o.mean():.3f}, V mean {vv.mean():.3f}, mean |V - O| {(vv - o).abs().mean():.3f}")
    assert (vv - o).abs().mean() > 0.01  # another frame's evidence, not O(x) again
    assert vv.min() >= 0.0 and torch.isfinite(vv).all()
    # the rest of each image is the plain one's
    for a, b in zip(plain, with_v):
        assert torch.equal(a.target, b.target) and torch.equal(a.indirect, b.indirect)


def test_relight_train_student_visibility(dataset, tmp_path, capsys):
    from relight.cli import main
    from viewer.neural import load_network

    out = tmp_path / "v"
    missing = tmp_path / "nope.safetensors"
    assert main(["train", "--data", str(dataset), "--out", str(out), "--quick", "--stage",
                 "student", "--student-visibility", str(missing), "--student-steps", "20"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and str(missing) in err[0] and not out.exists()
    assert main(["train", "--data", str(dataset), "--out", str(out), "--quick", "--stage",
                 "student", "--student-visibility", str(MESH_ESTIMATOR), "--student-steps", "20",
                 "--batch-pixels", "64", "-q"]) == 0
    net = load_network(out / "neural_student.safetensors", "student")
    assert net.training["config"]["student_visibility"] == str(MESH_ESTIMATOR)


def test_the_frame_that_takes_v_gets_the_student_trained_on_v_and_a_wrong_one_is_named():
    """``[render] shadow_net_use = "visibility"`` without ``weights``: the shipped
    ``neural_student_visibility`` (trained with ``--student-visibility``); otherwise the shipped
    student; a file given wins. A student trained on the other kind of frame is one warning
    naming it, either way."""
    import warnings

    import pytest

    from viewer.neural import default_weights
    from viewer.neural import network
    from viewer.neural.network import model_network, student_path
    from viewer.scene.settings import RenderSettings

    def settings(**keys):
        return RenderSettings().with_flat(**keys)

    v = settings(model="neural", ssao=True, shadow_net=str(MESH_ESTIMATOR),
                 shadow_net_use="visibility")
    plain = settings(model="neural", ssao=True)
    assert student_path(v) == default_weights("student_visibility")
    assert student_path(plain) == default_weights("student")
    given = settings(model="neural", weights=str(default_weights("student")),
                     shadow_net=str(MESH_ESTIMATOR), shadow_net_use="visibility")
    assert student_path(given) == default_weights("student")
    net, _ = model_network("neural", v)
    assert net.training["config"]["student_visibility"]
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        model_network("neural", v)
        model_network("neural", plain)
    network._WARNED.clear()  # once per file and process: this test's own warnings
    with pytest.warns(UserWarning, match="trained on frames with SSAO's O.x.; this frame takes"):
        model_network("neural", given)
    wrong = settings(model="neural", weights=str(default_weights("student_visibility")))
    with pytest.warns(UserWarning, match="trained on frames that take the shadow estimator's V"):
        model_network("neural", wrong)


def test_the_route_students_bench_scores_students_and_split_sum_on_v_frames(dataset, ctx,
                                                                             capsys):
    """``relight.bench.student_visibility``: every student and the classical row scored on V's
    frames; the classical row is a student at its start (k = 0.5, no correction), so its score
    is that of the same design exported untrained; the route's student and the O(x) student
    read the same frames and score differently; a bad argument is one line."""
    import math
    import tempfile
    from pathlib import Path

    from learned.export import export
    from relight.bench.student_visibility import BASE, base_student, main, score
    from viewer.neural import default_weights
    from viewer.renderer import Renderer

    with tempfile.TemporaryDirectory() as tmp:
        untrained = Path(tmp) / "base.safetensors"
        export(base_student(), str(untrained), {"stage": "test"})
        r = Renderer(ctx=ctx)
        try:
            table = score(str(MESH_ESTIMATOR),
                          {"v": str(default_weights("student_visibility")),
                           "o": str(default_weights("student")), "untrained": str(untrained)},
                          {"tiny": (str(dataset), "val")}, renderer=r, progress=False)
        finally:
            r.release()
    row = table["tiny"]
    assert row["images"] >= 1 and all(math.isfinite(row[k]) for k in (BASE, "v", "o"))
    assert abs(row["untrained"] - row[BASE]) < 1e-4  # the classical row is the untrained design
    assert row["v"] != row["o"]
    assert table["pooled"][BASE] == row[BASE]
    assert main([str(MESH_ESTIMATOR), "nonsense", "--data", f"t={dataset}"]) == 2
    assert "expected NAME=VALUE" in capsys.readouterr().err
