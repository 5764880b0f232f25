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


@pytest.mark.parametrize("name", sorted(_pass_checks()))
def test_every_registered_pass_check(programs, name):
    """Every pass and model check `relight parity` runs, so none is left out of the suite; each
    result passes and names the envelope its tolerance guards."""
    _, check = _pass_checks()[name]
    results = check(programs)
    assert results
    for r in results:
        assert r.passed, (f"{r.name}: max abs {r.max_abs:.3g}, max rel {r.max_rel:.3g} exceeds "
                          f"{r.tolerance} (measured: {r.measured})")
        assert r.envelope.strip(), f"{r.name}: no envelope stated beside its tolerance"
