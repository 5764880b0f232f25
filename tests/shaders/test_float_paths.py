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

Left out as well: ``forward:blend`` and ``shadow_net`` (together about a fifth of a path's run).
The forward pass shades transparent surfaces with the lighting functions ``model:ggx_split_sum``
and ``model:blinn_phong`` check here, its blending is fixed-function; the shadow estimator's
whole network is the layers ``shadow_net:layers`` checks here one by one, chained. The default
path runs both.

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
SKIPPED = ("--skip", "model:neural_teacher", "--skip", "neural:network:ubo",
           "--skip", "model:neural:ubo", "--skip", "forward:blend", "--skip", "shadow_net")


@pytest.fixture(scope="module")
def runs():
    """Both paths at once (one process per core), each the whole `relight parity --json`."""
    procs = {}
    for name, extra in PATHS.items():
        env = {**os.environ, **extra, "MESA_SHADER_CACHE_DISABLE": "true"}
        procs[name] = subprocess.Popen([sys.executable, "-m", "relight", "parity", "--json",
                                        *SKIPPED],
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
    assert len(results) > 100  # every function and pass, not a subset


def test_the_alternative_paths_are_really_different():
    """The override must reach llvmpipe: its renderer string names the vector width."""
    env = {**os.environ, **PATHS["llvmpipe-sse4.1-128bit+torch-default"]}
    info = subprocess.run([sys.executable, "-m", "relight", "info"], env=env, capture_output=True,
                          text=True, timeout=120)
    if "llvmpipe" not in info.stdout:
        pytest.skip("not llvmpipe: these paths are llvmpipe's")
    assert "128 bits" in info.stdout, info.stdout
