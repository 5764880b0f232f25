"""GLSL generation for exported networks: the virtual include ``generated/neural_<kind>.glsl``.

:func:`generate_glsl` writes the evaluation of a validated network (:class:`NetworkFile`) as
GLSL: a header naming the source file, the checkpoint hash and the layer sizes, then
``neural_student_weights`` or ``neural_teacher_contribution`` built from ``lib/neural.glsl``.
Never edit generated GLSL by hand; re-export the weights.

Where the generated code reads its weights is the *storage* (:data:`WEIGHT_STORAGES`,
``[render] neural_storage``; ``Network.code`` gives the code of each):

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
new file of the same shape only uploads new data (:class:`viewer.neural.NeuralWeights`).
Measured (``relight.bench.neural.weight_storage_rows``, README "Neural shader"): ``const`` is the
fastest on llvmpipe, which is why it is the default.
"""
from __future__ import annotations

from dataclasses import dataclass
from dataclasses import replace as _replace
from pathlib import Path

import numpy as np

from .format import STUDENT_FEATURES, NetworkFile, WeightsError, teacher_inputs

WEIGHT_STORAGES = ("const", "ubo", "texture")  # where generated code reads weights (module doc)
UBO_MIN_MAX_BYTES = 16384  # GL 4.3's minimum GL_MAX_UNIFORM_BLOCK_SIZE: larger blocks become SSBOs
WEIGHT_TEXTURE_WIDTH = 256  # texels per row of the "texture" storage (vec4 i at (i % W, i / W))
# buffer binding points of the weight blocks (uniform and storage blocks alike; the splat and
# kernel buffers use 0-5)
WEIGHT_BINDINGS = {"student": 6, "teacher": 7, "mlp": 6}
# architecture activation -> lib/neural.glsl function
_ACTIVATIONS = {"relu": "relu4", "sigmoid": "sigmoid4", "softplus": "softplus4"}

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


def _header(net: NetworkFile, code: NetworkCode) -> list[str]:
    nets = "; ".join(f"{n} {'-'.join(str(s) for s in spec['sizes'])} "
                     f"({', '.join(spec['activations'])})"
                     for n, spec in net.architecture["networks"].items())
    return [f"// {net.include_name} - GENERATED by viewer/neural/glsl.py from "
            f"{Path(net.path).name};",
            "// do not edit: re-export the weights (learned/export.py) instead.",
            f"// checkpoint sha256:{net.checkpoint}",
            f"// kind {net.kind}; layers: {nets}; Fourier frequencies: {net.num_freqs}",
            f"// parameters {net.parameter_count()}, multiply-adds per evaluation {net.macs()}",
            f"// weight storage {code.storage}: {code.describe()}",
            '#include "lib/neural.glsl"']


def generate_glsl(net: NetworkFile, storage: str = "const") -> NetworkCode:
    """The GLSL evaluation of ``net`` reading its weights from ``storage`` (module docstring)."""
    source = _Source(storage, net.kind)
    lines = []
    if net.kind == "student":
        inputs = STUDENT_FEATURES[net.features]
        dfg = "dfg.a" in inputs
        vis = "vis" in inputs
        pbr = net.output in ("pbr3", "split3")  # three achromatic factors
        split = net.output == "split3"
        indirect = net.indirect != "none"  # a 2nd network: the factor on the indirect light
        lines += [f"#define NEURAL_STUDENT_DFG {int(dfg)}  // 1: the network reads the DFG LUT",
                  f"#define NEURAL_STUDENT_VIS {int(vis)}  // 1: it reads the environment's "
                  "screen-space visibility",
                  f"#define NEURAL_STUDENT_ENV {int('env_below' in inputs)}  // 1: it reads "
                  "u_env_below",
                  f"#define NEURAL_STUDENT_PBR {int(pbr)}  // output form: 0 free6, 1 pbr3 "
                  "or split3",
                  f"#define NEURAL_STUDENT_SPLIT {int(split)}  // 1: split3, corrections of "
                  "the split-sum model",
                  f"#define NEURAL_STUDENT_INDIRECT {int(indirect)}  // 1: k_1.x is the factor "
                  "on the indirect light",
                  f"#define NEURAL_STUDENT_SUN {int(net.sun)}  // 1: the split3 base shades "
                  "the environment's sun analytically (SUN_LIGHT)",
                  f"#define NEURAL_STUDENT_MULTISCATTER {int(net.multiscatter)}  // 1: the "
                  "split3 base has ggx_split_sum's multiple-scattering compensation",
                  "",
                  "// k [0, 1]^6 (free6: k_0 = k_diffuse rgb, k_1 = k_specular rgb) or [0, 1]^3",
                  "// (pbr3: k_0 = (k_d, k_a, k_b), k_1 = 0; with NEURAL_STUDENT_INDIRECT k_1.x is",
                  "// the indirect light's k, lib/neural.glsl neural_indirect_factor): the factors that",
                  "// neural_student_radiance[_pbr] (lib/neural.glsl) combine with the lighting;",
                  "// dfg: split-sum LUT at (NoV, roughness), read only when NEURAL_STUDENT_DFG;",
                  "// vis: S(x) of passes/ssao.frag (SSAO_ENV_VIS), read only when NEURAL_STUDENT_VIS;",
                  "// env_below: the environment's light from below over above (u_env_below),",
                  "// read only when NEURAL_STUDENT_ENV.",
                  "// twin: learned.neural.student.Student.weights",
                  "void neural_student_weights(vec3 albedo, float roughness, float metallic,",
                  "                            float specular, float ao, float NoV, vec2 dfg,",
                  "                            float vis, float env_below, out vec3 k_0,",
                  "                            out vec3 k_1) {"]
        glsl_names = {"dfg.a": "dfg.x", "dfg.b": "dfg.y"}
        raw = [glsl_names.get(name, name) for name in inputs]
        enc_lines, enc = _encode(raw, net.num_freqs)
        pack_lines, x = _pack("x", enc)
        mlp_lines, y = _mlp(net.layers("mlp"), "m", x, source)
        lines += enc_lines + pack_lines + mlp_lines
        if pbr and indirect:  # the "indirect" network on the same inputs
            ind_lines, yi = _mlp(net.layers("indirect"), "i", x, source)
            lines += ind_lines
            lines += [f"    k_0 = {y[0]}.xyz;", f"    k_1 = vec3({yi[0]}.x, 0.0, 0.0);"]
        elif pbr:
            lines += [f"    k_0 = {y[0]}.xyz;", "    k_1 = vec3(0.0);"]
        else:
            lines += [f"    k_0 = {y[0]}.xyz;", f"    k_1 = vec3({y[0]}.w, {y[1]}.xy);"]
        if net.occlusion == "factor":  # occlusion "factor": AO scales the diffuse factor(s)
            lines += ["    k_0.x *= ao;" if pbr else "    k_0 *= ao;"]
        lines += ["}"]
    else:
        light = net.light_input  # log(1 + L_in) among the inputs (architecture "light_input")
        lines += ["",
                  "// rho * L_in of one light sample (learned.neural.teacher.Teacher.contribution)"
                  + ("" if light else ";"),
                  *([] if light else ["// light_input false: rho sees no radiance, so the "
                                      "contribution is linear in li"]),
                  "vec3 neural_teacher_contribution(vec3 albedo, vec3 n, float roughness,",
                  "                                 float metallic, float specular, vec3 v, vec3 l,",
                  "                                 vec3 li) {",
                  "    float NoL = dot(n, l);",
                  "    vec3 lin = li * max(NoL, 0.0);"]
        if light:
            lines.append("    vec3 log_lin = log(1.0 + lin);")
        glsl_names = {"log_Lin.r": "log_lin.r", "log_Lin.g": "log_lin.g", "log_Lin.b": "log_lin.b"}
        raw = [glsl_names.get(name, name) for name in teacher_inputs(light)]
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
