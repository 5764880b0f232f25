"""Shared fixtures: one headless GL context (EGL; llvmpipe without a GPU) for the whole session."""
import os

import pytest

# the suite is hermetic: no environment is read from or written to the user's disk cache
# (viewer.environment.disk_cache; the cache's own tests pass an explicit cache)
os.environ.setdefault("RELIGHT_ENV_CACHE", "0")


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


@pytest.fixture(scope="session")
def mitsuba_llvm():
    """Mitsuba with its fast LLVM backend, ``(mi, dr, variant)``; skipped, with the reason, where
    Mitsuba or a libLLVM >= 19 is missing (as Mitsuba's own suite skips a backend)."""
    try:
        import mitsuba  # noqa: F401
    except ImportError:
        pytest.skip("Mitsuba 3 is not installed (pip install -e '.[reference]')")
    from relight.reference.render import MIN_LLVM, find_libllvm, load_mitsuba

    if find_libllvm() is None:
        pytest.skip(f"no libLLVM >= {MIN_LLVM} (apt-get install libllvm19)")
    return load_mitsuba("llvm_ad_rgb")


@pytest.fixture(scope="session")
def generate_data(ctx):
    """``generate_data(root, config, **kw)``: :func:`learned.data.generator.generate` on the
    session's GL context, quietly, with the path tracer when ``config.targets == "reference"``."""
    def run(root, cfg, **kw):
        from learned.data.generator import generate
        from viewer.renderer import Renderer

        if cfg.targets == "reference":
            from relight.commands import reference_tracer

            kw["tracer"] = reference_tracer()
        r = Renderer(ctx=ctx)
        try:
            return generate(root, cfg, renderer=r, progress=False, **kw)
        finally:
            r.release()
    return run
