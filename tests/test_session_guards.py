"""The session stops, non-zero, with one line where a suite that skipped would pass
(tests/conftest.py ``pytest_sessionstart``): no headless OpenGL context at all, and
``RELIGHT_REQUIRE_TRUTH=1`` (set by ``.ci/run``) without the path tracer's fast backend. Each
check runs pytest on one cheap module in a subprocess (about a second each)."""
import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
TARGET = "tests/viewer/test_cache_working_set.py"  # pure Python, five tests
NO_LLVM = ("import relight.reference.render as r; r.find_libllvm = lambda: None; "
           "import pytest, sys; sys.exit(pytest.main(sys.argv[1:]))")


def _pytest(*args, env=None, code=None):
    base = {k: v for k, v in os.environ.items()  # nothing of the pytest running this one
            if k != "RELIGHT_REQUIRE_TRUTH" and not k.startswith("PYTEST_")}
    cmd = [sys.executable, "-c", code] if code else [sys.executable, "-m", "pytest"]
    run = subprocess.run([*cmd, "-q", "-p", "no:cacheprovider", *args, TARGET], cwd=ROOT,
                         env={**base, **(env or {})}, capture_output=True, text=True, timeout=120,
                         check=False)
    return run.returncode, run.stdout + run.stderr


@pytest.mark.parametrize("xdist", [[], ["-n", "2"]], ids=["serial", "xdist"])
def test_no_opengl_fails_the_session(xdist):
    """EGL without any vendor library (glvnd reads none from a missing file): context creation
    really fails, and the session fails with the reason instead of skipping every test."""
    rc, out = _pytest(*xdist, env={"__EGL_VENDOR_LIBRARY_FILENAMES": "/nonexistent.json"})
    assert rc != 0, out
    assert "no test can run without a headless OpenGL context" in out, out
    assert "passed" not in out and "skipped" not in out, out


def test_required_truth_without_its_backend_fails_the_session():
    rc, out = _pytest(env={"RELIGHT_REQUIRE_TRUTH": "1"}, code=NO_LLVM)
    assert rc != 0, out
    assert "RELIGHT_REQUIRE_TRUTH=1 but the path tracer cannot run: no libLLVM >= 19" in out, out


def test_without_the_requirement_a_missing_backend_only_skips():
    """On a workstation (no RELIGHT_REQUIRE_TRUTH) the same missing backend stops nothing: the
    path-traced checks skip on their own (the mitsuba_llvm fixture), the rest runs."""
    rc, out = _pytest(code=NO_LLVM)
    assert rc == 0 and "5 passed" in out, out
