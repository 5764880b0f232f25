"""Twins of ``shaders/lib/common.glsl``."""
from __future__ import annotations

import torch

from ._cases import Arg, ParityCase


def saturate(x: torch.Tensor) -> torch.Tensor:
    """GLSL ``float saturate(float x)``: clamp to [0, 1]."""
    return x.clamp(0.0, 1.0)


def sq(x: torch.Tensor) -> torch.Tensor:
    """GLSL ``float sq(float x)``."""
    return x * x


PARITY_CASES = [
    ParityCase("saturate", (Arg(lo=-2, hi=2, adversarial=(0.0, 1.0, -0.0, 1e30, -1e30)),),
               atol=0.0, rtol=0.0, measured="exact"),
    ParityCase("sq", (Arg(lo=-4, hi=4, adversarial=(0.0, 1e-20, 1e18)),),
               atol=0.0, rtol=1e-7, measured="exact"),
]
