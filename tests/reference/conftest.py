"""Fixtures for the path-traced reference: Mitsuba with its fast LLVM backend (skipped, with the
reason, where Mitsuba or a libLLVM >= 19 is missing, as Mitsuba's own suite skips a backend)."""
import pytest


@pytest.fixture(scope="session")
def mitsuba_llvm():
    try:
        import mitsuba  # noqa: F401
    except ImportError:
        pytest.skip("Mitsuba 3 is not installed (pip install -e '.[reference]')")
    from relight.reference.render import MIN_LLVM, find_libllvm, load_mitsuba

    if find_libllvm() is None:
        pytest.skip(f"no libLLVM >= {MIN_LLVM} (apt-get install libllvm19)")
    return load_mitsuba("llvm_ad_rgb")


@pytest.fixture(scope="session")
def renderer(ctx):
    from viewer.renderer import Renderer

    return Renderer(ctx=ctx)
