"""The ``ssao`` student (issue 38: a student that never invents a shadow): its network reads no
screen-space evidence, neither S(x) nor the occlusion O(x), which enters only as the factor on the
diffuse light, exactly as the classical models apply it. Students that read the evidence turned
its noise and stretch into speckle and invented shadows on real assets
(docs/measurements/real-assets.md); these tests hold the construction that rules that out."""
import dataclasses

import numpy as np
import pytest
import torch
from neural_weights import student_file

from learned.export import load_model
from learned.neural.student import FEATURE_INPUTS, Student
from learned.parity.checks import neural as tn
from viewer.neural import (load_network, needs_env_visibility, reads_occlusion,
                           reads_visibility, required_settings)
from viewer.neural.contract import STUDENT_FEATURES, _required_networks
from viewer.scene.description import scene_from_dict

DESIGN = {"features": "ssao", "output": "split3", "indirect": "factor", "sun": True,
          "multiscatter": True}


@pytest.fixture(scope="module")
def ssao_weights(tmp_path_factory):
    return student_file(tmp_path_factory, "ssao", 5, **DESIGN)


def test_the_network_never_reads_the_occlusion():
    """Two inputs that differ only in ao (material AO x O(x)) give the same network outputs, so
    the same specular and indirect factors, and diffuse factors in exactly ao's ratio: O(x)
    darkens the diffuse light as it darkens split-sum's, and nothing else. A ``base`` student
    (ao among its inputs) fails the same check: the check can fail."""
    torch.manual_seed(3)
    x = torch.from_numpy(tn.student_inputs(256))
    lo, hi = x.clone(), x.clone()
    lo[:, 6], hi[:, 6] = 0.2, 0.9
    s = Student(hidden=(8, 8), **DESIGN)
    with torch.no_grad():
        for p in s.parameters():
            p.normal_(0.0, 1.0)
        k_lo, k_hi = s.weights(lo), s.weights(hi)
        assert torch.equal(s.network_outputs(lo), s.network_outputs(hi))
        assert torch.equal(k_lo[:, 1:], k_hi[:, 1:])
        torch.testing.assert_close(k_hi[:, 0] / k_lo[:, 0], torch.full((len(x),), 0.9 / 0.2))
        base = Student(hidden=(8, 8), **(DESIGN | {"features": "base"}))
        for p in base.parameters():
            p.normal_(0.0, 1.0)
        assert (base.network_outputs(lo) - base.network_outputs(hi)).abs().max() > 1e-3
    assert "ao" not in STUDENT_FEATURES["ssao"] and "vis" not in STUDENT_FEATURES["ssao"]
    assert FEATURE_INPUTS == STUDENT_FEATURES  # the torch side's input sets are the viewer's


def test_ssao_needs_the_occlusion_factor():
    """Without the factor ao would enter nowhere: refused by the model and by a file's check."""
    with pytest.raises(ValueError, match="only as a factor"):
        Student(features="ssao", occlusion="input")
    arch = {"num_freqs": 0, "hidden": [8], "features": "ssao", "occlusion": "input"}
    with pytest.raises(ValueError, match="only as a factor"):
        _required_networks("student", arch)


def test_ssao_student_round_trip_parity_and_its_passes(programs, ssao_weights):
    """The exported file: GLSL and torch agree on the network and on whole frames; the renderer
    runs SSAO for it although the scene did not ask (its ao was trained with O(x)) but not the
    march of S(x) it does not read."""
    net = load_network(ssao_weights, "student")
    assert net.features == "ssao" and "mlp 21-8-12-3" in net.glsl  # 7 inputs x (1 + 2)
    assert "#define NEURAL_STUDENT_VIS 0" in net.glsl
    model = load_model(ssao_weights)
    assert model.reads_occlusion and not model.reads_visibility
    r = tn.check_network(programs, ssao_weights)
    assert r.passed and r.max_abs <= 1e-4, r
    r = tn.check_model(programs, "neural", {}, ssao_weights)
    assert r.passed, r
    scene = scene_from_dict(tn.PARITY_SCENE).with_render(model="neural",
                                                          weights=str(ssao_weights))
    assert not scene.render.ssao.enabled
    assert reads_occlusion(scene.render) and not reads_visibility(scene.render)
    assert not needs_env_visibility(scene.render)
    settings = required_settings(scene.render)
    assert settings.ssao.enabled and settings.ssao.indirect
    from viewer.renderer import Renderer

    renderer = Renderer(ctx=programs.ctx)
    try:
        t = renderer.draw(dataclasses.replace(scene, render=settings))
        w, h = t.ssao.size
        img = np.frombuffer(t.ssao.read(), np.float32).reshape(h, w, 4)
        assert img[..., 0].min() < 0.9  # O(x) darkens the contact under the sphere
    finally:
        renderer.release()
