"""Shared fixtures: one headless GL context (EGL; llvmpipe without a GPU) for the whole session."""
import pytest


@pytest.fixture(scope="session")
def ctx():
    from viewer.errors import GLContextError
    from viewer.gl import create_context

    try:
        return create_context()
    except GLContextError as exc:  # pragma: no cover - only on machines without EGL
        pytest.skip(f"no headless OpenGL: {exc}")


@pytest.fixture(scope="session")
def programs(ctx):
    from viewer.gl import Programs

    return Programs(ctx)


def pytest_addoption(parser):
    parser.addoption("--regen-golden", action="store_true",
                     help="rewrite the golden reference images in tests/golden")


@pytest.fixture(scope="module", autouse=True)
def _session_context_current_module(request):
    """Tests that call the CLI in-process create (and release) contexts of their own, which leaves
    no context current. Make the session context current again for every module (before its
    module-scoped fixtures) and every test."""
    from viewer.gl import make_current

    make_current(request.getfixturevalue("ctx"))


@pytest.fixture(autouse=True)
def _session_context_current(ctx):
    from viewer.gl import make_current

    make_current(ctx)
