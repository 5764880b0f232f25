"""Shared fixtures: one headless GL context (EGL; llvmpipe without a GPU) for the whole session.

Two things stop the session at its start with one line and a non-zero exit instead of letting
tests skip (a suite that skips everything would pass):

* no headless OpenGL context (every test needs one: the fixtures below make it current for every
  module and test). There is no opt-out: no part of the suite runs without GL.
* ``RELIGHT_REQUIRE_TRUTH=1`` (``.ci/run`` sets it) and no path tracer with its fast backend
  (Mitsuba 3 and a libLLVM >= 19): without it the ``mitsuba_llvm`` fixture skips every
  path-traced check, which is fine on a workstation and never in CI.
"""
import importlib.util
import os

import pytest

# the suite is hermetic: no environment is read from or written to the user's disk cache
# (viewer.environment.disk_cache; the cache's own tests pass an explicit cache)
os.environ.setdefault("RELIGHT_ENV_CACHE", "0")

# pytest-xdist workers share the cores: each worker's torch and llvmpipe rasterizer get
# cores // workers threads (at least one), so `-n 2` on two cores does not run eight threads that
# mostly wait and spin (tests/learned/test_neural.py + test_neural_students.py in one process,
# cold: 101 -> 85 s of CPU, 125 -> 88 s wall with one thread each). A setting already made wins.
if os.environ.get("PYTEST_XDIST_WORKER_COUNT"):  # set by xdist before this file is imported
    _threads = str(max(1, (os.cpu_count() or 1) // int(os.environ["PYTEST_XDIST_WORKER_COUNT"])))
    os.environ.setdefault("OMP_NUM_THREADS", _threads)
    os.environ.setdefault("LP_NUM_THREADS", _threads)

REQUIRE_TRUTH = "RELIGHT_REQUIRE_TRUTH"
_SESSION_CONTEXT = []  # the context pytest_sessionstart created (a worker's or a lone session's)


def _truth_missing() -> str | None:
    """Why the path-traced checks would skip (what ``mitsuba_llvm`` checks), or None."""
    if importlib.util.find_spec("mitsuba") is None:
        return "Mitsuba 3 is not installed (pip install -e '.[reference]')"
    from relight.reference import render

    if render.find_libllvm() is None:
        return f"no libLLVM >= {render.MIN_LLVM} (apt-get install libllvm19)"
    return None


def pytest_sessionstart(session):
    if os.environ.get(REQUIRE_TRUTH) == "1":
        missing = _truth_missing()
        if missing:
            pytest.exit(f"{REQUIRE_TRUTH}=1 but the path tracer cannot run: {missing}; every "
                        f"path-traced check would skip", returncode=pytest.ExitCode.TESTS_FAILED)
    from viewer.errors import GLContextError
    from viewer.gl import create_context

    try:
        ctx = create_context()
    except GLContextError as exc:
        pytest.exit(f"no test can run without a headless OpenGL context: {exc}",
                    returncode=pytest.ExitCode.TESTS_FAILED)
    if session.config.pluginmanager.hasplugin("dsession"):  # pytest-xdist's controller: no tests
        ctx.release()
    else:
        _SESSION_CONTEXT.append(ctx)


@pytest.fixture(scope="session")
def ctx():
    return _SESSION_CONTEXT[0]


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
    Mitsuba or a libLLVM >= 19 is missing (as Mitsuba's own suite skips a backend), unless
    ``RELIGHT_REQUIRE_TRUTH=1``, which stops the session at its start instead."""
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
