"""The neural shadow estimator as the viewer runs it (thesis eq. 4.3, redesigned for real time):

    V = f_eta(L_unshadowed, O(x), n, z, S(x))  a 5-level U-Net, first op at half resolution
    L = L_unshadowed (.) V                     on the surfaces, per colour

The layers are :func:`viewer.neural.shadow_net.plan`'s and the arithmetic is the twins'
(:mod:`learned.twins.shadow_net`), so a trained :class:`ShadowNet` is what
``passes/shadow_net_conv.comp`` computes (``relight parity --model shadow_net``). Saved with
:func:`save_shadow_net` as the viewer's weights file (``[render] shadow_net = "FILE"``).
"""
from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import torch
from safetensors.numpy import save_file
from torch import nn

from viewer.neural.shadow_net import (
    DEFAULT_ARCHITECTURE,
    demodulates,
    metadata,
    plan,
    read_shadow_net,
    receptive_field,
)

from ..twins.shadow_net import shadow_net, shadow_net_apply, shadow_net_inputs


class ShadowNet(nn.Module):
    """``architecture``: ``{"levels": L, "widths": [...]}`` (default: 5 levels, widths
    8-12-16-24-32, receptive field 220 px, ~825 multiply-adds per full-resolution pixel; with
    ``"gain": g`` V = g sigmoid in (0, g)). The output layer starts near "no shadow" (bias 3:
    sigmoid 0.95; with g > 1 the bias of V = 1, -log(g - 1); weights of 0.01 so that the
    gradient reaches every layer from the first step)."""

    kind = "shadow_net"

    def __init__(self, architecture: dict | None = None):
        super().__init__()
        self.architecture = dict(architecture or DEFAULT_ARCHITECTURE)
        self.layers = [layer.as_dict() for layer in plan(self.architecture)]
        self.weights = nn.ParameterDict()
        self.biases = nn.ParameterDict()
        for layer in plan(self.architecture):
            w = torch.empty(layer.weight_shape)
            nn.init.kaiming_normal_(w, nonlinearity="relu")
            b = torch.zeros(layer.out_channels)
            if layer.name == "out":  # near "no shadow", with a gradient into every layer
                w.normal_(0.0, 0.01)
                b.fill_(3.0 if layer.gain == 1.0 else -math.log(layer.gain - 1.0))
            self.weights[layer.name] = nn.Parameter(w)
            self.biases[layer.name] = nn.Parameter(b)

    @property
    def receptive_field(self) -> int:
        return receptive_field(self.architecture)

    def params(self) -> dict:
        return {name: (self.weights[name], self.biases[name]) for name in self.weights}

    @property
    def demodulates(self) -> bool:
        """Whether it reads the radiance over the base colour (``"demodulate"``)."""
        return demodulates(self.architecture)

    def visibility(self, radiance, ao, normal, depth, vis, keep: dict | None = None,
                   albedo=None) -> torch.Tensor:
        """``[B, 3|4, H, W]`` unshadowed radiance, ``[B, 1, H, W]`` O(x), ``[B, 3, H, W]``
        normals, ``[B, 1, H, W]`` view depth, ``[B, 1, H, W]`` S(x) (and ``[B, 3, H, W]`` base
        colour ``albedo``: needed by an estimator that :attr:`demodulates`) -> visibility
        ``[B, 3, H, W]`` in (0, g) (g: the architecture's gain, 1 when absent)."""
        if self.demodulates and albedo is None:
            raise ValueError("this estimator reads the radiance over the base colour "
                             "(architecture \"demodulate\"): give the albedo")
        inputs = shadow_net_inputs(radiance, ao, normal, depth, vis,
                                   albedo if self.demodulates else None)
        return shadow_net(inputs, self.layers, self.params(), keep)

    def forward(self, radiance, ao, normal, depth, vis, surface, albedo=None) -> torch.Tensor:
        """The shaded radiance ``[B, 4, H, W]``: rgb times the visibility where ``surface``
        ``[B, 1, H, W]`` (bool) holds."""
        if radiance.shape[1] == 3:
            radiance = torch.cat([radiance, torch.ones_like(radiance[:, :1])], 1)
        return shadow_net_apply(radiance, self.visibility(radiance, ao, normal, depth, vis,
                                                          albedo=albedo), surface)

    def tensors(self) -> dict[str, np.ndarray]:
        """The file's tensors, ``<layer>.weight`` / ``<layer>.bias`` float32."""
        out = {}
        for name in self.weights:
            out[f"{name}.weight"] = self.weights[name].detach().cpu().float().numpy().copy()
            out[f"{name}.bias"] = self.biases[name].detach().cpu().float().numpy().copy()
        return out


def save_shadow_net(model: ShadowNet, path, training: dict | None = None) -> Path:
    """``model`` as the viewer's weights file (``viewer.neural.shadow_net`` format); returns the
    path."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tensors = model.tensors()
    save_file(tensors, str(path), metadata=metadata(model.architecture, tensors, training))
    return path


def load_shadow_net(path) -> ShadowNet:
    """The :class:`ShadowNet` of a weights file, validated by the viewer's reader (one-line
    errors naming the file)."""
    net = read_shadow_net(path)
    model = ShadowNet(net.architecture)
    with torch.no_grad():
        for name in model.weights:
            model.weights[name].copy_(torch.from_numpy(net.weight(name)))
            model.biases[name].copy_(torch.from_numpy(net.bias(name)))
    return model.eval()


def describe(model: ShadowNet) -> str:
    """One line: architecture, parameters, receptive field."""
    n = sum(p.numel() for p in model.parameters())
    return (f"shadow_net {json.dumps(model.architecture)}: {n} parameters, receptive field "
            f"{model.receptive_field} px")
