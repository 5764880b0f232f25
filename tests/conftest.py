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


@pytest.fixture(autouse=True)
def _session_context_current(request):
    """Tests that call the CLI in-process create (and release) other contexts; make the session
    context current again for every test that uses it."""
    if "ctx" in request.fixturenames:
        with request.getfixturevalue("ctx"):
            yield
    else:
        yield
