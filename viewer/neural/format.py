"""The neural-shader weights file: its format and its validation. The networks' input/output
contract it records (inputs, outputs, architecture) is :mod:`viewer.neural.contract`, whose names
are importable from here too.

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
                [...]}}, "hidden": ..., "num_freqs": L, "inputs": [...], "features": "base" | "dfg" | "ssao" | "vis" | "dfg-vis",
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
                shades it (``SUN_LIGHT``, viewer/environment/sun.py), the sun's light with the same learned
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
from .contract import (  # the contract's names stay importable from here
    DEFAULT_FEATURES,
    DEFAULT_INDIRECT,
    DEFAULT_LIGHT_INPUT,
    DEFAULT_MULTISCATTER,
    DEFAULT_OCCLUSION,
    DEFAULT_OUTPUT,
    DEFAULT_SUN,
    INDIRECT_HIDDEN,
    STUDENT_ALL_INPUTS,
    STUDENT_FEATURES,
    STUDENT_INDIRECT,
    STUDENT_INPUTS,
    STUDENT_OCCLUSION,
    STUDENT_OUTPUTS,
    TEACHER_INPUTS,
    _required_networks,
    architecture,
    encoding,
    expected_networks,
    teacher_inputs,
)

__all__ = [
    "DEFAULT_FEATURES", "DEFAULT_INDIRECT", "DEFAULT_LIGHT_INPUT", "DEFAULT_MULTISCATTER",
    "DEFAULT_OCCLUSION", "DEFAULT_OUTPUT", "DEFAULT_SUN", "FORMAT", "FORMAT_VERSION",
    "INDIRECT_HIDDEN", "KINDS", "MODEL_KINDS", "STUDENT_ALL_INPUTS", "STUDENT_FEATURES",
    "STUDENT_INDIRECT", "STUDENT_INPUTS", "STUDENT_OCCLUSION", "STUDENT_OUTPUTS", "TEACHER_INPUTS",
    "TENSOR_PARTS", "NetworkFile", "WeightsError", "architecture", "checkpoint_hash",
    "default_weights", "encoding", "expected_networks", "metadata", "read_weights",
    "teacher_inputs", "tensor_name",
]


FORMAT = "relight-neural-shader"
FORMAT_VERSION = "1"
KINDS = ("student", "teacher")
MODEL_KINDS = {"neural": "student", "neural_teacher": "teacher"}  # model -> network kind

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
        """Student input set (``base`` | ``dfg`` | ``ssao`` | ``vis`` | ``dfg-vis``,
        :data:`STUDENT_FEATURES`)."""
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


def metadata(kind: str, arch: dict, tensors: dict, training: dict | None = None) -> dict[str, str]:
    """The string metadata of a file holding ``tensors`` of a ``kind`` network with the
    architecture ``arch`` (:func:`architecture`)."""
    return {"format": FORMAT, "version": FORMAT_VERSION, "kind": kind,
            "architecture": json.dumps(arch),
            "encoding": json.dumps(encoding(arch["num_freqs"])),
            "checkpoint": checkpoint_hash(tensors),
            "training": json.dumps(training or {})}


def read_safetensors(path: Path, file_format: str, version: int, what: str
                     ) -> tuple[dict, dict]:
    """``(metadata, tensors)`` of the safetensors file ``path`` whose metadata says ``format =
    file_format`` and ``version``; otherwise a one-line :class:`WeightsError` (``what``: the kind
    of file, for the message). Shared by every weights format of the viewer."""
    try:
        with safe_open(str(path), framework="numpy") as f:
            meta = dict(f.metadata() or {})
            tensors = {k: f.get_tensor(k) for k in f.keys()}
    except (SafetensorError, OSError, ValueError, MemoryError) as exc:
        raise WeightsError(f"not a readable safetensors file (truncated or corrupt: "
                           f"{str(exc).splitlines()[0] if str(exc) else type(exc).__name__})",
                           where=path) from None
    if meta.get("format") != file_format:
        raise WeightsError(f"not a relight {what} file (metadata format "
                           f"{meta.get('format')!r}, expected {file_format!r})", where=path)
    if meta.get("version") != version:
        raise WeightsError(f"format version {meta.get('version')!r} is not supported (this "
                           f"viewer reads version {version})", where=path)
    return meta, tensors


def check_tensor(path: Path, tensors: dict, name: str, shape: tuple) -> None:
    """Tensor ``name`` exists, is float32 of ``shape`` and finite (else a :class:`WeightsError`)."""
    t = tensors.get(name)
    if t is None:
        raise WeightsError(f"missing tensor {name!r}", where=path)
    if t.dtype != np.float32 or tuple(t.shape) != tuple(shape):
        raise WeightsError(f"tensor {name!r} is {t.dtype}{list(t.shape)}, expected "
                           f"float32{list(shape)}", where=path)
    if not np.isfinite(t).all():
        raise WeightsError(f"tensor {name!r} has NaN/Inf values", where=path)


def check_contents(path: Path, meta: dict, tensors: dict, names: set[str]) -> str:
    """No tensor beside ``names`` and the metadata's checkpoint hash matches the tensors: returns
    that hash (else a :class:`WeightsError`)."""
    extra = sorted(set(tensors) - names)
    if extra:
        raise WeightsError(f"unexpected tensors {', '.join(extra)}", where=path)
    digest = checkpoint_hash(tensors)
    if meta.get("checkpoint") != digest:
        raise WeightsError(f"checkpoint hash mismatch (metadata "
                           f"{str(meta.get('checkpoint'))[:12]}, tensors {digest[:12]}): the file "
                           f"was modified or damaged", where=path)
    return digest


def _check_tensors(path: Path, want: dict[str, dict], tensors: dict) -> set[str]:
    """Every tensor of the networks ``want`` describes; returns their names."""
    names = set()
    for net, spec in want.items():
        sizes = spec["sizes"]
        for i in range(len(sizes) - 1):
            for part, shape in zip(TENSOR_PARTS, ((sizes[i + 1], sizes[i]), (sizes[i + 1],))):
                name = tensor_name(net, i, part)
                names.add(name)
                check_tensor(path, tensors, name, shape)
    return names


def read_weights(path: str | os.PathLike, cls: type[NetworkFile] = NetworkFile) -> NetworkFile:
    """Read and validate the weights file ``path`` into a ``cls`` (:class:`NetworkFile` or a
    subclass). Every problem is a one-line :class:`WeightsError` naming the file."""
    path = Path(path)
    meta, tensors = read_safetensors(path, FORMAT, FORMAT_VERSION, "neural-shader")
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
    digest = check_contents(path, meta, tensors, _check_tensors(path, want, tensors))
    return cls(path=str(path), kind=kind, checkpoint=digest, architecture=arch, training=training,
               tensors=tensors)


def default_weights(kind: str) -> Path:
    """The weights shipped in ``assets/weights`` for ``kind``."""
    return ASSET_ROOT / "weights" / f"neural_{kind}.safetensors"
