"""The neural-shader weights file: its format, its input/output contract and its validation.

The one definition of the file, for reading (:func:`read_weights`, the viewer) and for writing
(:func:`architecture`, :func:`metadata`, :func:`tensor_name`; ``learned.export``). A weights file
is a safetensors file with float32 tensors ``<network>.<layer>.weight`` ``[out, in]`` / ``.bias``
``[out]`` (:func:`tensor_name`) and string metadata (:func:`metadata`):

=============== ====================================================================================
key             value
=============== ====================================================================================
format          ``relight-neural-shader``
version         ``1`` (:data:`FORMAT_VERSION`)
kind            ``student`` (model ``neural``) or ``teacher`` (model ``neural_teacher``)
architecture    JSON (:func:`architecture`): ``{"networks": {name: {"sizes": [...], "activations":
                [...]}}, "hidden": ..., "num_freqs": L, "inputs": [...], "features": "base" | "dfg" | "vis" | "dfg-vis",
                "output": "free6" | "pbr3"}`` (students; no ``features`` = ``base``: the 8 inputs of
                :data:`STUDENT_INPUTS`, ``dfg`` adds the split-sum LUT, ``vis`` the screen-space visibility of the environment's
                light (the renderer then runs SSAO with ``SSAO_ENV_VIS``); no ``output`` = ``free6``:
                six per-channel factors, ``pbr3`` three achromatic ones of the split-sum form,
                :data:`STUDENT_OUTPUTS`; ``"occlusion": "input" | "factor"``, no key = ``input``:
                ``factor`` multiplies the diffuse factor(s) by the ``ao`` input, as every classical
                model applies AO, :data:`STUDENT_OCCLUSION`); ``"indirect": "none" | "factor"``, no
                key = ``none``: ``factor`` adds a second network ``indirect`` (same inputs ->
                :data:`INDIRECT_HIDDEN` -> 1, sigmoid), a learned factor 2 k on the screen-space
                indirect light (the renderer then runs the indirect pass and the lighting pass
                writes the factor for it, :data:`STUDENT_INDIRECT`); ``"sun": true | false``, no
                key = false (``split3`` only): the student's split-sum base is the IBL without the
                environment's compact sun plus that sun as an analytic light, as ``ggx_split_sum``
                shades it (``SUN_LIGHT``, viewer/sun.py), the sun's light with the same learned
                corrections (``lib/neural.glsl`` ``neural_student_sun_split``);
                ``"multiscatter": true | false``, no key = false (``split3`` only): the base is
                ``ggx_split_sum`` with its multiple-scattering compensation (``ibl_energy_
                compensation``), as the classical model renders by default; teachers:
                ``"light_input": true | false``, no key = true: false drops the log(1 + L_in)
                inputs (:func:`teacher_inputs`), so rho cannot depend on the light and the teacher
                is exactly linear in it
encoding        JSON (:func:`encoding`): ``{"type": "fourier", "num_freqs": L, "frequencies":
                "pi * 2^k", "order": ...}``
checkpoint      sha256 (hex) of the tensors (:func:`checkpoint_hash`); verified on load
training        JSON summary of the training data and run (free form)
=============== ====================================================================================

:func:`read_weights` reads it with ``safetensors`` (numpy, no torch) and checks all of the above;
every problem is a one-line :class:`WeightsError` naming the file.
"""
from __future__ import annotations

import hashlib
import json
import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from safetensors import SafetensorError, safe_open

from assets import ASSET_ROOT

from ..errors import InputError

FORMAT = "relight-neural-shader"
FORMAT_VERSION = "1"
KINDS = ("student", "teacher")
MODEL_KINDS = {"neural": "student", "neural_teacher": "teacher"}  # model -> network kind
STUDENT_INPUTS = ("albedo.r", "albedo.g", "albedo.b", "roughness", "metallic", "specular", "ao",
                  "NoV")
# every student input, in the order of the generated code's arguments and of the parity kernel's
# planar rows; "vis" is the screen-space visibility of the environment's light (the g channel of
# passes/ssao.frag with SSAO_ENV_VIS), read by students that see visibility
STUDENT_ALL_INPUTS = STUDENT_INPUTS + ("dfg.a", "dfg.b", "vis")
# student input sets (architecture "features"; twin: learned.neural.student.FEATURE_INPUTS), each
# a subsequence of STUDENT_ALL_INPUTS
STUDENT_FEATURES = {"base": STUDENT_INPUTS, "dfg": STUDENT_INPUTS + ("dfg.a", "dfg.b"),
                    "vis": STUDENT_INPUTS + ("vis",),
                    "dfg-vis": STUDENT_ALL_INPUTS}
# student output forms (architecture "output"; twin: learned.neural.student.OUTPUTS) -> network
# outputs. The generated GLSL defines NEURAL_STUDENT_PBR (0 free6, 1 pbr3); shade_neural.frag
# combines the factors with the lighting by lib/neural.glsl's neural_student_radiance[_pbr].
STUDENT_OUTPUTS = {"free6": 6, "pbr3": 3, "split3": 3}
# what a student file without "features" / "output" (written before they existed) holds
DEFAULT_FEATURES = "base"
DEFAULT_OUTPUT = "free6"
# how a student uses its ao input (architecture "occlusion"): "input" only as an MLP input (files
# written before the key existed: the network had to learn the product, and learned the training
# set's mean occlusion instead, issue 14), "factor" also multiplies the diffuse factor(s) by it
STUDENT_OCCLUSION = ("input", "factor")
DEFAULT_OCCLUSION = "input"
# whether a student learns a factor on the screen-space indirect light (architecture "indirect";
# twin: learned.neural.student.INDIRECTS): "factor" = a second network "indirect" on the same
# inputs, INDIRECT_HIDDEN relu units -> one sigmoid output k, L = L_dir + 2 k L_ind
# (passes/ssao.frag), k = 0.5 the classical one-bounce term; files without the key (written
# before) have none. A separate network measured better than a 4th output of the student's own
# (README "Against truth": paired over 3 seeds, +0.08 dB on a held-out environment, +0.17 on
# held-out scene kinds)
STUDENT_INDIRECT = ("none", "factor")
DEFAULT_INDIRECT = "none"
INDIRECT_HIDDEN = 16  # hidden width of the "indirect" network (twin: learned.neural.student)
# whether a split3 student's base shades the environment's sun analytically (architecture "sun";
# twin: learned.neural.student.Student(sun=)): true = the base is ggx_split_sum with SUN_LIGHT (the
# IBL without the sun + the sun as a light, both with the student's corrections); files without
# the key (written before) are false, the split-sum of the whole environment
DEFAULT_SUN = False
# whether a split3 student's base has ggx_split_sum's multiple-scattering compensation
# (architecture "multiscatter"; NEURAL_STUDENT_MULTISCATTER); files without the key: single scattering
DEFAULT_MULTISCATTER = False
TEACHER_INPUTS = ("albedo.r", "albedo.g", "albedo.b", "n.x", "n.y", "n.z", "roughness", "metallic",
                  "specular", "l.x", "l.y", "l.z", "NoL", "log_Lin.r", "log_Lin.g", "log_Lin.b")
# whether a teacher sees the light's radiance log(1 + L_i(l) <n.l>) (architecture "light_input";
# twin: learned.neural.teacher.Teacher(light_input=)): true = the thesis's inputs (eq. 4.2; files
# written before the key existed), false = the first 13 only, rho independent of the light
DEFAULT_LIGHT_INPUT = True


def teacher_inputs(light_input: bool = DEFAULT_LIGHT_INPUT) -> tuple[str, ...]:
    """The teacher's inputs in order: :data:`TEACHER_INPUTS`, without the three log(1 + L_in)
    ones when ``light_input`` is false."""
    return TEACHER_INPUTS if light_input else TEACHER_INPUTS[:-3]

TENSOR_PARTS = ("weight", "bias")  # the tensors of one layer, in file order per layer


class WeightsError(InputError):
    """A weights file that cannot be used: unreadable, truncated, another format, version or
    architecture, or tensors that do not match the metadata."""


@dataclass(frozen=True)
class NetworkFile:
    """The validated contents of a weights file (numpy, float32); :class:`viewer.neural.Network`
    adds its generated GLSL."""

    path: str
    kind: str  # "student" | "teacher"
    checkpoint: str  # sha256 hex of the tensors
    architecture: dict
    training: dict
    tensors: dict  # name -> np.ndarray float32

    @property
    def include_name(self) -> str:
        """The virtual include file of its generated GLSL."""
        return f"generated/neural_{self.kind}.glsl"

    @property
    def num_freqs(self) -> int:
        return int(self.architecture["num_freqs"])

    @property
    def features(self) -> str:
        """Student input set (``base`` | ``dfg`` | ``vis`` | ``dfg-vis``, :data:`STUDENT_FEATURES`)."""
        return str(self.architecture.get("features", DEFAULT_FEATURES))

    @property
    def output(self) -> str:
        """Student output form (``free6`` | ``pbr3``, :data:`STUDENT_OUTPUTS`)."""
        return str(self.architecture.get("output", DEFAULT_OUTPUT))

    @property
    def indirect(self) -> str:
        """Whether the student learns a factor on the indirect light (``none`` | ``factor``,
        :data:`STUDENT_INDIRECT`)."""
        return str(self.architecture.get("indirect", DEFAULT_INDIRECT))

    @property
    def sun(self) -> bool:
        """Whether the student's split-sum base shades the environment's sun analytically
        (architecture ``"sun"``, :data:`DEFAULT_SUN` without the key)."""
        return bool(self.architecture.get("sun", DEFAULT_SUN))

    @property
    def multiscatter(self) -> bool:
        """Whether the student's split-sum base has the multiple-scattering compensation
        (architecture ``"multiscatter"``, :data:`DEFAULT_MULTISCATTER` without the key)."""
        return bool(self.architecture.get("multiscatter", DEFAULT_MULTISCATTER))

    @property
    def light_input(self) -> bool:
        """Whether the teacher sees the light's radiance log(1 + L_in) (architecture
        ``"light_input"``, :data:`DEFAULT_LIGHT_INPUT` without the key)."""
        return bool(self.architecture.get("light_input", DEFAULT_LIGHT_INPUT))

    @property
    def occlusion(self) -> str:
        """How the student applies its ao input (``input`` | ``factor``,
        :data:`STUDENT_OCCLUSION`)."""
        return str(self.architecture.get("occlusion", DEFAULT_OCCLUSION))

    def layers(self, network: str) -> list[tuple[np.ndarray, np.ndarray, str]]:
        """``[(weight [out, in], bias [out], activation)]`` of ``network``."""
        spec = self.architecture["networks"][network]
        return [(self.tensors[tensor_name(network, i, "weight")],
                 self.tensors[tensor_name(network, i, "bias")], act)
                for i, act in enumerate(spec["activations"])]

    def parameter_count(self) -> int:
        return int(sum(t.size for t in self.tensors.values()))

    def macs(self) -> int:
        """Multiply-adds of one evaluation (per pixel for a student, per light sample for a
        teacher)."""
        return int(sum(t.size for n, t in self.tensors.items() if n.endswith(".weight")))


def tensor_name(network: str, layer: int, part: str) -> str:
    """The key of a tensor: ``<network>.<layer>.<part>``, ``part`` in :data:`TENSOR_PARTS`."""
    return f"{network}.{layer}.{part}"


def checkpoint_hash(tensors: dict) -> str:
    """sha256 over (name, shape, little-endian float32 bytes) of every tensor, names sorted."""
    h = hashlib.sha256()
    for name in sorted(tensors):
        arr = np.ascontiguousarray(tensors[name], dtype="<f4")
        h.update(name.encode())
        h.update(json.dumps(list(arr.shape)).encode())
        h.update(arr.tobytes())
    return h.hexdigest()


def expected_networks(kind: str, num_freqs: int, hidden, features: str = DEFAULT_FEATURES,
                      output: str = DEFAULT_OUTPUT, indirect: str = DEFAULT_INDIRECT,
                      light_input: bool = DEFAULT_LIGHT_INPUT) -> dict[str, dict]:
    """The architecture every file of ``kind`` must have (sizes from its hidden widths and, for a
    student, its input ``features``, ``output`` form and ``indirect`` factor; for a teacher,
    whether it sees the light, ``light_input``)."""
    enc = lambda d: d * (1 + 2 * num_freqs)  # noqa: E731
    if kind == "student":
        n_in = enc(len(STUDENT_FEATURES[features]))
        sizes = [n_in, *[int(h) for h in hidden], STUDENT_OUTPUTS[output]]
        nets = {"mlp": {"sizes": sizes,
                        "activations": ["relu"] * (len(sizes) - 2) + ["sigmoid"]}}
        if indirect == "factor":
            nets["indirect"] = {"sizes": [n_in, INDIRECT_HIDDEN, 1],
                                "activations": ["relu", "sigmoid"]}
        return nets
    if kind == "teacher":
        h = int(hidden)
        return {"diffuse": {"sizes": [enc(len(teacher_inputs(light_input))), h, h],
                            "activations": ["relu", "relu"]},
                "specular": {"sizes": [h + 6, h, 3], "activations": ["relu", "softplus"]}}
    raise ValueError(kind)


def architecture(kind: str, num_freqs: int, hidden, features: str | None = None,
                 output: str | None = None, occlusion: str | None = None,
                 indirect: str | None = None, sun: bool = False, multiscatter: bool = False,
                 light_input: bool = DEFAULT_LIGHT_INPUT) -> dict:
    """The ``architecture`` metadata of a ``kind`` network (students record ``features``,
    ``output`` and ``occlusion``, ``None`` for :data:`DEFAULT_FEATURES` / :data:`DEFAULT_OUTPUT` /
    :data:`DEFAULT_OCCLUSION`, ``indirect`` when it is not ``none``, ``sun`` and ``multiscatter``
    when true, so
    files of students without them stay as they were written before they existed; teachers
    record ``light_input`` only when it is false, for the same reason)."""
    features = features or DEFAULT_FEATURES
    output = output or DEFAULT_OUTPUT
    indirect = indirect or DEFAULT_INDIRECT
    light_input = bool(light_input) if kind == "teacher" else DEFAULT_LIGHT_INPUT
    arch = {"networks": expected_networks(kind, num_freqs, hidden, features, output, indirect,
                                          light_input),
            "hidden": hidden, "num_freqs": num_freqs,
            "inputs": list(STUDENT_FEATURES[features] if kind == "student"
                           else teacher_inputs(light_input))}
    if kind == "student":
        arch["features"] = features
        arch["output"] = output
        arch["occlusion"] = occlusion or DEFAULT_OCCLUSION
        if indirect != DEFAULT_INDIRECT:
            arch["indirect"] = indirect
        if sun:
            arch["sun"] = True
        if multiscatter:
            arch["multiscatter"] = True
    elif not light_input:
        arch["light_input"] = False
    return arch


def encoding(num_freqs: int) -> dict:
    """The ``encoding`` metadata: the Fourier features of ``learned/neural/encoding.py``."""
    return {"type": "fourier", "num_freqs": num_freqs, "frequencies": "pi * 2^k",
            "order": "x, (sin, cos) per k"}


def metadata(kind: str, arch: dict, tensors: dict, training: dict | None = None) -> dict[str, str]:
    """The string metadata of a file holding ``tensors`` of a ``kind`` network with the
    architecture ``arch`` (:func:`architecture`)."""
    return {"format": FORMAT, "version": FORMAT_VERSION, "kind": kind,
            "architecture": json.dumps(arch),
            "encoding": json.dumps(encoding(arch["num_freqs"])),
            "checkpoint": checkpoint_hash(tensors),
            "training": json.dumps(training or {})}


def _required_networks(kind: str, arch: dict) -> dict[str, dict]:
    """The networks ``arch`` must describe; raises KeyError/ValueError/TypeError when it is
    malformed."""
    num_freqs = int(arch["num_freqs"])
    hidden = arch["hidden"]
    if not 0 <= num_freqs <= 16:
        raise ValueError(f"num_freqs {num_freqs}")
    features = arch.get("features", DEFAULT_FEATURES) if kind == "student" else DEFAULT_FEATURES
    if features not in STUDENT_FEATURES:
        raise ValueError(f"student features {features!r} (known: {', '.join(STUDENT_FEATURES)})")
    if kind == "student" and "inputs" in arch and \
            tuple(arch["inputs"]) != STUDENT_FEATURES[features]:
        raise ValueError(f"inputs {arch['inputs']} are not the {features!r} student inputs")
    output = arch.get("output", DEFAULT_OUTPUT) if kind == "student" else DEFAULT_OUTPUT
    if output not in STUDENT_OUTPUTS:
        raise ValueError(f"student output form {output!r} (known: {', '.join(STUDENT_OUTPUTS)})")
    if kind == "student" and arch.get("occlusion", DEFAULT_OCCLUSION) not in STUDENT_OCCLUSION:
        raise ValueError(f"student occlusion {arch['occlusion']!r} "
                         f"(known: {', '.join(STUDENT_OCCLUSION)})")
    indirect = arch.get("indirect", DEFAULT_INDIRECT) if kind == "student" else DEFAULT_INDIRECT
    if indirect not in STUDENT_INDIRECT:
        raise ValueError(f"student indirect {indirect!r} (known: {', '.join(STUDENT_INDIRECT)})")
    if indirect != DEFAULT_INDIRECT and STUDENT_OUTPUTS[output] != 3:
        raise ValueError(f"student indirect {indirect!r} needs a three-factor output form "
                         f"(pbr3 or split3), not {output!r}")
    for key, default in (("sun", DEFAULT_SUN), ("multiscatter", DEFAULT_MULTISCATTER)):
        # the split3 base's switches: booleans, only for that output form
        value = arch.get(key, default) if kind == "student" else default
        if not isinstance(value, bool):
            raise ValueError(f"student {key} {value!r} (true | false)")
        if value and output != "split3":
            raise ValueError(f"student {key} needs the split3 output form, not {output!r}")
    light_input = arch.get("light_input", DEFAULT_LIGHT_INPUT) if kind == "teacher" \
        else DEFAULT_LIGHT_INPUT
    if not isinstance(light_input, bool):
        raise ValueError(f"teacher light_input {light_input!r} (true | false)")
    if kind == "teacher" and "inputs" in arch and \
            tuple(arch["inputs"]) != teacher_inputs(light_input):
        raise ValueError(f"inputs {arch['inputs']} are not the teacher inputs with "
                         f"light_input {str(light_input).lower()}")
    return expected_networks(kind, num_freqs, hidden, features, output, indirect, light_input)


def _check_tensors(path: Path, want: dict[str, dict], tensors: dict) -> None:
    names = set()
    for net, spec in want.items():
        sizes = spec["sizes"]
        for i in range(len(sizes) - 1):
            for part, shape in zip(TENSOR_PARTS, ((sizes[i + 1], sizes[i]), (sizes[i + 1],))):
                name = tensor_name(net, i, part)
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


def read_weights(path: str | os.PathLike, cls: type[NetworkFile] = NetworkFile) -> NetworkFile:
    """Read and validate the weights file ``path`` into a ``cls`` (:class:`NetworkFile` or a
    subclass). Every problem is a one-line :class:`WeightsError` naming the file."""
    path = Path(path)
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
    if kind not in KINDS:
        raise WeightsError(f"unknown network kind {kind!r} ({' | '.join(KINDS)})", where=path)
    try:
        arch = json.loads(meta["architecture"])
        training = json.loads(meta.get("training", "{}"))
        want = _required_networks(kind, arch)
    except (KeyError, ValueError, TypeError) as exc:
        raise WeightsError(f"bad architecture metadata ({type(exc).__name__}: {exc})",
                           where=path) from None
    if arch.get("networks") != want:
        raise WeightsError(f"architecture {json.dumps(arch.get('networks'))} is not the {kind} "
                           f"architecture this viewer generates GLSL for "
                           f"({json.dumps(want)})", where=path)
    _check_tensors(path, want, tensors)
    digest = checkpoint_hash(tensors)
    if meta.get("checkpoint") != digest:
        raise WeightsError(f"checkpoint hash mismatch (metadata "
                           f"{str(meta.get('checkpoint'))[:12]}, tensors {digest[:12]}): the file "
                           f"was modified or damaged", where=path)
    return cls(path=str(path), kind=kind, checkpoint=digest, architecture=arch, training=training,
               tensors=tensors)


def default_weights(kind: str) -> Path:
    """The weights shipped in ``assets/weights`` for ``kind``."""
    return ASSET_ROOT / "weights" / f"neural_{kind}.safetensors"
