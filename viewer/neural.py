"""Exported neural shaders: torch-free loading, validation and GLSL generation.

A weights file is a safetensors file written by :func:`learned.export.export` with float32 tensors
``<network>.<layer>.weight`` ``[out, in]`` / ``.bias`` ``[out]`` and string metadata:

=============== ====================================================================================
key             value
=============== ====================================================================================
format          ``relight-neural-shader``
version         ``1`` (:data:`FORMAT_VERSION`)
kind            ``student`` (model ``neural``) or ``teacher`` (model ``neural_teacher``)
architecture    JSON: ``{"networks": {name: {"sizes": [...], "activations": [...]}}, "num_freqs": L,
                "inputs": [...], "features": "base" | "dfg", "output": "free6" | "pbr3"}``
                (students; no ``features`` = ``base``: the 8 inputs of :data:`STUDENT_INPUTS`,
                ``dfg`` adds the split-sum LUT; no ``output`` = ``free6``: six per-channel
                factors, ``pbr3`` three achromatic ones of the split-sum form,
                :data:`STUDENT_OUTPUTS`)
encoding        JSON: ``{"type": "fourier", "num_freqs": L, "frequencies": "pi * 2^k"}``
checkpoint      sha256 (hex) of the tensors (:func:`checkpoint_hash`); verified on load
training        JSON summary of the training data and run (free form)
=============== ====================================================================================

:func:`load_network` reads it with ``safetensors.numpy`` (no torch), checks all of the above and
generates the GLSL evaluation (:attr:`Network.glsl`): a virtual include file
``generated/neural_<kind>.glsl`` whose header names the source file, the checkpoint hash and the
layer sizes. Weights are baked into the code as constants (fully unrolled FMA chains, see
:func:`_dense`): on llvmpipe a 32-64-64-1 probe ran ~15 GFLOP/s that way against ~3 with a uniform
block and ~1.2 with texelFetch. Never edit generated GLSL by hand; re-export the weights.
"""
from __future__ import annotations

import hashlib
import json
import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .errors import InputError

FORMAT = "relight-neural-shader"
FORMAT_VERSION = "1"
STUDENT_INPUTS = ("albedo.r", "albedo.g", "albedo.b", "roughness", "metallic", "specular", "ao",
                  "NoV")
# student input sets (architecture "features"; twin: learned.neural.student.FEATURE_INPUTS)
STUDENT_FEATURES = {"base": STUDENT_INPUTS, "dfg": STUDENT_INPUTS + ("dfg.a", "dfg.b")}
# student output forms (architecture "output"; twin: learned.neural.student.OUTPUTS) -> network
# outputs. The generated GLSL defines NEURAL_STUDENT_PBR (0 free6, 1 pbr3); shade_neural.frag
# combines the factors with the lighting by lib/neural.glsl's neural_student_radiance[_pbr].
STUDENT_OUTPUTS = {"free6": 6, "pbr3": 3}
TEACHER_INPUTS = ("albedo.r", "albedo.g", "albedo.b", "n.x", "n.y", "n.z", "roughness", "metallic",
                  "specular", "l.x", "l.y", "l.z", "NoL", "log_Lin.r", "log_Lin.g", "log_Lin.b")
# kind -> network name -> (input size given L, output size, activations of hidden/last layers)
_ACTIVATIONS = {"relu": "relu4", "sigmoid": "sigmoid4", "softplus": "softplus4"}
MODEL_KINDS = {"neural": "student", "neural_teacher": "teacher"}


class WeightsError(InputError):
    """A weights file that cannot be used: unreadable, truncated, another format, version or
    architecture, or tensors that do not match the metadata."""


@dataclass(frozen=True)
class Network:
    """A validated exported network (numpy, float32) and its generated GLSL."""

    path: str
    kind: str  # "student" | "teacher"
    checkpoint: str  # sha256 hex of the tensors
    architecture: dict
    training: dict
    tensors: dict  # name -> np.ndarray float32
    glsl: str  # the text of the virtual file ``include_name``

    @property
    def include_name(self) -> str:
        return f"generated/neural_{self.kind}.glsl"

    @property
    def num_freqs(self) -> int:
        return int(self.architecture["num_freqs"])

    @property
    def features(self) -> str:
        """Student input set (``base`` | ``dfg``, :data:`STUDENT_FEATURES`)."""
        return str(self.architecture.get("features", "base"))

    @property
    def output(self) -> str:
        """Student output form (``free6`` | ``pbr3``, :data:`STUDENT_OUTPUTS`)."""
        return str(self.architecture.get("output", "free6"))

    def layers(self, network: str) -> list[tuple[np.ndarray, np.ndarray, str]]:
        spec = self.architecture["networks"][network]
        return [(self.tensors[f"{network}.{i}.weight"], self.tensors[f"{network}.{i}.bias"], act)
                for i, act in enumerate(spec["activations"])]

    def parameter_count(self) -> int:
        return int(sum(t.size for t in self.tensors.values()))

    def macs(self) -> int:
        """Multiply-adds of one evaluation (per pixel for a student, per light sample for a teacher)."""
        return int(sum(t.size for n, t in self.tensors.items() if n.endswith(".weight")))


def checkpoint_hash(tensors: dict) -> str:
    """sha256 over (name, shape, little-endian float32 bytes) of every tensor, names sorted."""
    h = hashlib.sha256()
    for name in sorted(tensors):
        arr = np.ascontiguousarray(tensors[name], dtype="<f4")
        h.update(name.encode())
        h.update(json.dumps(list(arr.shape)).encode())
        h.update(arr.tobytes())
    return h.hexdigest()


def expected_networks(kind: str, num_freqs: int, hidden, features: str = "base",
                      output: str = "free6") -> dict[str, dict]:
    """The architecture every file of ``kind`` must have (sizes from its hidden widths and, for a
    student, its input ``features`` and ``output`` form)."""
    enc = lambda d: d * (1 + 2 * num_freqs)  # noqa: E731
    if kind == "student":
        sizes = [enc(len(STUDENT_FEATURES[features])), *[int(h) for h in hidden],
                 STUDENT_OUTPUTS[output]]
        return {"mlp": {"sizes": sizes,
                        "activations": ["relu"] * (len(sizes) - 2) + ["sigmoid"]}}
    if kind == "teacher":
        h = int(hidden)
        return {"diffuse": {"sizes": [enc(len(TEACHER_INPUTS)), h, h],
                            "activations": ["relu", "relu"]},
                "specular": {"sizes": [h + 6, h, 3], "activations": ["relu", "softplus"]}}
    raise ValueError(kind)


_CACHE: dict[tuple, Network] = {}


def load_network(path: str | os.PathLike, kind: str | None = None) -> Network:
    """Read, validate and generate GLSL for the weights file ``path`` (cached by path, size and
    modification time). ``kind`` (``"student"``/``"teacher"``) is required to match when given.
    Every problem is a one-line :class:`WeightsError` naming the file."""
    path = Path(path)
    if not path.is_file():
        raise WeightsError("weights file not found", where=path)
    st = path.stat()
    key = (str(path.resolve()), st.st_size, st.st_mtime_ns)
    net = _CACHE.get(key)
    if net is None:
        net = _CACHE[key] = _load(path)
    if kind is not None and net.kind != kind:
        raise WeightsError(f"holds a {net.kind} network, expected a {kind} "
                           f"(model {'neural' if kind == 'student' else 'neural_teacher'})",
                           where=path)
    return net


def _load(path: Path) -> Network:
    from safetensors import SafetensorError, safe_open

    try:
        with safe_open(str(path), framework="numpy") as f:
            meta = dict(f.metadata() or {})
            tensors = {k: f.get_tensor(k) for k in f.keys()}
    except (SafetensorError, OSError, ValueError, MemoryError) as exc:
        raise WeightsError(f"not a readable safetensors file (truncated or corrupt: "
                           f"{str(exc).splitlines()[0] if str(exc) else type(exc).__name__})",
                           where=path) from None
    if meta.get("format") != FORMAT:
        raise WeightsError(f"not a relight neural-shader file (metadata format "
                           f"{meta.get('format')!r}, expected {FORMAT!r})", where=path)
    if meta.get("version") != FORMAT_VERSION:
        raise WeightsError(f"format version {meta.get('version')!r} is not supported (this "
                           f"viewer reads version {FORMAT_VERSION})", where=path)
    kind = meta.get("kind")
    if kind not in ("student", "teacher"):
        raise WeightsError(f"unknown network kind {kind!r} (student | teacher)", where=path)
    try:
        arch = json.loads(meta["architecture"])
        training = json.loads(meta.get("training", "{}"))
        num_freqs = int(arch["num_freqs"])
        hidden = arch["hidden"]
        if not 0 <= num_freqs <= 16:
            raise ValueError(f"num_freqs {num_freqs}")
        features = arch.get("features", "base") if kind == "student" else "base"
        if features not in STUDENT_FEATURES:
            raise ValueError(f"student features {features!r} (known: "
                             f"{', '.join(STUDENT_FEATURES)})")
        if kind == "student" and "inputs" in arch and \
                tuple(arch["inputs"]) != STUDENT_FEATURES[features]:
            raise ValueError(f"inputs {arch['inputs']} are not the {features!r} student inputs")
        output = arch.get("output", "free6") if kind == "student" else "free6"
        if output not in STUDENT_OUTPUTS:
            raise ValueError(f"student output form {output!r} (known: "
                             f"{', '.join(STUDENT_OUTPUTS)})")
        want = expected_networks(kind, num_freqs, hidden, features, output)
    except (KeyError, ValueError, TypeError) as exc:
        raise WeightsError(f"bad architecture metadata ({type(exc).__name__}: {exc})",
                           where=path) from None
    if arch.get("networks") != want:
        raise WeightsError(f"architecture {json.dumps(arch.get('networks'))} is not the {kind} "
                           f"architecture this viewer generates GLSL for "
                           f"({json.dumps(want)})", where=path)
    names = set()
    for net, spec in want.items():
        sizes = spec["sizes"]
        for i in range(len(sizes) - 1):
            for suffix, shape in (("weight", (sizes[i + 1], sizes[i])), ("bias", (sizes[i + 1],))):
                name = f"{net}.{i}.{suffix}"
                names.add(name)
                t = tensors.get(name)
                if t is None:
                    raise WeightsError(f"missing tensor {name!r}", where=path)
                if t.dtype != np.float32 or tuple(t.shape) != shape:
                    raise WeightsError(f"tensor {name!r} is {t.dtype}{list(t.shape)}, expected "
                                       f"float32{list(shape)}", where=path)
                if not np.isfinite(t).all():
                    raise WeightsError(f"tensor {name!r} has NaN/Inf values", where=path)
    extra = sorted(set(tensors) - names)
    if extra:
        raise WeightsError(f"unexpected tensors {', '.join(extra)}", where=path)
    digest = checkpoint_hash(tensors)
    if meta.get("checkpoint") != digest:
        raise WeightsError(f"checkpoint hash mismatch (metadata {str(meta.get('checkpoint'))[:12]}, "
                           f"tensors {digest[:12]}): the file was modified or damaged", where=path)
    net = Network(path=str(path), kind=kind, checkpoint=digest, architecture=arch,
                  training=training, tensors=tensors, glsl="")
    object.__setattr__(net, "glsl", generate_glsl(net))
    return net


# ---- GLSL generation -----------------------------------------------------------------------------

def _f(x: float) -> str:
    """A float32 as a GLSL literal that round-trips exactly."""
    s = f"{float(np.float32(x)):.9g}"
    return s if any(c in s for c in ".en") else s + ".0"


def _dense(prefix: str, weight: np.ndarray, bias: np.ndarray, act: str, inputs: list[str]
           ) -> tuple[list[str], list[str]]:
    """One fully connected layer over ``inputs`` (vec4 variable names, zero-padded); returns the
    code lines and the names of the vec4 outputs (the last one padded with act(0)).

    Column form: every output block is a chain ``y += vec4(W[:, j]) * x_j`` over the input
    components whose weight column is non-zero (zero padding costs nothing), and a last block of
    fewer than 4 outputs is accumulated as a vec2/vec3. Measured on llvmpipe (8-32-32-6,
    262,144 inputs): 65 GFLOP/s against 62 for ``act(b + mat4(...) * x_0 + ...)`` blocks, 61 for
    per-output dot products and 61 for ``x * mat4``: the unrolled constants make every form a
    chain of broadcast-constant FMAs, so the form matters little; the zero columns and rows skipped
    are what is saved.
    """
    out_n, in_n = weight.shape
    w = np.zeros((out_n, 4 * len(inputs)), np.float32)
    w[:, :in_n] = weight
    lines, outs = [], []
    for o in range(0, out_n, 4):
        k = min(4, out_n - o)
        vec = "float" if k == 1 else f"vec{k}"
        var = f"{prefix}_{o // 4}"
        acc = var if k == 4 else f"{var}_acc"
        lines.append(f"    {vec} {acc} = {vec}({', '.join(_f(v) for v in bias[o:o + k])});")
        for j, name in enumerate(inputs):
            for c in range(4):
                col = w[o:o + k, 4 * j + c]
                if col.any():
                    lines.append(f"    {acc} += {vec}({', '.join(_f(v) for v in col)}) * "
                                 f"{name}.{'xyzw'[c]};")
        if k == 4:
            lines.append(f"    {var} = {_ACTIVATIONS[act]}({var});")
        else:
            pad = ", ".join(["0.0"] * (4 - k))
            lines.append(f"    vec4 {var} = {_ACTIVATIONS[act]}(vec4({acc}, {pad}));")
        outs.append(var)
    return lines, outs


def _pack(prefix: str, scalars: list[str]) -> tuple[list[str], list[str]]:
    """Pack scalar expressions into vec4 variables (zero-padded)."""
    lines, names = [], []
    for i in range(0, len(scalars), 4):
        part = scalars[i:i + 4] + ["0.0"] * (4 - len(scalars[i:i + 4]))
        names.append(f"{prefix}_{i // 4}")
        lines.append(f"    vec4 {names[-1]} = vec4({', '.join(part)});")
    return lines, names


def _encode(raw: list[str], num_freqs: int) -> tuple[list[str], list[str]]:
    """Fourier encoding of scalar expressions ``raw`` (order of learned/neural/encoding.py)."""
    lines, out = [], []
    for i, e in enumerate(raw):
        lines.append(f"    float r{i} = {e};")
        out.append(f"r{i}")
        for k in range(num_freqs):
            lines.append(f"    vec2 e{i}_{k} = fourier_feature(r{i}, {_f(np.pi * 2.0 ** k)});")
            out += [f"e{i}_{k}.x", f"e{i}_{k}.y"]
    return lines, out


def _mlp(net: Network, name: str, inputs: list[str]) -> tuple[list[str], list[str]]:
    lines = []
    for i, (w, b, act) in enumerate(net.layers(name)):
        more, inputs = _dense(f"{name[0]}{i}", w, b, act, inputs)
        lines += more
    return lines, inputs


def _header(net: Network) -> list[str]:
    nets = "; ".join(f"{n} {'-'.join(str(s) for s in spec['sizes'])} "
                     f"({', '.join(spec['activations'])})"
                     for n, spec in net.architecture["networks"].items())
    return [f"// {net.include_name} - GENERATED by viewer/neural.py from {Path(net.path).name};",
            "// do not edit: re-export the weights (learned/export.py) instead.",
            f"// checkpoint sha256:{net.checkpoint}",
            f"// kind {net.kind}; layers: {nets}; Fourier frequencies: {net.num_freqs}",
            f"// parameters {net.parameter_count()}, multiply-adds per evaluation {net.macs()}",
            '#include "lib/neural.glsl"']


def generate_glsl(net: Network) -> str:
    """The GLSL evaluation of ``net`` (see the module docstring)."""
    lines = _header(net)
    if net.kind == "student":
        dfg = net.features == "dfg"
        pbr = net.output == "pbr3"
        lines += [f"#define NEURAL_STUDENT_DFG {int(dfg)}  // 1: the network reads the DFG LUT",
                  f"#define NEURAL_STUDENT_PBR {int(pbr)}  // output form: 0 free6, 1 pbr3",
                  "",
                  "// k [0, 1]^6 (free6: k_0 = k_diffuse rgb, k_1 = k_specular rgb) or [0, 1]^3",
                  "// (pbr3: k_0 = (k_d, k_a, k_b), k_1 = 0): the factors that",
                  "// neural_student_radiance[_pbr] (lib/neural.glsl) combine with the lighting;",
                  "// dfg: split-sum LUT at (NoV, roughness), read only when NEURAL_STUDENT_DFG.",
                  "// twin: learned.neural.student.Student.weights",
                  "void neural_student_weights(vec3 albedo, float roughness, float metallic,",
                  "                            float specular, float ao, float NoV, vec2 dfg,",
                  "                            out vec3 k_0, out vec3 k_1) {"]
        raw = ["albedo.r", "albedo.g", "albedo.b", "roughness", "metallic", "specular", "ao", "NoV"]
        raw += ["dfg.x", "dfg.y"] if dfg else []
        enc_lines, enc = _encode(raw, net.num_freqs)
        pack_lines, x = _pack("x", enc)
        mlp_lines, y = _mlp(net, "mlp", x)
        lines += enc_lines + pack_lines + mlp_lines
        if pbr:
            lines += [f"    k_0 = {y[0]}.xyz;", "    k_1 = vec3(0.0);", "}"]
        else:
            lines += [f"    k_0 = {y[0]}.xyz;", f"    k_1 = vec3({y[0]}.w, {y[1]}.xy);", "}"]
    else:
        lines += ["",
                  "// rho * L_in of one light sample (learned.neural.teacher.Teacher.contribution)",
                  "vec3 neural_teacher_contribution(vec3 albedo, vec3 n, float roughness,",
                  "                                 float metallic, float specular, vec3 v, vec3 l,",
                  "                                 vec3 li) {",
                  "    float NoL = dot(n, l);",
                  "    vec3 lin = li * max(NoL, 0.0);",
                  "    vec3 log_lin = log(1.0 + lin);"]
        raw = ["albedo.r", "albedo.g", "albedo.b", "n.x", "n.y", "n.z", "roughness", "metallic",
               "specular", "l.x", "l.y", "l.z", "NoL", "log_lin.r", "log_lin.g", "log_lin.b"]
        enc_lines, enc = _encode(raw, net.num_freqs)
        pack_lines, x = _pack("x", enc)
        d_lines, feat = _mlp(net, "diffuse", x)
        lines += enc_lines + pack_lines + d_lines
        lines += ["    vec3 h = neural_half_vector(v, l);",
                  "    vec4 vh_0 = vec4(v, h.x);", "    vec4 vh_1 = vec4(h.yz, 0.0, 0.0);"]
        hidden = int(net.architecture["hidden"])
        # the specular input is [feat (hidden), v, h]: feat fills whole vec4s when hidden % 4 == 0
        if hidden % 4:
            raise WeightsError(f"teacher hidden width {hidden} must be a multiple of 4",
                               where=net.path)
        s_lines, rgb = _mlp(net, "specular", feat + ["vh_0", "vh_1"])
        lines += s_lines + [f"    return {rgb[0]}.rgb * lin;", "}"]
    return "\n".join(lines) + "\n"


# Compute kernel evaluating the generated ``neural_student_weights`` on a batch (parity checks and
# the throughput bench). Planar layout: input k of item i at ``inv[k * u_count + i]`` (k < 10,
# the ``dfg`` input order; base students ignore k = 8, 9), output k at ``outv[k * u_count + i]``
# (k < 6; a pbr3 student writes 3, then zeros): neighbouring invocations read neighbouring
# floats. Interleaved items (``inv[10 i + k]``)
# with 64 invocations per group took 4.4 ms for 65,536 items of the 8-32-32-6 student on llvmpipe
# with the previous ``mat4`` code, this layout with 256 per group and the column form 3.0 ms.
STUDENT_KERNEL_GROUP = 256
STUDENT_KERNEL = """
#include "lib/common.glsl"
#include "generated/neural_student.glsl"
layout(local_size_x = 256) in;
uniform uint u_count;
layout(std430, binding = 0) readonly buffer In { float inv[]; };    // [10][n]
layout(std430, binding = 1) writeonly buffer Out { float outv[]; };  // [6][n]
void main() {
    uint i = gl_GlobalInvocationID.x;
    uint n = u_count;
    if (i >= n) return;
    vec3 k0;
    vec3 k1;
    neural_student_weights(vec3(inv[i], inv[n + i], inv[2u * n + i]), inv[3u * n + i],
                           inv[4u * n + i], inv[5u * n + i], inv[6u * n + i], inv[7u * n + i],
                           vec2(inv[8u * n + i], inv[9u * n + i]), k0, k1);
    outv[i] = k0.x;
    outv[n + i] = k0.y;
    outv[2u * n + i] = k0.z;
    outv[3u * n + i] = k1.x;
    outv[4u * n + i] = k1.y;
    outv[5u * n + i] = k1.z;
}
"""


def default_weights(kind: str) -> Path:
    """The weights shipped in ``assets/weights`` for ``kind``."""
    from assets import ASSET_ROOT

    return ASSET_ROOT / "weights" / f"neural_{kind}.safetensors"


def virtual_files(model: str, settings) -> dict[str, str]:
    """Generated include files a lighting pass of ``model`` needs (empty for classical models)."""
    kind = MODEL_KINDS.get(model)
    if kind is None:
        return {}
    attr = "weights" if kind == "student" else "teacher_weights"
    path = getattr(settings, attr, None) or default_weights(kind)
    net = load_network(path, kind)
    return {net.include_name: net.glsl}
