"""The distilled student: one small MLP evaluation per pixel from pre-integrated lighting.

Design (chosen by measurement among :data:`DESIGNS`, see README "Neural shader" and
:func:`learned.train.compare_students`): the teacher integrates N light samples per pixel; the
student instead reads the two pre-integrated lighting terms every classical model already has -
SH irradiance E(n) and the GGX-prefiltered radiance P(r, roughness) - and an MLP of the per-pixel
material and n.v predicts how much of each the surface reflects::

    k = sigmoid(MLP(enc(albedo, roughness, metallic, specular, ao, n.v [, dfg.a, dfg.b])))   # [6]
    L_o = 2 k_d * albedo * E / pi + 2 k_s * P                                  # linear in light

so the output is exactly linear in the environment (any intensity, any HDR range) and costs one
evaluation per pixel. The scale 2 leaves room for the indirect light the teacher learned. With
``features="dfg"`` the two split-sum terms of the DFG LUT at (n.v, roughness) (Karis 2013) are
inputs too: the specular factor of the classical model, f0 A + B, is then one linear map away.
"""
from __future__ import annotations

import math

import torch
from torch import nn

from .encoding import encoded_size, fourier_encode

# input sets (feature name -> inputs); the generated GLSL and viewer/neural.py share these
INPUTS = ("albedo.r", "albedo.g", "albedo.b", "roughness", "metallic", "specular", "ao", "NoV")
FEATURE_INPUTS = {"base": INPUTS, "dfg": INPUTS + ("dfg.a", "dfg.b")}
OUTPUT_SCALE = 2.0

# Candidate designs of the measured comparison (learned.train.compare_students):
# name -> Student keyword arguments
DESIGNS: dict[str, dict] = {
    "w16": {"hidden": (16,)},
    "w16x2": {"hidden": (16, 16)},
    "w32x2": {"hidden": (32, 32)},
    "w64x2": {"hidden": (64, 64)},
    "w32x2-pe2": {"hidden": (32, 32), "num_freqs": 2},
    "w16x2-dfg": {"hidden": (16, 16), "features": "dfg"},
    "w32x2-dfg": {"hidden": (32, 32), "features": "dfg"},
}
SHIPPED_DESIGN = "w16x2-dfg"  # assets/weights/neural_student.safetensors (README "Neural shader")


class Student(nn.Module):
    kind = "student"

    def __init__(self, hidden: tuple[int, ...] = (32, 32), num_freqs: int = 0,
                 features: str = "base"):
        super().__init__()
        if features not in FEATURE_INPUTS:
            raise ValueError(f"unknown student features {features!r} "
                             f"(known: {', '.join(FEATURE_INPUTS)})")
        self.hidden = tuple(int(h) for h in hidden)
        self.num_freqs = int(num_freqs)
        self.features = features
        sizes = [encoded_size(len(self.inputs), self.num_freqs), *self.hidden, 6]
        self.layers = nn.ModuleList(nn.Linear(a, b) for a, b in zip(sizes[:-1], sizes[1:]))

    @property
    def inputs(self) -> tuple[str, ...]:
        return FEATURE_INPUTS[self.features]

    @property
    def config(self) -> dict:
        return {"hidden": list(self.hidden), "num_freqs": self.num_freqs,
                "features": self.features}

    def activations(self) -> list[str]:
        return ["relu"] * len(self.hidden) + ["sigmoid"]

    def weights(self, x: torch.Tensor) -> torch.Tensor:
        """``x [N, len(inputs)]`` (``inputs`` order; wider x is cut) -> the reflectance factors
        ``k [N, 6]`` in [0, 1]."""
        h = fourier_encode(x[:, :len(self.inputs)], self.num_freqs)
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
