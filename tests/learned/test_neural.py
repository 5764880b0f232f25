"""The neural shader: export/load round trip, GLSL parity on random weights in every weight
storage, the shipped weights and ``relight parity``. Student designs: test_neural_students.py,
bad files: test_neural_bad_files.py, the learned indirect factor: test_neural_indirect.py, the
teacher: test_neural_teacher.py."""
import json

import pytest

from learned.export import load_model
from learned.parity.checks import neural as tn
from viewer.neural import WEIGHT_STORAGES, load_network


def test_round_trip_and_generated_header(weights):
    s_path, _ = weights
    net = load_network(s_path, "student")
    model = load_model(s_path)
    assert net.checkpoint == model.checkpoint and net.training == {"note": "test"}
    assert net.glsl.splitlines()[2] == f"// checkpoint sha256:{net.checkpoint}"
    assert "mlp 40-16-32-6" in net.glsl  # 8 inputs x (1 + 2 x 2 frequencies)
    assert net.macs() == model.macs_per_pixel() == 40 * 16 + 16 * 32 + 32 * 6


def test_student_network_parity(programs, weights):
    r = tn.check_network(programs, weights[0])
    assert r.passed and r.max_abs <= 1e-4, r


@pytest.mark.parametrize("storage", WEIGHT_STORAGES)
def test_every_weight_storage_matches_torch(programs, weights, small_weights, storage):
    """Baked constants, uniform block and texture give the torch student's outputs (kernel and
    lighting pass) and the teacher's (pass); measured max abs 1.0e-7 for every storage.

    The lighting pass runs the smaller student of ``small_weights`` (8-12 hidden, 24 inputs; the
    same generated code, block binding and upload, 360 instead of 1344 weight reads): llvmpipe
    compiles the pass with the ``weights`` student's uniform-block reads in 67 s of CPU (7.5 s for
    the small one, 3 s with constants), and the kernel check above still runs that student in
    every storage."""
    s_path, t_path = weights
    code = load_network(s_path).code(storage)
    assert code.binding == storage and f"// weight storage {storage}" in code.glsl
    assert (code.data is None) == (storage == "const")
    r = tn.check_network(programs, s_path, storage)
    assert r.passed and r.max_abs <= 1e-4, r
    assert load_network(small_weights).code(storage).binding == storage
    r = tn.check_model(programs, "neural", {"neural_storage": storage}, small_weights)
    assert r.passed, r
    r = tn.check_model(programs, "neural_teacher",
                       {"samples": 4, "sampling": "uniform", "neural_storage": storage}, t_path)
    assert r.passed, r


def test_weights_over_16_kib_go_to_a_storage_block(programs, weights, monkeypatch):
    """``ubo`` storage above the 16 KiB minimum uniform-block size is a read-only SSBO (a small
    limit stands in for a big network: a real one compiles for minutes on llvmpipe): the kernel,
    and a lighting pass (a teacher with hidden layers of 8, as the shipped teacher's 18 KiB of
    weights are a storage block; tests/shaders/test_library_parity.py runs its check on a small
    network)."""
    import shutil

    import viewer.neural as vn

    net = load_network(weights[0], "student")
    assert net.code("ubo").binding == "ubo"
    monkeypatch.setattr(vn.glsl, "UBO_MIN_MAX_BYTES", 256)
    code = vn.generate_glsl(net, "ubo")
    assert code.binding == "ssbo" and "readonly buffer" in code.glsl
    monkeypatch.setitem(net._code, "ubo", code)
    r = tn.check_network(programs, weights[0], "ubo")
    assert r.passed and r.max_abs <= 1e-4, r
    teacher = tn.other_teacher()  # a fresh file: its code is generated under the small limit
    try:
        assert load_network(teacher, "teacher").code("ubo").binding == "ssbo"
        r = tn.check_model(programs, "neural_teacher",
                           {"samples": 4, "sampling": "uniform", "neural_storage": "ubo"}, teacher)
        assert r.passed and r.name.endswith("neural_storage=ubo"), r
    finally:
        shutil.rmtree(teacher.parent, ignore_errors=True)


def test_unknown_weight_storage_is_a_scene_error():
    from viewer.errors import SceneError
    from viewer.scene.description import scene_from_dict

    with pytest.raises(SceneError, match="render.neural_storage = 'ssbo' is not one of"):
        scene_from_dict({"render": {"model": "neural", "neural_storage": "ssbo"}})


def test_student_and_teacher_pass_parity(programs, weights):
    r = tn.check_model(programs, "neural", {}, weights[0])
    assert r.passed, r
    r = tn.check_model(programs, "neural_teacher", {"samples": 4, "sampling": "uniform"},
                       weights[1])
    assert r.passed, r


def test_shipped_weights_load_and_are_small():
    from viewer.neural import default_weights

    net = load_network(default_weights("student"), "student")
    assert net.macs() <= 4096 and net.training.get("stage") == "student"
    teacher = load_network(default_weights("teacher"), "teacher")
    # the shipped student learns from the path-traced targets themselves (--student-target
    # target); a distilled one records the teacher it was distilled from
    assert net.training["distilled_from"] in (teacher.checkpoint, "the dataset's targets")
    assert net.training["config"]["student_target"] == "target"


def test_parity_cli_neural_passes(capsys):
    """``--model neural`` runs the neural checks and ``--skip`` leaves out the named ones (the
    lighting passes and the uniform-block network, whose compile is the slow one on llvmpipe:
    tests/shaders/test_library_parity.py runs them all, this test checks the command's flow)."""
    from relight.cli import main

    skipped = ("model:neural", "model:neural:ubo", "model:neural:texture", "neural:network:ubo")
    assert main(["parity", "--model", "neural", "--json",
                 *[a for name in skipped for a in ("--skip", name)]]) == 0
    rows = json.loads(capsys.readouterr().out)
    names = {r["name"] for r in rows}
    assert {"neural:network", "neural:network:texture"} <= names
    assert "neural:network:ubo" not in names  # --skip names a network check too
    assert not any(n.startswith("model:neural") for n in names), names  # both --model neural
    # and --skip leave out model:neural_teacher: another model's check
    net = next(r for r in rows if r["name"] == "neural:network")
    assert net["passed"] and net["max_abs"] <= 1e-4
