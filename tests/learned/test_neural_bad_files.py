"""Bad neural-shader weights files: each problem a one-line error naming the file, nothing
overwritten; files written before a key existed load with its old default."""
import json

import pytest
from neural_weights import tamper

from learned.export import load_model
from viewer.neural import WeightsError, load_network


def test_files_without_output_form_are_free6(tmp_path, dfg_weights):
    """Weights exported before the output form existed (no ``output`` key) load as ``free6``."""
    arch = dict(load_network(dfg_weights).architecture)
    del arch["output"]
    old = tamper(dfg_weights, tmp_path / "old.safetensors", {"architecture": json.dumps(arch)})
    net = load_network(old, "student")
    assert net.output == "free6" and "#define NEURAL_STUDENT_PBR 0" in net.glsl
    assert load_model(old).output == "free6"


def test_unknown_student_output_form_is_rejected(tmp_path, pbr_weights):
    arch = dict(load_network(pbr_weights).architecture, output="rgb9")
    bad = tamper(pbr_weights, tmp_path / "o.safetensors", {"architecture": json.dumps(arch)})
    with pytest.raises(WeightsError, match="student output form 'rgb9'"):
        load_network(bad)


def test_unknown_student_features_are_rejected(tmp_path, dfg_weights):
    arch = dict(load_network(dfg_weights).architecture, features="fancy")
    bad = tamper(dfg_weights, tmp_path / "f.safetensors", {"architecture": json.dumps(arch)})
    with pytest.raises(WeightsError, match="student features 'fancy'"):
        load_network(bad)


@pytest.mark.parametrize("case, message", [
    ("truncated", "truncated or corrupt"),
    ("version", "format version '99' is not supported"),
    ("format", "not a relight neural-shader file"),
    ("architecture", "is not the student architecture"),
    ("tampered", "checkpoint hash mismatch"),
    ("kind", "holds a teacher network, expected a student"),
])
def test_bad_weights_are_one_line_errors_naming_the_file(tmp_path, weights, case, message):
    s_path, t_path = weights
    bad = tmp_path / f"{case}.safetensors"
    if case == "truncated":
        bad.write_bytes(s_path.read_bytes()[:-100])
    elif case == "version":
        tamper(s_path, bad, {"version": "99"})
    elif case == "format":
        tamper(s_path, bad, {"format": "something-else"})
    elif case == "architecture":
        arch = json.loads(load_network(s_path).architecture and
                          json.dumps(load_network(s_path).architecture))
        arch["networks"]["mlp"]["sizes"][1] = 17
        tamper(s_path, bad, {"architecture": json.dumps(arch)})
    elif case == "tampered":
        tamper(s_path, bad, tensor_change="mlp.0.weight")
    else:
        bad.write_bytes(t_path.read_bytes())
    before = bad.read_bytes()
    with pytest.raises(WeightsError) as info:
        load_network(bad, "student")
    text = str(info.value)
    assert message in text and str(bad) in text and "\n" not in text
    assert bad.read_bytes() == before  # nothing overwritten


def test_render_with_bad_weights_is_a_scene_level_error(tmp_path, ctx):
    from viewer.renderer import Renderer
    from viewer.scene.description import scene_from_dict

    missing = tmp_path / "none.safetensors"
    scene = scene_from_dict({"camera": {"size": [8, 8]},
                             "objects": [{"type": "sphere"}],
                             "render": {"model": "neural", "weights": str(missing)}})
    r = Renderer(ctx=ctx)
    try:
        with pytest.raises(WeightsError, match="weights file not found"):
            r.render(scene)
    finally:
        r.release()
