"""The neural shadow estimator's weights file, its layer plan and its packing for GLSL (torch-free).

The estimator (thesis eq. 4.3, redesigned for the viewer) is a U-Net over the frame:

    x0 = [log(1 + L_unshadowed), O(x), n, 1 / (1 + z), S(x)]    9 channels, full resolution
                                                                 (``"demodulate": true``: L
                                                                 over max(albedo, 0.05))
    e_l = relu(conv3(relu(conv2/2(e_{l-1}))))                    l = 1..L at 1 / 2^l
    d_l = relu(conv_k([up(d_{l+1}), e_l]))                       l = L-1..1 (d_L = e_L), k = 3
                                                                 (1 at l = 1), nearest up
                                                                 (``"upsample": "bilinear"``:
                                                                 bilinear into d_1)
    V   = g sigmoid(conv1([bilinear_up(d_1), x0]))               full resolution, 3 channels

and the shading is multiplied by V where there is a surface (the product form). The gain g
(``"gain"`` in the architecture, 1 when absent: V is a visibility in (0, 1)) lets V also add
light the unshadowed frame lacks (inter-reflections, the base model's missing energy): on the
protocol's validation split over half of the frame's error is where it is too dark, which a
visibility cannot reach (docs/measurements/students.md). The first
operation halves the resolution, so full resolution only sees the inputs and the last 1 x 1
layer; :func:`receptive_field` is the reach of one output pixel (``levels`` 5: 220 px, covering
the ~100 px penumbrae of Neural Shadow Mapping's 5-level table).

The file is safetensors with float32 tensors ``<layer>.weight`` ``[out, in, k, k]`` and
``<layer>.bias`` ``[out]`` (the layers of :func:`plan`; input channels: the first source's then
the skip's) and string metadata ``format`` = :data:`FORMAT`, ``version`` = :data:`FORMAT_VERSION`,
``architecture`` (JSON ``{"levels": L, "widths": [C_1 .. C_L]}``, optionally ``"gain": g``,
``"env_visibility": false``, ``"upsample": "bilinear"``: the 1 x 1 decoder at half resolution
reads the level below bilinear-upsampled, not nearest, so that V shows no blocks of the coarse
levels, and ``"demodulate": true``: the radiance input is divided by the surface's base colour,
so that texture detail does not read as geometry), ``checkpoint`` (sha256 of the
tensors, :func:`viewer.neural.checkpoint_hash`) and ``training`` (JSON, free form).
:func:`read_shadow_net` validates all of it; every problem is one :class:`WeightsError` line
naming the file. :func:`pack_layer` lays a layer's weights out as the ``vec4`` array its pass
reads (``shaders/passes/shadow_net_conv.comp``).
"""
from __future__ import annotations

import json
import math
import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from safetensors import SafetensorError, safe_open

from .format import (
    WeightsError,
    check_contents,
    check_tensor,
    checkpoint_hash,
    read_safetensors,
)

FORMAT = "relight-shadow-net"
FORMAT_VERSION = "1"
# lib/shadow_net.glsl shadow_net_input_a (4), shadow_net_input_b (4) and shadow_net_input_c (1):
# S(x) is the SSAO pass's visibility of the environment's light (SSAO_ENV_VIS)
INPUT_CHANNELS = 9
LEVELS_RANGE = (1, 7)
WIDTH_MAX = 64
GAIN_RANGE = (1.0, 4.0)  # the output's V in (0, g): g = 1 a visibility, above it also a gain
UBO_VEC4_MAX = 4096  # 64 KiB: GL_MAX_UNIFORM_BLOCK_SIZE on llvmpipe and most GPUs
DEFAULT_ARCHITECTURE = {"levels": 5, "widths": [8, 12, 16, 24, 32]}
# how the last decoder (1 x 1, half resolution) reads the level below ("upsample"; the others,
# 3 x 3, read it nearest: the pass samples bilinear for 1 x 1 kernels only)
UPSAMPLES = ("nearest", "bilinear")

# sources of a layer's inputs (SN_A_SOURCE / SN_B_SOURCE of passes/shadow_net_conv.comp)
SOURCE_NONE, SOURCE_MAP, SOURCE_NEAREST_UP, SOURCE_BILINEAR_UP, SOURCE_FRAME = 0, 1, 2, 3, 4
ACT_RELU, ACT_SIGMOID = 0, 1
# how the frame takes the visibility ([render] shadow_net_use; viewer/graph/shadow_net.py):
# multiplied into the shaded radiance, or in place of SSAO's O(x) and S(x) in the lighting pass
SHADOW_NET_USES = ("product", "visibility")


@dataclass(frozen=True)
class Layer:
    """One convolution of the plan: ``kernel`` x ``kernel`` taps (stride 1, replicate padding) or
    2 x 2 at stride 2; input ``a`` (a map name, or ``"input"``: the frame's inputs) read as
    ``a_source``, an optional skip ``b`` at the output's level; output at ``level`` (0 = full)."""

    name: str
    level: int
    kernel: int
    stride: int
    a: str
    a_source: int
    a_channels: int
    b: str | None
    b_source: int
    b_channels: int
    out_channels: int
    act: int
    gain: float = 1.0  # the output times this after its activation (SN_GAIN; the last layer)
    # whether a frame source reads S(x) (SN_ENV_VIS); False: the input channel holds 1, the
    # architecture's "env_visibility": false (the frame then marches no S(x) for it)
    env_vis: bool = True
    # whether a frame source divides the radiance by the base colour (SN_DEMODULATE; the
    # architecture's "demodulate")
    demodulate: bool = False

    @property
    def in_channels(self) -> int:
        return self.a_channels + self.b_channels

    @property
    def weight_shape(self) -> tuple[int, int, int, int]:
        return (self.out_channels, self.in_channels, self.kernel, self.kernel)

    def as_dict(self) -> dict:
        """The plain form the torch twin takes (``learned.twins.shadow_net.shadow_net``)."""
        return {k: getattr(self, k) for k in self.__dataclass_fields__}


def slices(channels: int) -> int:
    """RGBA32F texels per pixel holding ``channels`` (the maps are tiled side by side)."""
    return -(-int(channels) // 4)


def level_size(size: tuple[int, int], level: int) -> tuple[int, int]:
    """Width, height at ``level`` of a frame of ``size``: ceil halving per level."""
    w, h = int(size[0]), int(size[1])
    for _ in range(level):
        w, h = -(-w // 2), -(-h // 2)
    return w, h


def check_architecture(arch: dict) -> tuple[int, list[int]]:
    """``(levels, widths)`` of ``arch``, or ``ValueError`` saying what is wrong."""
    if not isinstance(arch, dict):
        raise TypeError("architecture is not a JSON object")
    levels, widths = arch.get("levels"), arch.get("widths")
    if not isinstance(levels, int) or not LEVELS_RANGE[0] <= levels <= LEVELS_RANGE[1]:
        raise ValueError(f"levels {levels!r} is not an integer in {LEVELS_RANGE[0]}.."
                         f"{LEVELS_RANGE[1]}")
    if (not isinstance(widths, list) or len(widths) != levels
            or not all(isinstance(w, int) and 1 <= w <= WIDTH_MAX for w in widths)):
        raise ValueError(f"widths {widths!r} is not a list of {levels} integers in 1..{WIDTH_MAX}")
    gain = arch.get("gain", 1.0)
    if (isinstance(gain, bool) or not isinstance(gain, (int, float))
            or not GAIN_RANGE[0] <= gain <= GAIN_RANGE[1]):
        raise ValueError(f"gain {gain!r} is not a number in {GAIN_RANGE[0]}..{GAIN_RANGE[1]}")
    if not isinstance(arch.get("env_visibility", True), bool):
        raise ValueError(f"env_visibility {arch['env_visibility']!r} is not true or false")
    if not isinstance(arch.get("demodulate", False), bool):
        raise ValueError(f"demodulate {arch['demodulate']!r} is not true or false")
    if arch.get("upsample", "nearest") not in UPSAMPLES:
        raise ValueError(f"upsample {arch['upsample']!r} is not one of {', '.join(UPSAMPLES)}")
    return levels, list(widths)


def demodulates(arch: dict) -> bool:
    """Whether an estimator of ``arch`` reads the radiance over the base colour (``"demodulate"``,
    false when absent: lib/shadow_net.glsl ``shadow_net_demodulate``)."""
    return bool(arch.get("demodulate", False))


def reads_env_visibility(arch: dict) -> bool:
    """Whether an estimator of ``arch`` reads S(x), the SSAO pass's visibility of the
    environment's light (``"env_visibility"``, true when absent)."""
    return bool(arch.get("env_visibility", True))


def plan(arch: dict) -> list[Layer]:
    """The layers of ``arch`` in the order they run (see the module's docstring)."""
    levels, widths = check_architecture(arch)
    c = [INPUT_CHANNELS] + widths
    vis = reads_env_visibility(arch)
    dem = demodulates(arch)
    layers = []
    for lv in range(1, levels + 1):
        prev = "input" if lv == 1 else f"enc{lv - 1}"
        src = SOURCE_FRAME if lv == 1 else SOURCE_MAP
        layers.append(Layer(f"down{lv}", lv, 2, 2, prev, src, c[lv - 1], None, SOURCE_NONE, 0,
                            c[lv], ACT_RELU, env_vis=vis, demodulate=dem))
        layers.append(Layer(f"enc{lv}", lv, 3, 1, f"down{lv}", SOURCE_MAP, c[lv], None,
                            SOURCE_NONE, 0, c[lv], ACT_RELU))
    coarse = f"enc{levels}"
    up1 = SOURCE_BILINEAR_UP if arch.get("upsample") == "bilinear" else SOURCE_NEAREST_UP
    for lv in range(levels - 1, 0, -1):
        layers.append(Layer(f"dec{lv}", lv, 3 if lv > 1 else 1, 1, coarse,
                            up1 if lv == 1 else SOURCE_NEAREST_UP,
                            c[lv + 1], f"enc{lv}", SOURCE_MAP, c[lv], c[lv], ACT_RELU))
        coarse = f"dec{lv}"
    layers.append(Layer("out", 0, 1, 1, coarse, SOURCE_BILINEAR_UP, c[1], "input", SOURCE_FRAME,
                        INPUT_CHANNELS, 3, ACT_SIGMOID, float(arch.get("gain", 1.0)), vis, dem))
    return layers


def receptive_field(arch: dict) -> int:
    """Full-resolution pixels across the widest region one output pixel depends on: its interval
    walked back along the longest path (the output, the decoder, the encoder's deepest level, the
    encoder back up to the inputs), the widest over the output pixel's alignments to the levels."""
    by_name = {layer.name: layer for layer in plan(arch)}
    levels = int(arch["levels"])
    widest = 0
    for p in range(2 ** (levels + 1)):
        lo, hi, name = p, p, "out"
        while name != "input":
            layer = by_name[name]
            r = layer.kernel // 2 if layer.stride == 1 else 0
            lo, hi = lo - r, hi + r
            if layer.stride == 2:  # taps 2p, 2p + 1 of the level below
                lo, hi = 2 * lo, 2 * hi + 1
            elif layer.a_source == SOURCE_NEAREST_UP:
                lo, hi = lo // 2, hi // 2
            elif layer.a_source == SOURCE_BILINEAR_UP:  # texels x // 2 and its neighbour
                lo, hi = lo // 2 - (lo % 2 == 0), hi // 2 + (hi % 2 == 1)
            name = layer.a
        widest = max(widest, hi - lo + 1)
    return widest


def macs_per_pixel(arch: dict) -> float:
    """Multiply-adds per full-resolution pixel (each level has a quarter of the pixels)."""
    return float(sum(np.prod(layer.weight_shape) / 4 ** layer.level for layer in plan(arch)))


@dataclass(frozen=True)
class ShadowNetFile:
    """A validated weights file: its path, checkpoint, architecture, plan and tensors."""

    path: str
    checkpoint: str
    architecture: dict
    training: dict
    layers: tuple[Layer, ...]
    tensors: dict  # name -> np.ndarray float32

    def weight(self, layer: str) -> np.ndarray:
        return self.tensors[f"{layer}.weight"]

    def bias(self, layer: str) -> np.ndarray:
        return self.tensors[f"{layer}.bias"]

    def packed(self, layer: Layer) -> np.ndarray:
        return pack_layer(layer, self.weight(layer.name), self.bias(layer.name))


def len_packed(layer: Layer) -> int:
    """``vec4`` s of :func:`pack_layer`'s array for ``layer``."""
    so = slices(layer.out_channels)
    return layer.kernel ** 2 * (slices(layer.a_channels) + slices(layer.b_channels)) * so * 4 + so


def pack_layer(layer: Layer, weight: np.ndarray, bias: np.ndarray) -> np.ndarray:
    """``[N, 4]`` float32, the ``vec4`` array ``passes/shadow_net_conv.comp`` reads: for each tap
    (row-major), input slice (the first source's slices, then the skip's) and output slice, the
    four columns of the ``mat4`` M with out += M in; then one bias ``vec4`` per output slice.
    Channels past a source's count are zero."""
    sa, sb, so = slices(layer.a_channels), slices(layer.b_channels), slices(layer.out_channels)
    k = layer.kernel
    w = np.zeros((k * k, sa + sb, so, 4, 4), np.float32)  # [tap, in slice, out slice, col, row]
    full = np.zeros((4 * so, 4 * (sa + sb), k, k), np.float32)  # padded [out, in, ky, kx]
    full[:layer.out_channels, :layer.a_channels] = weight[:, :layer.a_channels]
    full[:layer.out_channels, 4 * sa:4 * sa + layer.b_channels] = weight[:, layer.a_channels:]
    taps = full.reshape(so, 4, sa + sb, 4, k * k)  # [out slice, row, in slice, col, tap]
    w[:] = taps.transpose(4, 2, 0, 3, 1)
    b = np.zeros(4 * so, np.float32)
    b[:layer.out_channels] = bias
    return np.concatenate([w.reshape(-1, 4), b.reshape(so, 4)]).astype(np.float32)


def metadata(arch: dict, tensors: dict, training: dict | None = None) -> dict[str, str]:
    """The string metadata of a file holding ``tensors`` of ``arch``."""
    check_architecture(arch)
    return {"format": FORMAT, "version": FORMAT_VERSION, "architecture": json.dumps(arch),
            "checkpoint": checkpoint_hash(tensors), "training": json.dumps(training or {})}


def frame_settings(training: dict) -> dict:
    """The frame a weights file's estimator was trained to multiply, from its ``training``
    metadata: ``{"model", "ssao", "indirect", "specular_occlusion", "geometry"}`` (files
    written before the record: split-sum with SSAO, no indirect light, stacks; before
    ``specular_occlusion``: without it). Read by the viewer's check
    (:func:`viewer.graph.shadow_net.check_frame`) and the protocol's scoring."""
    frame = {"model": "ggx_split_sum", "ssao": True, "indirect": False,
             "specular_occlusion": False, "geometry": "stack"}
    return frame | dict(training.get("frame") or {})


def read_shadow_net(path: str | os.PathLike) -> ShadowNetFile:
    """Read and validate the estimator's weights file ``path``; every problem is a one-line
    :class:`WeightsError` naming the file."""
    path = Path(path)
    meta, tensors = read_safetensors(path, FORMAT, FORMAT_VERSION, "shadow-estimator")
    try:
        arch = json.loads(meta["architecture"])
        training = json.loads(meta.get("training", "{}"))
        layers = tuple(plan(arch))
    except (KeyError, ValueError, TypeError) as exc:
        raise WeightsError(f"bad architecture metadata ({type(exc).__name__}: {exc})",
                           where=path) from None
    names = set()
    for layer in layers:
        need = len_packed(layer)
        if need > UBO_VEC4_MAX:
            raise WeightsError(f"layer {layer.name!r} needs {need * 16 // 1024} KiB of weights, "
                               f"more than a 64 KiB uniform block holds", where=path)
        for part, shape in (("weight", layer.weight_shape), ("bias", (layer.out_channels,))):
            names.add(f"{layer.name}.{part}")
            check_tensor(path, tensors, f"{layer.name}.{part}", shape)
    digest = check_contents(path, meta, tensors, names)
    return ShadowNetFile(str(path), digest, arch, training, layers, tensors)


def random_tensors(arch: dict, seed: int = 0, scale: float = 1.0) -> dict[str, np.ndarray]:
    """He-initialised tensors of ``arch`` (numpy, seeded; biases small and random): for tests
    and parity checks, never shipped."""
    rng = np.random.default_rng(seed)
    out = {}
    for layer in plan(arch):
        fan_in = layer.in_channels * layer.kernel ** 2
        out[f"{layer.name}.weight"] = (rng.normal(0.0, scale * math.sqrt(2.0 / fan_in),
                                                  layer.weight_shape)).astype(np.float32)
        out[f"{layer.name}.bias"] = rng.normal(0.0, 0.1, layer.out_channels).astype(np.float32)
    return out


_LOADED: dict[tuple, ShadowNetFile] = {}
_LOADED_MAX = 4


def load_shadow_net(path: str | os.PathLike) -> ShadowNetFile:
    """:func:`read_shadow_net`, cached by path, size and modification time (:data:`_LOADED_MAX`
    files; the oldest dropped), so a frame graph built every frame reads the file once."""
    p = Path(path)
    try:
        st = p.stat()
    except OSError as exc:
        raise WeightsError(f"cannot read the shadow estimator's weights ({exc.strerror})",
                           where=p) from None
    key = (str(p.resolve()), st.st_size, st.st_mtime_ns)
    net = _LOADED.get(key)
    if net is None:
        net = read_shadow_net(p)
        while len(_LOADED) >= _LOADED_MAX:
            _LOADED.pop(next(iter(_LOADED)))
        _LOADED[key] = net
    return net


def file_format(path: str | os.PathLike) -> str | None:
    """The ``format`` metadata of a safetensors file, or None where it cannot be read (the
    reader of its format then says why): which reader a weights file needs."""
    try:
        with safe_open(str(path), framework="numpy") as f:
            return (f.metadata() or {}).get("format")
    except (SafetensorError, OSError, ValueError, MemoryError):
        return None
