"""A ``split3`` student whose base shades the environment's sun analytically (architecture
``"sun": true``): its untrained frame is ``ggx_split_sum`` with ``SUN_LIGHT``, GLSL and torch agree
on a perturbed one, and files without the key render as before; malformed sun and multiscatter
keys (the split3 base's switches) are one-line errors."""
import json

import numpy as np
import pytest
import torch

from learned.export import export, load_model
from learned.neural.student import Student
from learned.parity.checks import neural as tn
from viewer.neural import WeightsError, load_network, shades_sun


def _render(programs, scene):
    from viewer.renderer import Renderer

    renderer = Renderer(ctx=programs.ctx)
    try:
        frame = renderer.render(scene)
        targets = renderer.draw(scene)
        return frame.radiance, dict(targets.variant.defines)
    finally:
        renderer.release()


def test_sun_student_starts_at_the_split_sum_model_with_the_sun(programs, tmp_path):
    """k = 0.5 everywhere (zero-initialised last layer) is ``ggx_split_sum`` with the analytic
    sun (single scattering): the two passes agree to float rounding, the neural one compiled
    with SUN_LIGHT; then torch and GLSL agree on a perturbed student (``model:neural``)."""
    from viewer.scene.description import scene_from_dict

    torch.manual_seed(5)
    s = Student(hidden=(8, 8), features="vis", output="split3", sun=True)
    path = tmp_path / "sun.safetensors"
    export(s, path)
    net = load_network(path, "student")
    assert net.sun and net.architecture["sun"] is True
    assert "#define NEURAL_STUDENT_SUN 1" in net.glsl
    assert load_model(path).sun
    base = scene_from_dict(tn.PARITY_SCENE).with_render(multiscatter=False, tonemap="none",
                                                         ssao=True)
    assert shades_sun(base.with_render(model="neural", weights=str(path)).render)
    neural, defines = _render(programs, base.with_render(model="neural", weights=str(path)))
    assert defines.get("SUN_LIGHT") == 1
    classical, cdef = _render(programs, base.with_render(model="ggx_split_sum"))
    assert cdef.get("SUN_LIGHT") == 1
    np.testing.assert_allclose(neural, classical, rtol=2e-6, atol=2e-6)
    # render.sun = false is overridden for it: its base was trained with the sun's light
    forced, fdef = _render(programs, base.with_render(model="neural", weights=str(path),
                                                      sun=False))
    assert fdef.get("SUN_LIGHT") == 1
    np.testing.assert_array_equal(forced, neural)
    with torch.no_grad():
        s.layers[-1].weight.normal_(0.0, 2.0)
    export(s, path)
    r = tn.check_model(programs, "neural", {}, path)
    assert r.passed, r


def test_files_without_the_sun_key_render_as_before(programs, tmp_path):
    """A split3 student written without ``"sun"`` loads as false, compiles no SUN_LIGHT and
    renders bit-identically whatever ``render.sun`` says (its base is the plain split-sum)."""
    from viewer.scene.description import scene_from_dict

    torch.manual_seed(5)
    s = Student(hidden=(8, 8), features="vis", output="split3")
    path = tmp_path / "plain.safetensors"
    export(s, path)
    net = load_network(path, "student")
    assert "sun" not in net.architecture and not net.sun
    assert "#define NEURAL_STUDENT_SUN 0" in net.glsl
    base = scene_from_dict(tn.PARITY_SCENE).with_render(model="neural", weights=str(path),
                                                         tonemap="none")
    on, d_on = _render(programs, base)
    off, d_off = _render(programs, base.with_render(sun=False))
    assert "SUN_LIGHT" not in d_on and d_on == d_off
    np.testing.assert_array_equal(on, off)


def test_sun_needs_split3():
    with pytest.raises(ValueError, match="split3"):
        Student(output="pbr3", sun=True)


@pytest.mark.parametrize("change, message", [  # the split3 base's switches: sun, multiscatter
    ({"sun": "yes"}, "student sun 'yes'"),
    ({"sun": True, "output": "pbr3"}, "student sun needs the split3 output form"),
    ({"multiscatter": 1}, "student multiscatter 1"),
    ({"multiscatter": True, "output": "pbr3"}, "student multiscatter needs the split3 output"),
])
def test_bad_base_metadata_is_a_one_line_error(tmp_path, change, message):
    from safetensors import safe_open
    from safetensors.numpy import save_file

    torch.manual_seed(0)
    src = tmp_path / "s.safetensors"
    export(Student(hidden=(4,), output="split3"), src)
    with safe_open(str(src), framework="numpy") as f:
        meta = dict(f.metadata())
        tensors = {k: f.get_tensor(k) for k in f.keys()}
    meta["architecture"] = json.dumps(json.loads(meta["architecture"]) | change)
    bad = tmp_path / "bad.safetensors"
    save_file(tensors, str(bad), metadata=meta)
    with pytest.raises(WeightsError) as info:
        load_network(bad, "student")
    text = str(info.value)
    assert message in text and str(bad) in text and "\n" not in text


def test_training_a_sun_student(tmp_path, ctx):
    """``relight train --student-sun`` reaches the config; the training images carry the IBL
    without the sun (with the sun) and the student trains on its base and exports ``"sun": true``."""
    from learned.data.generator import GeneratorConfig, generate
    from learned.train import TrainConfig, load_images, train
    from relight.cli import build_parser
    from viewer.renderer import Renderer

    args = build_parser().parse_args(["train", "--out", str(tmp_path / "x"), "--student-sun"])
    assert args.student_sun is True
    assert build_parser().parse_args(["train", "--out", str(tmp_path / "x")]).student_sun is None
    dataset = tmp_path / "data"
    r = Renderer(ctx=ctx)
    try:
        generate(dataset, GeneratorConfig(count=10, size=16, samples=4, seed=3, env_width=32),
                 renderer=r, progress=False)
        images = load_images(str(dataset), "train", r, sun=True)
    finally:
        r.release()
    assert all(img.lighting_sun is not None for img in images)
    assert any(img.lighting_sun.sun is not None for img in images), "no sun in the test data"
    cfg = TrainConfig(data=str(dataset), out=str(tmp_path / "run"), teacher_steps=3,
                      shadow_steps=2, student_steps=40, batch_pixels=128, light_samples=4,
                      teacher_hidden=8, teacher_freqs=0, student_hidden=(8, 8), shadow_width=4,
                      distill_samples=4, lr=3e-3, checkpoint_every=10, log_every=10,
                      student_target="target", student_features="vis", student_output="split3",
                      student_sun=True)
    res = train(cfg, quiet=True)
    net = load_network(res["student"], "student")
    assert net.sun and load_model(res["student"]).sun
    assert np.abs(net.tensors["mlp.2.weight"]).max() > 0.0  # moved off the zero start


def test_sun_student_under_several_environment_lights(programs, tmp_path):
    """Under a map of three compact lights the student's input takes the most energetic (its
    sun); the other two go through its classical base (ENV_LIGHTS 2): untrained it is still
    ``ggx_split_sum`` with all three lights, and GLSL and torch agree on a perturbed student."""
    from tests.viewer.test_env_lights import three_discs
    from viewer.imageio import write_exr
    from viewer.scene.description import scene_from_dict

    env_path = tmp_path / "discs.exr"
    write_exr(env_path, three_discs(128))
    environment = {"path": str(env_path), "rotation_deg": 25.0, "intensity": 0.8}
    torch.manual_seed(6)
    s = Student(hidden=(8, 8), features="vis", output="split3", sun=True)
    path = tmp_path / "sun.safetensors"
    export(s, path)
    base = scene_from_dict(dict(tn.PARITY_SCENE, environment=environment)).with_render(
        multiscatter=False, tonemap="none", ssao=True, shadows=False)
    neural, defines = _render(programs, base.with_render(model="neural", weights=str(path)))
    assert defines.get("SUN_LIGHT") == 1 and defines.get("ENV_LIGHTS") == 2
    classical, cdef = _render(programs, base.with_render(model="ggx_split_sum"))
    assert cdef.get("ENV_LIGHTS") == 2
    np.testing.assert_allclose(neural, classical, rtol=2e-6, atol=2e-6)
    with torch.no_grad():
        s.layers[-1].weight.normal_(0.0, 2.0)
    export(s, path)
    r = tn.check_model(programs, "neural", {}, path, environment=environment)
    assert r.passed, r
