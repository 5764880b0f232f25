"""The neural teacher: linear in the light it is given, and the teacher without the light's
radiance among its inputs (``"light_input": false``)."""
import json

import pytest
import torch

from learned.export import export, load_model
from learned.neural.teacher import Teacher
from learned.parity.checks import neural as tn
from neural_weights import tamper
from viewer.neural import TEACHER_INPUTS, WeightsError, load_network


def test_teacher_estimate_is_linear_in_light(weights):
    """rho L_in / p: doubling the environment doubles the light feature's multiplier (the log
    feature changes too, so only zero light is checked exactly: no light, no radiance)."""
    t = load_model(weights[1])
    n = torch.nn.functional.normalize(torch.randn(64, 3), dim=-1)
    mat = torch.rand(64, 6)
    l = torch.nn.functional.normalize(torch.randn(64, 3), dim=-1)
    with torch.no_grad():
        c = t.contribution(mat, n, -n, l, torch.zeros(64, 3))
    assert torch.all(c == 0)


# ---- the teacher without the light's radiance among its inputs ("light_input": false) -----------

@pytest.fixture(scope="module")
def lightless_teacher(tmp_path_factory):
    torch.manual_seed(5)
    path = tmp_path_factory.mktemp("lightless") / "t.safetensors"
    export(Teacher(hidden=8, num_freqs=1, light_input=False), path)
    return path


def test_lightless_teacher_round_trip_and_generated_code(lightless_teacher, weights):
    """``"light_input": false`` is recorded, reloaded and generated without the log(1 + L_in)
    inputs (13 inputs x 3 Fourier terms); a file without the key is the thesis's teacher, whose
    generated code still computes them."""
    net = load_network(lightless_teacher, "teacher")
    assert net.architecture["light_input"] is False and not net.light_input
    assert net.architecture["inputs"][-1] == "NoL"
    assert net.architecture["networks"]["diffuse"]["sizes"][0] == 13 * 3
    assert "log_lin" not in net.glsl and "rho * L_in" in net.glsl
    assert load_model(lightless_teacher).light_input is False
    old = load_network(weights[1], "teacher")
    assert "light_input" not in old.architecture and old.light_input
    assert "vec3 log_lin = log(1.0 + lin);" in old.glsl


def test_lightless_teacher_is_exactly_linear_in_the_light(lightless_teacher):
    """rho sees no radiance, so the contribution rho L_in is linear in L_in: twice the light is
    twice the contribution to float32 rounding (a power-of-two scale: exactly)."""
    t = load_model(lightless_teacher)
    g = torch.Generator().manual_seed(0)
    n = torch.nn.functional.normalize(torch.randn(256, 3, generator=g), dim=-1)
    l = torch.nn.functional.normalize(torch.randn(256, 3, generator=g), dim=-1)
    mat, li = torch.rand(256, 6, generator=g), 10.0 * torch.rand(256, 3, generator=g)
    with torch.no_grad():
        one = t.contribution(mat, n, -n, l, li)
        two = t.contribution(mat, n, -n, l, 2.0 * li)
    assert torch.equal(two, 2.0 * one)


def test_lightless_teacher_pass_parity(programs, lightless_teacher):
    r = tn.check_model(programs, "neural_teacher", {"samples": 4, "sampling": "env"},
                       lightless_teacher, label="light_input=false")
    assert r.passed and r.name.endswith(":light_input=false"), r


@pytest.mark.parametrize("change, message", [
    ({"light_input": "no"}, "teacher light_input 'no'"),
    ({"light_input": True}, "is not the teacher architecture"),
])
def test_mismatched_light_input_metadata_is_a_one_line_error(tmp_path, lightless_teacher,
                                                             change, message):
    arch = dict(load_network(lightless_teacher).architecture, **change)
    if change.get("light_input") is True:  # the key says 16 inputs; keep the inputs list honest
        arch["inputs"] = list(TEACHER_INPUTS)
    bad = tamper(lightless_teacher, tmp_path / "t.safetensors",
                  {"architecture": json.dumps(arch)})
    with pytest.raises(WeightsError, match=message):
        load_network(bad)


def test_the_teachers_default_sample_count_converges():
    """``[render] samples`` unset: the teacher accumulates its own count (256), whose frame of the
    parity scene (a sky with a sharp sun: the hard case) is within 6 % RMS of a 1024-spp frame of
    another seed, with under 3 % of the pixels' luminance off by more than half (measured 2.7 %
    and 1.2 % against 4096 spp); one sample per pixel is salt-and-pepper noise (measured 236 %
    and 92 %)."""
    import numpy as np

    from learned.parity.checks.models import PARITY_SCENE, gl_texture
    from viewer.models import TEACHER_SAMPLES, model_info, sample_count
    from viewer.renderer import Renderer
    from viewer.scene.description import scene_from_dict

    doc = {**PARITY_SCENE, "camera": {**PARITY_SCENE["camera"], "size": [32, 24]}}
    scene = scene_from_dict(doc).with_render(model="neural_teacher")
    assert scene.render.mc.samples is None and sample_count(scene.render) == TEACHER_SAMPLES
    assert model_info("ggx_mc").samples == 1
    renderer = Renderer()
    try:
        got = {}
        for spp, seed in ((None, 0), (1, 0), (1024, 1)):
            targets = renderer.draw(scene if spp is None else
                                    scene.with_render(samples=spp, seed=seed))
            assert targets.samples == (spp or TEACHER_SAMPLES)
            rgba = gl_texture(targets.radiance)  # alpha: coverage
            got[spp] = rgba[..., :3][rgba[..., 3] > 0]
    finally:
        renderer.release()
    ref = got[1024]

    def rel_rms(x):
        return float(np.sqrt(((x - ref) ** 2).mean()) / ref.mean())

    def speckle(x):  # luminance off by more than half
        return float((np.abs(x.mean(-1) - ref.mean(-1)) > 0.5 * ref.mean(-1) + 1e-3).mean())

    assert rel_rms(got[None]) < 0.06 and speckle(got[None]) < 0.03, (rel_rms(got[None]),
                                                                      speckle(got[None]))
    assert rel_rms(got[1]) > 1.0 and speckle(got[1]) > 0.5, (rel_rms(got[1]), speckle(got[1]))
