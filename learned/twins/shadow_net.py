"""Twins of ``shaders/lib/shadow_net.glsl`` and of the pass ``passes/shadow_net_conv.comp``: the
neural shadow estimator's inputs, activations, upsampling taps, feature-map fetch, one layer
(:func:`shadow_net_conv`) and the whole network (:func:`shadow_net`, :func:`shadow_net_apply`).

Maps are ``[B, C, H, W]`` tensors (the GL side tiles them as RGBA texels, four channels a slice);
a layer is the plain dict of ``viewer.neural.shadow_net.Layer.as_dict`` (sources: 0 none, 1 a map
at the output's level, 2 half resolution nearest-upsampled, 3 the same bilinear, 4 the frame's
inputs; act 0 relu, 1 sigmoid).
"""
from __future__ import annotations

import torch
from torch.nn import functional as F

SOURCE_NONE, SOURCE_MAP, SOURCE_NEAREST_UP, SOURCE_BILINEAR_UP, SOURCE_FRAME = 0, 1, 2, 3, 4


def shadow_net_input_a(radiance: torch.Tensor, ao: torch.Tensor) -> torch.Tensor:
    """GLSL ``vec4 shadow_net_input_a(vec3 radiance, float ao)``: ``[..., 3]``, ``[...]`` ->
    ``[..., 4]``, log(1 + max(L, 0)) and O(x)."""
    return torch.cat([torch.log(1.0 + radiance.clamp_min(0.0)), ao[..., None]], -1)


SHADOW_NET_ALBEDO_FLOOR = 0.05  # GLSL SHADOW_NET_ALBEDO_FLOOR


def shadow_net_demodulate(radiance: torch.Tensor, albedo: torch.Tensor) -> torch.Tensor:
    """GLSL ``vec3 shadow_net_demodulate(vec3 radiance, vec3 albedo)``: ``radiance`` over
    ``max(albedo, SHADOW_NET_ALBEDO_FLOOR)`` per channel (``[..., 3]`` both)."""
    return radiance / albedo.clamp_min(SHADOW_NET_ALBEDO_FLOOR)


def shadow_net_input_b(normal: torch.Tensor, depth: torch.Tensor) -> torch.Tensor:
    """GLSL ``vec4 shadow_net_input_b(vec3 normal, float depth)``: the normal and 1 / (1 + z),
    0 where z <= 0."""
    inv = torch.where(depth > 0.0, 1.0 / (1.0 + depth.clamp_min(0.0)), torch.zeros_like(depth))
    return torch.cat([normal, inv[..., None]], -1)


def shadow_net_input_c(visibility: torch.Tensor) -> torch.Tensor:
    """GLSL ``vec4 shadow_net_input_c(float visibility)``: S(x) and three zeros."""
    z = torch.zeros_like(visibility)
    return torch.stack([visibility, z, z, z], -1)


def shadow_net_act(x: torch.Tensor, kind: torch.Tensor) -> torch.Tensor:
    """GLSL ``vec4 shadow_net_act(vec4 x, int kind)``: relu (0) or sigmoid (1); ``kind``
    ``[...]`` (or a Python int). torch's sigmoid is 1 / (1 + exp(-x)) to rounding and has a
    finite gradient where exp(-x) overflows (the formula's autograd gives inf / inf there)."""
    kind = torch.as_tensor(kind, device=x.device)
    sig = torch.sigmoid(x)
    return torch.where((kind == 1)[..., None] if kind.dim() else kind == 1, sig, x.clamp_min(0.0))


def shadow_net_up_taps(x: torch.Tensor, n: torch.Tensor) -> torch.Tensor:
    """GLSL ``vec4 shadow_net_up_taps(int x, int n)``: ``(i0, i1, 0.75, 0.25)`` of fine pixel x
    over a source n texels long (float tensors holding integers)."""
    x, n = x.to(torch.int64), n.to(torch.int64)
    i = x // 2
    j = torch.where(x % 2 == 0, i - 1, i + 1)
    j = torch.minimum(torch.maximum(j, torch.zeros_like(j)), n - 1)
    return torch.stack([i.float(), j.float(), torch.full_like(i, 0, dtype=torch.float32) + 0.75,
                        torch.full_like(i, 0, dtype=torch.float32) + 0.25], -1)


def shadow_net_fetch(fmap: torch.Tensor, p: torch.Tensor, s: torch.Tensor) -> torch.Tensor:
    """GLSL ``vec4 shadow_net_fetch(sampler2D map, ivec2 p, int s, ivec2 size)``: channels
    4 s .. 4 s + 3 (zero past the map's) of ``fmap`` ``[C, H, W]`` at ``p`` ``[N, 2]`` (x, y)
    clamped to the map; ``s`` ``[N]`` -> ``[N, 4]``."""
    c, h, w = fmap.shape
    padded = torch.cat([fmap, fmap.new_zeros((-c) % 4 + 4, h, w)])
    x = p[:, 0].long().clamp(0, w - 1)
    y = p[:, 1].long().clamp(0, h - 1)
    ch = 4 * s.long()[:, None] + torch.arange(4)
    return padded[ch, y[:, None], x[:, None]]


def _nearest_up(x: torch.Tensor, size: tuple[int, int]) -> torch.Tensor:
    return x.repeat_interleave(2, -1).repeat_interleave(2, -2)[..., :size[1], :size[0]]


def _bilinear_up(x: torch.Tensor, size: tuple[int, int]) -> torch.Tensor:
    """2x bilinear (half-pixel centres, clamped) cropped to ``size`` (W, H): the taps of
    :func:`shadow_net_up_taps` with its weights in its order."""
    h, w = x.shape[-2:]
    tx = shadow_net_up_taps(torch.arange(size[0]), torch.tensor(w))
    ty = shadow_net_up_taps(torch.arange(size[1]), torch.tensor(h))
    ix0, ix1 = tx[:, 0].long(), tx[:, 1].long()
    iy0, iy1 = ty[:, 0].long(), ty[:, 1].long()
    rows0, rows1 = x[..., iy0, :], x[..., iy1, :]
    top = 0.75 * rows0[..., ix0] + 0.25 * rows0[..., ix1]
    bottom = 0.75 * rows1[..., ix0] + 0.25 * rows1[..., ix1]
    return 0.75 * top + 0.25 * bottom


def _at_output(x: torch.Tensor, kind: int, size: tuple[int, int]) -> torch.Tensor:
    if kind == SOURCE_NEAREST_UP:
        return _nearest_up(x, size)
    if kind == SOURCE_BILINEAR_UP:
        return _bilinear_up(x, size)
    return x


def _frame_input(x: torch.Tensor | None, layer: dict, source: int) -> torch.Tensor | None:
    """``x`` as the pass reads it: the frame's inputs (``source`` 4) with S(x), their last
    channel (:func:`shadow_net_input_c`), held at 1 for an estimator that does not read it."""
    if x is None or source != SOURCE_FRAME or layer.get("env_vis", True):
        return x
    return torch.cat([x[:, :8], torch.ones_like(x[:, 8:9])], 1)


def shadow_net_conv(a: torch.Tensor, b: torch.Tensor | None, weight: torch.Tensor,
                    bias: torch.Tensor, layer: dict) -> torch.Tensor:
    """Pass ``passes/shadow_net_conv.comp`` (tiled output, ``SN_OUTPUT`` 0): ``layer``'s
    convolution of ``a`` ``[B, Ca, h, w]`` (at the level its source names) and the skip ``b``
    (``[B, Cb, H, W]`` or None), replicate padding, -> ``[B, Cout, H', W']`` after the activation
    times ``layer["gain"]`` (absent: 1). A frame source (the inputs) with ``layer["env_vis"]``
    false reads 1 for S(x) (``SN_ENV_VIS`` 0).
    ``weight`` ``[Cout, Ca + Cb, k, k]``, ``bias`` ``[Cout]``."""
    a = _frame_input(a, layer, layer["a_source"])
    b = _frame_input(b, layer, layer["b_source"])
    k, stride = layer["kernel"], layer["stride"]
    if stride == 2:  # 2 x 2 taps at 2p: the level below's size, odd sides replicated
        x = a
        ph, pw = x.shape[-2] % 2, x.shape[-1] % 2
        x = F.pad(x, (0, pw, 0, ph), mode="replicate") if ph or pw else x
        y = F.conv2d(x, weight, bias, stride=2)
    else:
        size = (b.shape[-1], b.shape[-2]) if b is not None else (a.shape[-1], a.shape[-2])
        if layer["a_source"] in (SOURCE_NEAREST_UP, SOURCE_BILINEAR_UP) and b is None:
            raise ValueError("an upsampled source needs the skip that sets the output's size")
        x = _at_output(a, layer["a_source"], size)
        if b is not None:
            x = torch.cat([x, b], 1)
        r = k // 2
        x = F.pad(x, (r, r, r, r), mode="replicate") if r else x
        y = F.conv2d(x, weight, bias)
    y = shadow_net_act(y.movedim(1, -1), layer["act"]).movedim(-1, 1)
    gain = float(layer.get("gain", 1.0))  # SN_GAIN: the output layer's g (1 elsewhere)
    return y if gain == 1.0 else gain * y


def shadow_net_inputs(radiance: torch.Tensor, ao: torch.Tensor, normal: torch.Tensor,
                      depth: torch.Tensor, vis: torch.Tensor,
                      albedo: torch.Tensor | None = None) -> torch.Tensor:
    """The frame's inputs ``[B, 9, H, W]`` from ``[B, 3 | 4, H, W]`` radiance, ``[B, 1, H, W]``
    occlusion O(x), ``[B, 3, H, W]`` normals, ``[B, 1, H, W]`` view depth and ``[B, 1, H, W]``
    visibility of the environment's light S(x) (SN_*_SOURCE 4); with ``albedo``
    (``[B, 3, H, W]`` base colour) the radiance is demodulated first (``SN_DEMODULATE``: an
    estimator whose architecture says ``"demodulate"``)."""
    def last(t):
        return t.movedim(1, -1)

    rgb = last(radiance[:, :3])
    if albedo is not None:
        rgb = shadow_net_demodulate(rgb, last(albedo))
    a = shadow_net_input_a(rgb, last(ao)[..., 0])
    b = shadow_net_input_b(last(normal), last(depth)[..., 0])
    c = shadow_net_input_c(last(vis)[..., 0])[..., :1]
    return torch.cat([a, b, c], -1).movedim(-1, 1)


def shadow_net(inputs: torch.Tensor, layers: list[dict], params: dict,
               keep: dict | None = None) -> torch.Tensor:
    """The whole estimator: ``inputs`` ``[B, 9, H, W]`` (:func:`shadow_net_inputs`) through
    ``layers`` in order -> the visibility ``[B, 3, H, W]``; ``params``: name -> (weight, bias);
    ``keep``: filled with every layer's output by name."""
    maps = {"input": inputs}
    for layer in layers:
        w, bias = params[layer["name"]]
        a = maps[layer["a"]]
        b = maps[layer["b"]] if layer["b"] is not None else None
        maps[layer["name"]] = shadow_net_conv(a, b, w, bias, layer)
    if keep is not None:
        keep.update(maps)
    return maps[layers[-1]["name"]]


def shadow_net_apply(radiance: torch.Tensor, visibility: torch.Tensor,
                     surface: torch.Tensor) -> torch.Tensor:
    """``passes/shadow_net_conv.comp`` with ``SN_OUTPUT`` 1: ``radiance`` ``[B, 4, H, W]`` with
    its rgb multiplied by ``visibility`` ``[B, 3, H, W]`` where ``surface`` ``[B, 1, H, W]``
    (alpha > 0 and depth > 0) holds."""
    rgb = torch.where(surface, radiance[:, :3] * visibility, radiance[:, :3])
    return torch.cat([rgb, radiance[:, 3:]], 1)
