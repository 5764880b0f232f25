"""Every GLSL library function against its torch twin (tolerances and measured errors live in the
cases of ``learned/parity/cases``, one module per GLSL file), and coverage of the whole library."""
import pytest

from learned.parity import check_function, coverage, library_cases

CASES = library_cases()


@pytest.mark.parametrize("name", sorted(CASES))
def test_library_parity(programs, name):
    result = check_function(programs, CASES[name])
    assert result.passed, (f"{name}: max abs {result.max_abs:.3g}, max rel {result.max_rel:.3g} "
                           f"exceeds {result.tolerance} (measured: {CASES[name].measured})")


def test_every_library_function_has_a_twin_and_a_check():
    assert coverage() == []


def test_every_case_names_the_envelope_its_tolerance_guards():
    missing = sorted(name for name, case in CASES.items() if not case.envelope.strip())
    assert not missing, f"ParityCases without an envelope: {missing}"


def _pass_checks():
    from learned.parity import pass_checks

    return pass_checks()


# Checks whose network is only their input, run here on small random networks of the shipped
# designs (the shipped files' configurations with hidden layers of 8): what they compare is the
# generated GLSL with the torch network on the same weights, whatever the weights. llvmpipe
# compiles a lighting pass that reads a shipped network from a uniform or storage block for about a
# minute (cold, CPU: model:neural:ubo 63 s; the teacher's uniform-block variant 54 s, its 18 KiB
# of weights a storage block); on the small networks 9 s and 10 s for the whole check. The shipped
# networks stay checked: the student's in every storage (neural:network:<storage>) and its const
# and texture passes (model:neural, model:neural:texture); the teacher's GLSL against its torch
# model's physics (tests/learned/test_neural_physics.py); a lighting pass with a storage block:
# tests/learned/test_neural.py::test_weights_over_16_kib_go_to_a_storage_block.
SMALL_NETWORKS = {"model:neural:ubo": "student", "model:neural_teacher": "teacher"}


@pytest.fixture(scope="module")
def small_networks(tmp_path_factory):
    """kind -> a weights file of a random network of the shipped design, hidden layers of 8."""
    import torch

    from learned.export import export, load_model
    from learned.neural.student import Student
    from learned.neural.teacher import Teacher
    from viewer.neural import default_weights

    d = tmp_path_factory.mktemp("small-networks")
    torch.manual_seed(3)
    student = Student(**{**load_model(default_weights("student"), "student").config,
                         "hidden": (8, 8)})
    with torch.no_grad():  # move the outputs away from the sigmoid's flat ends
        student.layers[-1].weight.mul_(3.0)
    teacher = Teacher(**{**load_model(default_weights("teacher"), "teacher").config,
                         "hidden": 8})
    export(student, d / "student.safetensors")
    export(teacher, d / "teacher.safetensors")
    return {"student": d / "student.safetensors", "teacher": d / "teacher.safetensors"}


@pytest.mark.parametrize("name", sorted(_pass_checks()))
def test_every_registered_pass_check(programs, name, request):
    """Every pass and model check `relight parity` runs, so none is left out of the suite (those
    of :data:`SMALL_NETWORKS` on a small network); each result passes and names the envelope its
    tolerance guards."""
    _, check = _pass_checks()[name]
    if name in SMALL_NETWORKS:
        results = check(programs, weights=request.getfixturevalue("small_networks")[
            SMALL_NETWORKS[name]])
    else:
        results = check(programs)
    assert results
    for r in results:
        assert r.passed, (f"{r.name}: max abs {r.max_abs:.3g}, max rel {r.max_rel:.3g} exceeds "
                          f"{r.tolerance} (measured: {r.measured})")
        assert r.envelope.strip(), f"{r.name}: no envelope stated beside its tolerance"
