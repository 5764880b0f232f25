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
