"""Evaluate one GLSL library function on arrays of inputs, for parity tests and ``relight parity``.

For ``float d_ggx(float NoH, float a)`` in ``lib/brdf.glsl``, :func:`evaluate` generates a compute
shader that reads each argument from a std430 float buffer, calls the function once per element and
writes the result back, so torch twins can be compared with what the GPU computes on the same inputs.
"""
from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from shaders import SHADER_ROOT

from ..errors import ShaderCompileError
from .context import make_current

COMPONENTS = {"float": 1, "vec2": 2, "vec3": 3, "vec4": 4, "int": 1, "uint": 1}
_SIGNATURE = re.compile(
    r"^(float|vec[234]|int|uint)\s+([A-Za-z_]\w*)\s*\(([^)]*)\)\s*\{", re.MULTILINE)


@dataclass(frozen=True)
class Signature:
    file: str  # relative to shaders/, e.g. "lib/brdf.glsl"
    name: str
    returns: str
    params: tuple[tuple[str, str], ...]  # (type, name)


def _parse_params(text: str) -> tuple[tuple[str, str], ...] | None:
    params = []
    for raw in filter(None, (p.strip() for p in text.split(","))):
        words = raw.split()
        if words[0] in ("in", "const"):
            words = words[1:]
        if len(words) != 2 or words[0] not in COMPONENTS:
            return None  # samplers, out/inout, structs: tested at pass level
        params.append((words[0], words[1]))
    return tuple(params)


def library_functions(lib_dir: Path | None = None) -> dict[str, Signature]:
    """Every function in ``shaders/lib/*.glsl`` whose arguments and result are scalars or vectors."""
    lib_dir = lib_dir or SHADER_ROOT / "lib"
    found: dict[str, Signature] = {}
    for path in sorted(lib_dir.glob("*.glsl")):
        text = path.read_text()
        for m in _SIGNATURE.finditer(text):
            params = _parse_params(m.group(3))
            if params is None:
                continue
            found[m.group(2)] = Signature(f"lib/{path.name}", m.group(2), m.group(1), params)
    return found


def all_library_function_names(lib_dir: Path | None = None) -> dict[str, str]:
    """Name -> file of *every* function defined in ``shaders/lib`` (including sampler ones)."""
    lib_dir = lib_dir or SHADER_ROOT / "lib"
    any_sig = re.compile(r"^\s*(?:[A-Za-z_]\w*)\s+([A-Za-z_]\w*)\s*\([^;{]*\)\s*\{", re.MULTILINE)
    names: dict[str, str] = {}
    for path in sorted(lib_dir.glob("*.glsl")):
        for m in any_sig.finditer(path.read_text()):
            if m.group(1) not in ("if", "for", "while", "switch", "return"):
                names[m.group(1)] = f"lib/{path.name}"
    return names


def _kernel_source(sig: Signature) -> str:
    lines = [f'#include "{sig.file}"', "layout(local_size_x = 64) in;", "uniform uint u_count;"]
    for i, (typ, _) in enumerate(sig.params):
        lines.append(f"layout(std430, binding = {i}) readonly buffer In{i} {{ float in{i}[]; }};")
    out_binding = len(sig.params)
    lines.append(f"layout(std430, binding = {out_binding}) writeonly buffer Out {{ float outv[]; }};")
    lines.append("void main() {")
    lines.append("    uint i = gl_GlobalInvocationID.x;")
    lines.append("    if (i >= u_count) return;")
    args = []
    for i, (typ, _) in enumerate(sig.params):
        n = COMPONENTS[typ]
        comps = ", ".join(f"in{i}[{n}u * i + {c}u]" for c in range(n))
        ctor = {"int": "int", "uint": "uint"}.get(typ, typ)
        lines.append(f"    {typ} a{i} = {ctor}({comps});")
        args.append(f"a{i}")
    n_out = COMPONENTS[sig.returns]
    lines.append(f"    {sig.returns} r = {sig.name}({', '.join(args)});")
    if n_out == 1:
        lines.append("    outv[i] = float(r);")
    else:
        for c in range(n_out):
            lines.append(f"    outv[{n_out}u * i + {c}u] = r[{c}];")
    lines.append("}")
    return "\n".join(lines) + "\n"


def evaluate(programs, name: str, *args: np.ndarray, signatures: dict | None = None) -> np.ndarray:
    """Run GLSL library function ``name`` on the GPU (see :func:`_evaluate`), with the programs'
    context current (another context may be current in the same process)."""
    make_current(programs.ctx)
    return _evaluate(programs, name, *args, signatures=signatures)


def _evaluate(programs, name: str, *args: np.ndarray, signatures: dict | None = None) -> np.ndarray:
    """Run GLSL library function ``name`` on the GPU for every element of ``args``.

    Each argument is an array ``[N]`` (scalars) or ``[N, k]`` (vecK); the result is ``[N]`` or
    ``[N, k]`` float32. Integer arguments are passed as floats and converted in the shader.
    """
    sigs = signatures or library_functions()
    if name not in sigs:
        raise ShaderCompileError(f"no GLSL library function {name!r} with scalar/vector arguments",
                                 where="shaders/lib")
    sig = sigs[name]
    if len(args) != len(sig.params):
        raise ValueError(f"{name} takes {len(sig.params)} arguments, got {len(args)}")
    ctx = programs.ctx
    count = None
    buffers = []
    for (typ, pname), arr in zip(sig.params, args):
        arr = np.asarray(arr, dtype=np.float32)
        n = COMPONENTS[typ]
        arr = arr.reshape(-1, n)
        if count is None:
            count = arr.shape[0]
        elif arr.shape[0] != count:
            raise ValueError(f"{name}: argument {pname} has {arr.shape[0]} rows, expected {count}")
        buffers.append(ctx.buffer(np.ascontiguousarray(arr).tobytes()))
    if not sig.params:
        count = 1  # a constant function: evaluate once
    count = count or 0
    n_out = COMPONENTS[sig.returns]
    out = ctx.buffer(reserve=max(4, 4 * n_out * count))
    prog = programs.compute(f"<kernel:{name}>", virtual={f"<kernel:{name}>": _kernel_source(sig)})
    try:
        for i, buf in enumerate(buffers):
            buf.bind_to_storage_buffer(i)
        out.bind_to_storage_buffer(len(buffers))
        prog["u_count"].value = count
        prog.run(group_x=max(1, (count + 63) // 64))
        # shader-storage writes are incoherent: without the barrier the read-back may see the
        # buffer before the dispatch lands (env_row_sin_theta failed 1 run in 6 with a stale
        # 1.5e-4; none in 12 runs with it)
        ctx.memory_barrier()
        result = np.frombuffer(out.read(), dtype=np.float32)[: n_out * count].copy()
    finally:
        for buf in buffers:
            buf.release()
        out.release()
    return result if n_out == 1 else result.reshape(count, n_out)


def run_kernel(programs, entry: str, inputs, out_width: int, setup=None, *,
               virtual: dict | None = None, defines: dict | None = None,
               group: int = 64, count: int | None = None) -> np.ndarray:
    """Dispatch a compute kernel over the rows of float32 ``inputs`` and read its output back.

    The kernel's protocol (every kernel under ``shaders/passes`` written for it follows it):
    ``uniform uint u_count`` rows; the inputs as std430 float buffer binding 0 (one ``[n, k]``
    array, or a list of arrays bound to 0, 1, ...) and the output, ``[n, out_width]`` float32, as
    the binding after the last input; ``local_size_x = group``. ``setup(program)`` binds whatever
    else the kernel reads (textures, uniforms). ``entry`` is a file under ``shaders/`` or a name in
    ``virtual`` (generated source); ``defines`` select its variant. ``count`` overrides the row
    count for kernels that read planar inputs (``[k, n]``, one plane per component); the result is
    then the output buffer's first ``count * out_width`` floats in whatever order the kernel wrote.
    """
    make_current(programs.ctx)
    ctx = programs.ctx
    arrays = inputs if isinstance(inputs, (list, tuple)) else [inputs]
    arrays = [np.ascontiguousarray(a, dtype=np.float32) for a in arrays]
    count = arrays[0].shape[0] if count is None else int(count)
    prog = programs.compute(entry, defines=defines, virtual=virtual)
    buffers = [ctx.buffer(a.tobytes() if a.size else b"\0\0\0\0") for a in arrays]
    out = ctx.buffer(reserve=max(4, 4 * out_width * count))
    try:
        if setup is not None:
            setup(prog)
        for i, buf in enumerate(buffers):
            buf.bind_to_storage_buffer(i)
        out.bind_to_storage_buffer(len(buffers))
        prog["u_count"].value = count
        prog.run(group_x=max(1, (count + group - 1) // group))
        ctx.memory_barrier()
        result = np.frombuffer(out.read(), dtype=np.float32)[: out_width * count].copy()
    finally:
        for buf in buffers:
            buf.release()
        out.release()
    return result.reshape(count, out_width)
