"""Fixtures for the path-traced reference (``mitsuba_llvm`` is in tests/conftest.py)."""
import pytest


@pytest.fixture(scope="session")
def renderer(ctx):
    from viewer.renderer import Renderer

    return Renderer(ctx=ctx)
