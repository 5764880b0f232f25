"""Every GLSL library function against its torch twin (tolerances and measured errors live in the
``PARITY_CASES`` of each ``learned/twins`` module), and coverage of the whole library."""
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
