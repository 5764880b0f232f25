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
layer sizes. Never edit generated GLSL by hand; re-export the weights.

Where the generated code reads its weights is the *storage* (:data:`WEIGHT_STORAGES`,
``[render] neural_storage``; :meth:`Network.code` gives the code of each):

=========== ========================================================================================
storage     weights live in
=========== ========================================================================================
const       the code: literal constants in fully unrolled FMA chains (:func:`_dense`); the default
ubo         a buffer of vec4 weight vectors: a std140 uniform block when it fits the 16 KiB every
            GL 4.3 driver allows (:data:`UBO_MIN_MAX_BYTES`), otherwise a read-only std430
            shader-storage block (:attr:`NetworkCode.binding` says which)
texture     an RGBA32F texture read with ``texelFetch``, one texel per vec4
=========== ========================================================================================

The buffered storages use the same unrolled chains with the literal vectors replaced by reads at
constant indices; their code depends on the architecture only (zero weights are read too), so a
new file of the same shape only uploads new data. :class:`NeuralWeights` uploads and binds the data.
Measured (``relight.bench.neural.weight_storage_rows``, README "Neural shader"): ``const`` is the
fastest on llvmpipe, which is why it is the default.
"""
from __future__ import annotations

import hashlib
import json
import os
from dataclasses import dataclass, field
from dataclasses import replace as _replace
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
WEIGHT_STORAGES = ("const", "ubo", "texture")  # where generated code reads weights (module doc)
UBO_MIN_MAX_BYTES = 16384  # GL 4.3's minimum GL_MAX_UNIFORM_BLOCK_SIZE: larger blocks become SSBOs
WEIGHT_TEXTURE_WIDTH = 256  # texels per row of the "texture" storage (vec4 i at (i % W, i / W))
# buffer binding points of the weight blocks (uniform and storage blocks alike; the splat and
# kernel buffers use 0-5)
WEIGHT_BINDINGS = {"student": 6, "teacher": 7, "mlp": 6}


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
    _code: dict = field(default_factory=dict, repr=False, compare=False)  # storage -> NetworkCode

    @property
    def include_name(self) -> str:
        return f"generated/neural_{self.kind}.glsl"

    @property
    def glsl(self) -> str:
        """The text of the virtual file ``include_name`` with weights baked as constants."""
        return self.code("const").glsl

    def code(self, storage: str = "const") -> NetworkCode:
        """The generated GLSL and weight data for ``storage`` (:data:`WEIGHT_STORAGES`; cached)."""
        if storage not in WEIGHT_STORAGES:
            raise ValueError(f"weight storage {storage!r} (known: {', '.join(WEIGHT_STORAGES)})")
        if storage not in self._code:
            self._code[storage] = generate_glsl(self, storage)
        return self._code[storage]

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
                  training=training, tensors=tensors)
    net.code("const")  # generation errors belong to loading
    return net


# ---- GLSL generation -----------------------------------------------------------------------------

def _f(x: float) -> str:
    """A float32 as a GLSL literal that round-trips exactly."""
    s = f"{float(np.float32(x)):.9g}"
    return s if any(c in s for c in ".en") else s + ".0"


@dataclass(frozen=True)
class NetworkCode:
    """Generated GLSL of one weight storage and the data it reads.

    ``binding``: ``"const"`` (no data), ``"ubo"`` (std140 uniform block), ``"ssbo"`` (read-only
    std430 storage block; ``ubo`` storage above :data:`UBO_MIN_MAX_BYTES`) or ``"texture"``;
    ``data`` ``[N, 4]`` float32 vec4 weight vectors (``None`` for ``const``); ``symbol`` the
    block / uniform name; ``point`` the buffer binding point (:data:`WEIGHT_BINDINGS`)."""

    glsl: str
    storage: str
    binding: str
    data: np.ndarray | None  # [N, 4] float32
    symbol: str = ""
    point: int = 0

    def describe(self) -> str:
        if self.data is None:
            return "baked constants"
        size = f"{len(self.data)} vec4, {self.data.nbytes} bytes"
        return {"ubo": f"std140 uniform block ({size})",
                "ssbo": f"std430 storage buffer ({size} > {UBO_MIN_MAX_BYTES // 1024} KiB UBO)",
                "texture": f"RGBA32F texture + texelFetch ({size})"}[self.binding]


class _Source:
    """Where :func:`_dense` reads a weight vector: a literal (``const``) or the next vec4 of the
    weight data at a constant index (``ubo``, ``texture``; collected in :attr:`rows`)."""

    def __init__(self, storage: str, kind: str):
        self.storage = storage
        self.macro = f"NEURAL_{kind.upper()}_W"
        self.rows: list[np.ndarray] = []

    def vec(self, values: np.ndarray) -> str:
        """GLSL ``float``/``vecK`` expression of ``values`` ``[K]``, K <= 4."""
        k = len(values)
        if self.storage == "const":
            return f"{'float' if k == 1 else f'vec{k}'}({', '.join(_f(v) for v in values)})"
        row = np.zeros(4, np.float32)
        row[:k] = values
        self.rows.append(row)
        read = f"{self.macro}({len(self.rows) - 1})"
        return read if k == 4 else f"{read}.{'xyzw'[:k]}"

    def skip(self, column: np.ndarray) -> bool:
        """Baked code skips all-zero columns; buffered code reads them (its code is shared by
        every file of the same architecture).

        Buffered reads stay unrolled: loops over blocks and input vec4s (tried) are unrolled again
        by Mesa's compiler and ran 1.3x slower. Either way llvmpipe compiles storage-block reads
        slowly: the first dispatch of the 32-64-64-1 probe (1,633 reads, an SSBO) took 136 s with
        a cold shader cache (uniform block at 433 reads: 2 s; texture at 1,633: 1 s)."""
        return self.storage == "const" and not column.any()

    def finish(self, kind: str) -> tuple[list[str], NetworkCode]:
        """Declarations to put before the code, and the storage's :class:`NetworkCode` (its
        ``glsl`` left empty for the caller)."""
        if self.storage == "const":
            return [], NetworkCode("", "const", "const", None)
        data = np.stack(self.rows) if self.rows else np.zeros((1, 4), np.float32)
        n, point = len(data), WEIGHT_BINDINGS[kind]
        name = f"neural_{kind}_w"
        if self.storage == "texture":
            sym = f"u_{name}"
            lines = [f"uniform sampler2D {sym};  // RGBA32F, {WEIGHT_TEXTURE_WIDTH} texels a row",
                     f"#define {self.macro}(i) texelFetch({sym}, ivec2((i) % "
                     f"{WEIGHT_TEXTURE_WIDTH}, (i) / {WEIGHT_TEXTURE_WIDTH}), 0)"]
            return lines, NetworkCode("", "texture", "texture", data, sym, 0)
        block = "".join(w.capitalize() for w in name.split("_"))
        if data.nbytes <= UBO_MIN_MAX_BYTES:
            lines = [f"layout(std140, binding = {point}) uniform {block} {{ vec4 {name}[{n}]; }};"]
            binding = "ubo"
        else:  # over the minimum every driver allows: a storage block of the same vec4 array
            lines = [f"layout(std430, binding = {point}) readonly buffer {block} "
                     f"{{ vec4 {name}[{n}]; }};"]
            binding = "ssbo"
        lines.append(f"#define {self.macro}(i) {name}[i]")
        return lines, NetworkCode("", "ubo", binding, data, block, point)


def _dense(prefix: str, weight: np.ndarray, bias: np.ndarray, act: str, inputs: list[str],
           source: _Source) -> tuple[list[str], list[str]]:
    """One fully connected layer over ``inputs`` (vec4 variable names, zero-padded); returns the
    code lines and the names of the vec4 outputs (the last one padded with act(0)). ``source``
    writes each weight vector (bias, then one column per input component) as a literal or a read.

    Column form: every output block is a chain ``y += vec4(W[:, j]) * x_j`` over the input
    components (the zero padding of ``inputs`` costs nothing; with baked constants, neither do
    zero columns), and a last block of fewer than 4 outputs is accumulated as a vec2/vec3.
    Measured on llvmpipe (8-32-32-6, 262,144 inputs): 65 GFLOP/s against 62 for
    ``act(b + mat4(...) * x_0 + ...)`` blocks, 61 for per-output dot products and 61 for
    ``x * mat4``: the unrolled constants make every form a chain of broadcast-constant FMAs, so the
    form matters little; the zero columns and rows skipped are what is saved.
    """
    out_n, in_n = weight.shape
    lines, outs = [], []
    for o in range(0, out_n, 4):
        k = min(4, out_n - o)
        vec = "float" if k == 1 else f"vec{k}"
        var = f"{prefix}_{o // 4}"
        acc = var if k == 4 else f"{var}_acc"
        lines.append(f"    {vec} {acc} = {source.vec(bias[o:o + k])};")
        for j in range(in_n):
            col = weight[o:o + k, j]
            if not source.skip(col):
                lines.append(f"    {acc} += {source.vec(col)} * {inputs[j // 4]}.{'xyzw'[j % 4]};")
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


def _mlp(layers, prefix: str, inputs: list[str], source: _Source) -> tuple[list[str], list[str]]:
    """The layers ``[(weight [out, in], bias [out], activation)]`` over vec4 ``inputs``."""
    lines = []
    for i, (w, b, act) in enumerate(layers):
        more, inputs = _dense(f"{prefix}{i}", w, b, act, inputs, source)
        lines += more
    return lines, inputs


def _header(net: Network, code: NetworkCode) -> list[str]:
    nets = "; ".join(f"{n} {'-'.join(str(s) for s in spec['sizes'])} "
                     f"({', '.join(spec['activations'])})"
                     for n, spec in net.architecture["networks"].items())
    return [f"// {net.include_name} - GENERATED by viewer/neural.py from {Path(net.path).name};",
            "// do not edit: re-export the weights (learned/export.py) instead.",
            f"// checkpoint sha256:{net.checkpoint}",
            f"// kind {net.kind}; layers: {nets}; Fourier frequencies: {net.num_freqs}",
            f"// parameters {net.parameter_count()}, multiply-adds per evaluation {net.macs()}",
            f"// weight storage {code.storage}: {code.describe()}",
            '#include "lib/neural.glsl"']


def generate_glsl(net: Network, storage: str = "const") -> NetworkCode:
    """The GLSL evaluation of ``net`` reading its weights from ``storage`` (module docstring)."""
    source = _Source(storage, net.kind)
    lines = []
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
        mlp_lines, y = _mlp(net.layers("mlp"), "m", x, source)
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
        d_lines, feat = _mlp(net.layers("diffuse"), "d", x, source)
        lines += enc_lines + pack_lines + d_lines
        lines += ["    vec3 h = half_vector(v, l);",
                  "    vec4 vh_0 = vec4(v, h.x);", "    vec4 vh_1 = vec4(h.yz, 0.0, 0.0);"]
        hidden = int(net.architecture["hidden"])
        # the specular input is [feat (hidden), v, h]: feat fills whole vec4s when hidden % 4 == 0
        if hidden % 4:
            raise WeightsError(f"teacher hidden width {hidden} must be a multiple of 4",
                               where=net.path)
        s_lines, rgb = _mlp(net.layers("specular"), "s", feat + ["vh_0", "vh_1"], source)
        lines += s_lines + [f"    return {rgb[0]}.rgb * lin;", "}"]
    declarations, code = source.finish(net.kind)
    text = _header(net, code) + declarations + lines
    return _replace(code, glsl="\n".join(text) + "\n")


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


def mlp_kernel(layers, storage: str = "const") -> NetworkCode:
    """A compute kernel evaluating a bare MLP ``[(weight [out, in], bias [out], activation)]``
    (no encoding) with weights from ``storage``: the weight-storage probe of
    ``relight.bench.neural.weight_storage_rows``. Layout and bindings as :data:`STUDENT_KERNEL`
    (inputs ``inv[k * u_count + i]``, outputs ``outv[k * u_count + i]``, buffers 0 and 1)."""
    source = _Source(storage, "mlp")
    in_n, out_n = layers[0][0].shape[1], layers[-1][0].shape[0]
    raw = [f"inv[{k}u * n + i]" for k in range(in_n)]
    pack_lines, x = _pack("x", raw)
    mlp_lines, y = _mlp(layers, "m", x, source)
    declarations, code = source.finish("mlp")
    sizes = "-".join(str(w.shape[1]) for w, _, _ in layers) + f"-{out_n}"
    text = [f"// MLP {sizes} kernel - GENERATED by viewer/neural.py (weight storage {storage}: "
            f"{code.describe()})", '#include "lib/neural.glsl"', *declarations,
            f"layout(local_size_x = {STUDENT_KERNEL_GROUP}) in;", "uniform uint u_count;",
            "layout(std430, binding = 0) readonly buffer In { float inv[]; };",
            "layout(std430, binding = 1) writeonly buffer Out { float outv[]; };",
            "void main() {", "    uint i = gl_GlobalInvocationID.x;", "    uint n = u_count;",
            "    if (i >= n) return;", *pack_lines, *mlp_lines,
            *[f"    outv[{k}u * n + i] = {y[k // 4]}.{'xyzw'[k % 4]};" for k in range(out_n)], "}"]
    return _replace(code, glsl="\n".join(text) + "\n")


class NeuralWeights:
    """The GL side of one :class:`NetworkCode`: uploads its weight data once (a buffer for
    ``ubo``/``ssbo``, an RGBA32F texture for ``texture``, nothing for ``const``);
    :meth:`bind` before every draw or dispatch of a program built from ``code.glsl``."""

    def __init__(self, ctx, code: NetworkCode):
        self.code = code
        self._buffer = self._texture = None
        if code.binding in ("ubo", "ssbo"):
            self._buffer = ctx.buffer(np.ascontiguousarray(code.data, "<f4").tobytes())
        elif code.binding == "texture":
            w = WEIGHT_TEXTURE_WIDTH
            rows = -(-len(code.data) // w)
            texels = np.zeros((rows * w, 4), np.float32)
            texels[:len(code.data)] = code.data
            self._texture = ctx.texture((w, rows), 4, texels.tobytes(), dtype="f4")
            self._texture.filter = (ctx.NEAREST, ctx.NEAREST)
            self._texture.repeat_x = self._texture.repeat_y = False

    def bind(self, prog, unit: int) -> int:
        """Bind the data for ``prog``; returns the next free texture unit."""
        if self.code.binding == "ubo":
            self._buffer.bind_to_uniform_block(self.code.point)
        elif self.code.binding == "ssbo":
            self._buffer.bind_to_storage_buffer(self.code.point)
        elif self.code.binding == "texture" and self.code.symbol in prog:
            self._texture.use(unit)
            prog[self.code.symbol].value = unit
            return unit + 1
        return unit

    def release(self) -> None:
        for r in (self._buffer, self._texture):
            if r is not None:
                r.release()
        self._buffer = self._texture = None


def default_weights(kind: str) -> Path:
    """The weights shipped in ``assets/weights`` for ``kind``."""
    from assets import ASSET_ROOT

    return ASSET_ROOT / "weights" / f"neural_{kind}.safetensors"


def model_network(model: str, settings) -> tuple[Network, NetworkCode] | None:
    """The network of a lighting pass of ``model`` under the render ``settings`` (its weights file
    and ``neural_storage``) and its generated code; ``None`` for classical models."""
    kind = MODEL_KINDS.get(model)
    if kind is None:
        return None
    attr = "weights" if kind == "student" else "teacher_weights"
    path = getattr(settings, attr, None) or default_weights(kind)
    net = load_network(path, kind)
    return net, net.code(getattr(settings, "neural_storage", "const"))


def virtual_files(model: str, settings) -> dict[str, str]:
    """Generated include files a lighting pass of ``model`` needs (empty for classical models)."""
    found = model_network(model, settings)
    if found is None:
        return {}
    net, code = found
    return {net.include_name: code.glsl}
