"""`relight parity` on other float paths of this machine, so a tolerance that only the default
path meets is caught here and not on a user's GPU.

Each path is a different code generator on both sides: llvmpipe limited to SSE4.1 (no AVX, no FMA,
4-wide vectors: other instruction selection, other approximations of exp2/log2/atan) or to SSE2 at
128 bits, and torch's ``default`` (no SIMD) or AVX2 kernels instead of the widest the CPU has. The
shader disk cache is off so nothing compiled for another path is reused.

Left out on these paths: ``model:neural_teacher``. Its GLSL is the network code that
``neural:network`` and ``model:neural`` check here on both paths plus ggx_mc's sampling that
``model:ggx_mc`` checks; evaluating the teacher per light sample per pixel is the slowest check by far
(about a third of the whole run on llvmpipe) and would put the two runs past their time limit on a
2-core machine. The default path runs it (test_library_parity, `relight parity`).

Left out too: the ``ubo`` weight storage (``neural:network:ubo``, ``model:neural:ubo``). Its code
is the const storage's unrolled FMA chains with each literal vector replaced by a read of the same
float32 vector from a uniform block (viewer/neural/glsl.py), so its arithmetic, the part a float
path changes, is checked here by ``neural:network`` and ``model:neural``; what is particular to it
(the block's layout and upload) does not depend on the code generator and the default path checks
it. llvmpipe's 128-bit SSE4.1 backend takes about 90 s to compile the kernel's storage-block reads
alone (0.25 s for the same network with constants).

Left out too: ``forward:blend``. Its six variants compile the same shading sources
(passes/shade_*.frag through passes/forward_surface.glsl) that the ``model:*`` checks compile
as lighting passes here on both paths, and what the forward pass adds (the depth test, the sort
and the blend over) is exact arithmetic; it took about 35 s of CPU on the SSE4.1 path, the most
of any check there, half of it the twin's torch code in its no-SIMD mode. The default path runs
it.

The two paths share the pass checks: each runs every library function and every other pass check
(in the registry's order), so every pass check runs on one of them and the pair costs the time of
one whole run (the suite's budget, 10 minutes on two cores, has no room for two).

Not used: ``GALLIUM_OVERRIDE_CPU_CAPS=nosse``, where LLVM falls back to x87 arithmetic with 80-bit
intermediates. That path is not a conforming GLSL implementation (a * b + c is no longer rounded
per operation; GLSL 4.x requires + - * correctly rounded in float32), and it shows: the `precise`
splat_view_depth differs there by 1 ulp.
"""
import json
import os
import subprocess
import sys

import pytest

PATHS = {
    "llvmpipe-sse4.1-128bit+torch-default": {"GALLIUM_OVERRIDE_CPU_CAPS": "sse4.1",
                                             "LP_NATIVE_VECTOR_WIDTH": "128",
                                             "ATEN_CPU_CAPABILITY": "default"},
    "llvmpipe-sse2+torch-avx2": {"GALLIUM_OVERRIDE_CPU_CAPS": "sse2",
                                 "ATEN_CPU_CAPABILITY": "avx2"},
}


# the checks these paths leave out (module doc)
LEFT_OUT = ("model:neural_teacher", "neural:network:ubo", "model:neural:ubo", "forward:blend")


def skipped(path: str) -> list[str]:
    """``--skip`` arguments for ``path``: :data:`LEFT_OUT` and the other path's half of the
    pass checks (module doc)."""
    from learned.parity import pass_checks

    names = [n for n in pass_checks() if n not in LEFT_OUT]
    mine = set(names[list(PATHS).index(path)::len(PATHS)])
    return [a for n in (*LEFT_OUT, *(n for n in names if n not in mine)) for a in ("--skip", n)]


@pytest.fixture(scope="module")
def runs():
    """Both paths at once (one process per core), each `relight parity --json` on its share."""
    procs = {}
    for name, extra in PATHS.items():
        # one thread each for torch and llvmpipe's rasterizer: the two run side by side, one per
        # core (beside the suite's workers), and threads beyond the cores only wait and spin.
        # Neither count changes a code generator (what a path is); measured alone, cold, CPU:
        # SSE4.1 half 71.6 -> 50.3 s, SSE2 half 72.8 -> 47.3 s
        env = {**os.environ, **extra, "MESA_SHADER_CACHE_DISABLE": "true",
               "OMP_NUM_THREADS": "1", "LP_NUM_THREADS": "1"}
        procs[name] = subprocess.Popen([sys.executable, "-m", "relight", "parity", "--json",
                                        *skipped(name)],
                                       env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                                       text=True)
    out = {}
    for name, proc in procs.items():
        stdout, stderr = proc.communicate(timeout=1200)
        out[name] = (proc.returncode, stdout, stderr)
    return out


@pytest.mark.slow
@pytest.mark.parametrize("path", list(PATHS))
def test_parity_holds_on_another_float_path(runs, path):
    code, stdout, stderr = runs[path]
    assert stdout.strip(), f"{path}: no output (exit {code}): {stderr[-2000:]}"
    results = json.loads(stdout)
    failed = [f"{r['name']}: max abs {r['max_abs']:.3g}, max rel {r['max_rel']:.3g}, "
              f"{r['tolerance']}" for r in results if not r["passed"]]
    assert not failed, f"{path}: " + "; ".join(failed)
    assert code == 0, stderr[-2000:]
    assert len(results) > 100  # every function and its half of the passes, not fewer


def test_the_alternative_paths_are_really_different():
    """The override must reach llvmpipe: its renderer string names the vector width."""
    # no shader disk cache, as for the runs: nothing compiled on another path is stored
    env = {**os.environ, **PATHS["llvmpipe-sse4.1-128bit+torch-default"],
           "MESA_SHADER_CACHE_DISABLE": "true"}
    info = subprocess.run([sys.executable, "-m", "relight", "info"], env=env, capture_output=True,
                          text=True, timeout=120)
    if "llvmpipe" not in info.stdout:
        pytest.skip("not llvmpipe: these paths are llvmpipe's")
    assert "128 bits" in info.stdout, info.stdout
