"""The distilled student: one small MLP evaluation per pixel from pre-integrated lighting.

Design (chosen by measurement, see README "Neural shader"): the teacher integrates N light samples
per pixel; the student instead reads the two pre-integrated lighting terms every classical model
already has - SH irradiance E(n) and the GGX-prefiltered radiance P(r, roughness) - and an MLP of
the per-pixel material and n.v predicts how much of each the surface reflects::

    k = sigmoid(MLP(enc(albedo, roughness, metallic, specular, ao, n.v)))       # [6] in [0, 1]
    L_o = 2 k_d * albedo * E / pi + 2 k_s * P                                   # linear in light

so the output is exactly linear in the environment (any intensity, any HDR range) and costs one
evaluation per pixel. The scale 2 leaves room for the indirect light the teacher learned.
"""
from __future__ import annotations

import math

import torch
from torch import nn

from .encoding import encoded_size, fourier_encode

INPUTS = ("albedo.r", "albedo.g", "albedo.b", "roughness", "metallic", "specular", "ao", "NoV")
OUTPUT_SCALE = 2.0


class Student(nn.Module):
    kind = "student"

    def __init__(self, hidden: tuple[int, ...] = (32, 32), num_freqs: int = 0):
        super().__init__()
        self.hidden = tuple(int(h) for h in hidden)
        self.num_freqs = int(num_freqs)
        sizes = [encoded_size(len(INPUTS), self.num_freqs), *self.hidden, 6]
        self.layers = nn.ModuleList(nn.Linear(a, b) for a, b in zip(sizes[:-1], sizes[1:]))

    @property
    def config(self) -> dict:
        return {"hidden": list(self.hidden), "num_freqs": self.num_freqs}

    def activations(self) -> list[str]:
        return ["relu"] * len(self.hidden) + ["sigmoid"]

    def weights(self, x: torch.Tensor) -> torch.Tensor:
        """``x [N, 8]`` (INPUTS order) -> the reflectance factors ``k [N, 6]`` in [0, 1]."""
        h = fourier_encode(x, self.num_freqs)
        for layer in self.layers[:-1]:
            h = torch.relu(layer(h))
        return torch.sigmoid(self.layers[-1](h))

    def forward(self, x: torch.Tensor, irradiance: torch.Tensor, prefiltered: torch.Tensor
                ) -> torch.Tensor:
        """Radiance ``[N, 3]`` from :func:`learned.neural.lighting.student_features`."""
        k = self.weights(x) * OUTPUT_SCALE
        return k[:, :3] * x[:, :3] * irradiance * (1.0 / math.pi) + k[:, 3:] * prefiltered

    def networks(self) -> dict[str, list[tuple[torch.Tensor, torch.Tensor, str]]]:
        """name -> [(weight [out, in], bias [out], activation)] as exported."""
        return {"mlp": [(l.weight, l.bias, a) for l, a in zip(self.layers, self.activations())]}

    def macs_per_pixel(self) -> int:
        return sum(l.in_features * l.out_features for l in self.layers)

    def parameter_count(self) -> int:
        return sum(p.numel() for p in self.parameters())
