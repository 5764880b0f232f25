"""The learned indirect factor (architecture ``"indirect": "factor"``, issue 14): the untrained
student is split-sum + SSAO + the classical indirect pass, GLSL matches torch, it trains in the
forward pass, and its metadata is checked."""
import json

import numpy as np
import pytest
import torch
from neural_weights import tamper

from learned.export import export, load_model
from learned.neural.student import Student
from learned.parity.checks import neural as tn
from viewer.neural import WEIGHT_STORAGES, WeightsError, load_network


def test_indirect_student_starts_at_split_sum_with_ssao_and_indirect(programs, tmp_path):
    """An untrained student with the indirect factor (zero-initialised last layers: split3's k = 0.5
    and the indirect network's factor 2 k_i = 1) renders ``ggx_split_sum`` (single scattering) + SSAO + the classical
    indirect pass exactly, although the scene asks for neither SSAO nor indirect light: the renderer
    forces both on for it, and allocates the factor's target only for such a student."""
    from viewer.neural import learns_indirect, required_settings
    from viewer.renderer import Renderer
    from viewer.scene.description import scene_from_dict

    torch.manual_seed(5)
    s = Student(hidden=(8, 8), features="vis", output="split3", indirect="factor")
    path = tmp_path / "ind.safetensors"
    export(s, path)
    net = load_network(path, "student")
    assert net.indirect == "factor" and "mlp 9-8-8-3" in net.glsl
    assert "indirect 9-16-1 (relu, sigmoid)" in net.glsl
    assert "#define NEURAL_STUDENT_INDIRECT 1" in net.glsl
    base = scene_from_dict(tn.PARITY_SCENE).with_render(multiscatter=False, tonemap="none")
    scene = base.with_render(model="neural", weights=str(path))
    assert not scene.render.ssao.enabled and not scene.render.ssao.indirect
    assert learns_indirect(scene.render)
    forced = required_settings(scene.render)
    assert forced.ssao.enabled and forced.ssao.indirect
    renderer = Renderer(ctx=programs.ctx)
    try:
        targets = renderer.draw(scene)
        assert targets.indirect_factor is not None and targets.direct is not None
        w, h = targets.indirect_factor.size
        factor = np.frombuffer(targets.indirect_factor.read(), np.float32)
        np.testing.assert_array_equal(factor, np.ones(w * h, np.float32))
        neural = renderer.render(scene).radiance
        classical = renderer.render(base.with_render(model="ggx_split_sum", ssao=True,
                                                     indirect=True, sun=False)).radiance
        direct_only = renderer.render(base.with_render(model="ggx_split_sum", ssao=True)).radiance
        # a student without the factor: no factor target, the frame as before (indirect off)
        plain = tmp_path / "plain.safetensors"
        export(Student(hidden=(8, 8), features="vis", output="split3"), plain)
        t2 = renderer.draw(base.with_render(model="neural", weights=str(plain)))
        assert t2.indirect_factor is None and t2.direct is None
    finally:
        renderer.release()
    np.testing.assert_allclose(neural, classical, rtol=2e-6, atol=2e-6)
    assert np.abs(classical - direct_only).max() > 0.05  # the scene has indirect light to scale


def test_indirect_student_parity_glsl_vs_torch(programs):
    """A perturbed student with the factor: the networks (the student's and the indirect one, every
    weight storage), its lighting pass (the direct
    target), its second output (the factor, which varies over the frame) and the indirect pass
    scaled by it, GL against the torch twins."""
    path = tn.indirect_student(programs, tn.indirect_student(programs))  # a random one
    net = load_network(path, "student")
    assert net.indirect == "factor"
    for storage in WEIGHT_STORAGES:  # both networks read from every weight storage
        r = tn.check_network(programs, path, storage)
        assert r.passed and r.max_abs <= 1e-4, r
    r = tn.check_model(programs, "neural", {}, path)
    assert r.passed, r
    factor, frame = tn.check_indirect_factor(programs, path)
    assert factor.passed and factor.max_abs <= 2e-4, factor
    assert frame.passed, frame
    model = load_model(path)
    x = torch.from_numpy(tn.student_inputs(256))
    with torch.no_grad():
        f = model.indirect_factor(x)
    assert f.max() - f.min() > 0.2  # the factor is live, within [0, 2]
    assert 0.0 <= f.min() and f.max() <= 2.0


def test_indirect_factor_trains_in_the_forward_pass():
    """``Student.forward`` with the indirect light adds factor x L_ind (factor 1 untrained, the
    classical sum); without it, the lighting pass's direct light alone; students without the
    factor add L_ind as it is."""
    torch.manual_seed(0)
    s = Student(hidden=(8, 8), features="vis", output="split3", indirect="factor")
    x = torch.from_numpy(tn.student_inputs(64))
    n = x.shape[0]
    irr, pre, ind = torch.rand(n, 3), torch.rand(n, 3), torch.rand(n, 3)
    with torch.no_grad():
        direct = s(x, irr, pre)
        np.testing.assert_allclose(s(x, irr, pre, ind), direct + ind, rtol=1e-6, atol=1e-6)
        s.indirect_layers[-1].bias[0] = 1.0
        f = 2.0 * torch.sigmoid(torch.tensor(1.0))
        np.testing.assert_allclose(s(x, irr, pre, ind), direct + f * ind, rtol=1e-6, atol=1e-6)
        np.testing.assert_allclose(s(x, irr, pre), direct, rtol=0, atol=0)
    plain = Student(hidden=(8, 8), features="vis", output="split3")
    assert not plain.learns_indirect
    with pytest.raises(ValueError, match="three-factor output form"):
        Student(output="free6", indirect="factor")


def test_files_without_indirect_key_have_no_factor(pbr_weights):
    """Files written before the factor existed (no ``indirect`` in the architecture) load as
    ``none``; students without it still export no key, so their files are unchanged."""
    net = load_network(pbr_weights, "student")
    assert "indirect" not in net.architecture and net.indirect == "none"
    assert "#define NEURAL_STUDENT_INDIRECT 0" in net.glsl
    assert not load_model(pbr_weights).learns_indirect


@pytest.mark.parametrize("change, message", [
    ({"indirect": "factor"}, "is not the student architecture"),  # 3 outputs, factor claimed
    ({"indirect": "bogus"}, "student indirect 'bogus'"),
    ({"indirect": "factor", "output": "free6"}, "needs a three-factor output form"),
])
def test_mismatched_indirect_metadata_is_a_one_line_error(tmp_path, pbr_weights, change, message):
    arch = dict(load_network(pbr_weights).architecture) | change
    bad = tamper(pbr_weights, tmp_path / "bad.safetensors", {"architecture": json.dumps(arch)})
    with pytest.raises(WeightsError) as info:
        load_network(bad, "student")
    text = str(info.value)
    assert message in text and str(bad) in text and "\n" not in text
