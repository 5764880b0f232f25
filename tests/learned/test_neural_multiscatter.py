"""A ``split3`` student whose base has ``ggx_split_sum``'s multiple-scattering compensation
(architecture ``"multiscatter": true``), and the training penalty on corrections that brighten the
base (``TrainConfig.student_gain_penalty``): the untrained student renders the classical model's
default, GLSL and torch agree on a perturbed one, files without the key render as before, the
penalty keeps a student that its targets pull brighter close to its base, and the direct penalty
(``student_direct_penalty``) keeps one that its targets pull darker at its base."""
import numpy as np
import pytest
import torch

from learned.export import export, load_model
from learned.neural.student import Student
from learned.parity.checks import neural as tn
from learned.twins.neural import NEURAL_OUTPUT_SCALE
from viewer.neural import load_network


def _render(programs, scene):
    from viewer.renderer import Renderer

    renderer = Renderer(ctx=programs.ctx)
    try:
        return renderer.render(scene).radiance
    finally:
        renderer.release()


def test_multiscatter_student_starts_at_the_classical_default(programs, tmp_path):
    """k = 0.5 everywhere (zero-initialised last layers) with the sun, the indirect factor and
    multiscatter is ``ggx_split_sum`` as it renders by default (multiscatter on, the analytic
    sun) + SSAO + indirect: equal to float rounding. The single-scattering student differs from
    it (the compensation brightens the parity scene's rough metal by percents), so the
    comparison can fail. Then torch and GLSL agree on a perturbed student (``model:neural``)."""
    from viewer.scene.description import scene_from_dict

    torch.manual_seed(5)
    s = Student(hidden=(8, 8), features="vis", output="split3", indirect="factor", sun=True,
                multiscatter=True)
    path = tmp_path / "ms.safetensors"
    export(s, path)
    net = load_network(path, "student")
    assert net.multiscatter and net.architecture["multiscatter"] is True
    assert "#define NEURAL_STUDENT_MULTISCATTER 1" in net.glsl
    assert load_model(path).multiscatter
    base = scene_from_dict(tn.PARITY_SCENE).with_render(tonemap="none")
    assert base.render.multiscatter  # the classical default
    neural = _render(programs, base.with_render(model="neural", weights=str(path)))
    classical = _render(programs, base.with_render(model="ggx_split_sum", ssao=True,
                                                   indirect=True))
    np.testing.assert_allclose(neural, classical, rtol=2e-6, atol=2e-6)
    single = Student(hidden=(8, 8), features="vis", output="split3", indirect="factor", sun=True)
    single_path = tmp_path / "single.safetensors"
    export(single, single_path)
    plain = _render(programs, base.with_render(model="neural", weights=str(single_path)))
    assert np.abs(plain[..., :3] - neural[..., :3]).max() > 1e-2
    with torch.no_grad():
        s.layers[-1].weight.normal_(0.0, 2.0)
    export(s, path)
    r = tn.check_model(programs, "neural", {}, path)
    assert r.passed, r


def test_files_without_the_multiscatter_key_keep_single_scattering(programs, tmp_path):
    """A split3 student written without ``"multiscatter"`` loads as false and renders
    ``ggx_split_sum`` with multiscatter off, as before the key existed."""
    from viewer.scene.description import scene_from_dict

    torch.manual_seed(5)
    path = tmp_path / "plain.safetensors"
    export(Student(hidden=(8, 8), features="vis", output="split3"), path)
    net = load_network(path, "student")
    assert "multiscatter" not in net.architecture and not net.multiscatter
    assert "#define NEURAL_STUDENT_MULTISCATTER 0" in net.glsl
    base = scene_from_dict(tn.PARITY_SCENE).with_render(tonemap="none", ssao=True)
    neural = _render(programs, base.with_render(model="neural", weights=str(path)))
    classical = _render(programs, base.with_render(model="ggx_split_sum", multiscatter=False,
                                                   sun=False))  # nor the sun: no "sun" key
    np.testing.assert_allclose(neural, classical, rtol=2e-6, atol=2e-6)


def test_multiscatter_needs_split3():
    with pytest.raises(ValueError, match="split3"):
        Student(output="pbr3", multiscatter=True)


def test_gain_measures_only_brightening():
    """``Student.gain``: 0 untrained (S k = 1) and for corrections that darken; the mean of
    sum max(S k - 1, 0) over the direct corrections, the indirect factor excluded."""
    torch.manual_seed(0)
    s = Student(hidden=(8,), features="vis", output="split3", indirect="factor")
    x = torch.rand(64, 11)
    assert s.gain(s.network_outputs(x)).item() == 0.0
    with torch.no_grad():
        s.layers[-1].bias.copy_(torch.tensor([-2.0, -1.0, -3.0]))  # every correction darkens
        s.indirect_layers[-1].bias.fill_(4.0)  # a brightening indirect factor does not count
    assert s.gain(s.network_outputs(x)).item() == 0.0
    with torch.no_grad():
        s.layers[-1].bias.copy_(torch.tensor([1.0, 0.0, -1.0]))
    expected = 2.0 * torch.sigmoid(torch.tensor(1.0)).item() - 1.0  # k_d alone, 0.462
    assert s.gain(s.network_outputs(x)).item() == pytest.approx(expected, rel=1e-6)
    out, gain = s(x, torch.rand(64, 3), torch.rand(64, 3), torch.rand(64, 3), with_gain=True)
    assert out.shape == (64, 3) and gain.item() == pytest.approx(expected, rel=1e-6)


@pytest.fixture(scope="module")
def training_images(tmp_path_factory, ctx):
    """(dataset folder, its train images): ten tiny generated samples the penalty tests train on."""
    from learned.data.generator import GeneratorConfig, generate
    from learned.train import load_images
    from viewer.renderer import Renderer

    dataset = tmp_path_factory.mktemp("penalties") / "data"
    r = Renderer(ctx=ctx)
    try:
        generate(dataset, GeneratorConfig(count=10, size=16, samples=4, seed=3, env_width=32),
                 renderer=r, progress=False)
        return dataset, load_images(str(dataset), "train", r, multiscatter=True)
    finally:
        r.release()


def _trained(training_images, out, design, feats, targets, **penalties):
    """A student of ``design`` trained 150 steps on ``targets`` with the given penalties."""
    from learned.train import TrainConfig
    from learned.train.runner import Run
    from learned.train.stages import distill_student

    dataset, images = training_images
    cfg = TrainConfig(data=str(dataset), out=str(out), student_steps=150, batch_pixels=128,
                      lr=1e-2, checkpoint_every=1000, log_every=1000, student_target="target",
                      **penalties)
    return distill_student(Run(cfg, 0, quiet=True), images, targets, design=design,
                           feats=feats)[0]


def test_gain_penalty_keeps_the_student_near_its_base(tmp_path, training_images):
    """The options reach the config; on targets 1.6x the base's own radiance (which pull every
    correction up) the student trained without the penalty brightens its base, and with
    ``student_gain_penalty = 5`` brightens it several times less, the same data, seed and steps.
    The exported file records multiscatter."""
    from learned.train.stages import design_features
    from relight.cli import build_parser

    args = build_parser().parse_args(["train", "--out", str(tmp_path / "x"),
                                      "--student-multiscatter", "--student-gain-penalty", "1"])
    assert args.student_multiscatter is True and args.student_gain_penalty == 1.0
    with pytest.raises(SystemExit):
        build_parser().parse_args(["train", "--student-gain-penalty", "-1"])
    _, images = training_images
    design = {"hidden": (8, 8), "features": "vis", "output": "split3", "indirect": "factor",
              "multiscatter": True}
    base = Student(**design)
    feats = design_features(base, images)
    with torch.no_grad():
        targets = [1.6 * base(*f[:3], img.indirect) for f, img in zip(feats, images)]
    gains = {}
    for weight in (0.0, 5.0):
        model = _trained(training_images, tmp_path / f"run{weight}", design, feats, targets,
                         student_gain_penalty=weight, student_direct_penalty=0.0)  # gain alone
        with torch.no_grad():
            gains[weight] = float(np.mean([model.gain(model.network_outputs(f[0])).item()
                                           for f in feats]))
    assert gains[0.0] > 0.3, gains  # the pull up is learned without the penalty
    assert gains[5.0] < 0.25 * gains[0.0], gains
    path = tmp_path / "ms.safetensors"
    export(model, path)
    assert load_network(path, "student").multiscatter


def test_direct_penalty_holds_the_direct_factors_either_way(tmp_path, training_images):
    """``student_direct_penalty``: on targets 0.6x the base's radiance (which pull every
    correction down, where the gain penalty does nothing) the student trained without it darkens
    its direct factors, and with a weight of 100 stays at the base's (S k = 1 within 2 %), the
    same data, seed and steps; Student.deviation is the mean squared distance, 0 untrained at
    k = 0.5; the option reaches the config."""
    from learned.train.stages import design_features
    from relight.cli import build_parser

    args = build_parser().parse_args(["train", "--student-direct-penalty", "100"])
    assert args.student_direct_penalty == 100.0
    _, images = training_images
    design = {"hidden": (8, 8), "features": "ssao", "output": "split3", "indirect": "factor",
              "multiscatter": True}
    base = Student(**design)
    with torch.no_grad():
        for p in (base.layers[-1].weight, base.layers[-1].bias):
            p.zero_()
    feats = design_features(base, images)
    assert base.deviation(base.network_outputs(feats[0][0])).item() == pytest.approx(0.0, abs=1e-12)
    with torch.no_grad():
        targets = [0.6 * base(*f[:3], img.indirect) for f, img in zip(feats, images)]
    spread = {}
    for weight in (0.0, 100.0):
        model = _trained(training_images, tmp_path / f"run{weight}", design, feats, targets,
                         student_direct_penalty=weight, student_gain_penalty=0.0)  # direct alone
        with torch.no_grad():
            k = torch.cat([model.network_outputs(f[0])[:, :3] for f in feats]) * NEURAL_OUTPUT_SCALE
        spread[weight] = float((k - 1.0).abs().max())
    assert spread[0.0] > 0.1, spread  # the pull down is learned without the penalty
    assert spread[100.0] < 0.02, spread
