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


def half_vector(v: torch.Tensor, l: torch.Tensor) -> torch.Tensor:
    """GLSL ``vec3 half_vector(vec3 v, vec3 l)``: normalize(v + l), +Z where v = -l. [..., 3]."""
    h = v + l
    len2 = (h * h).sum(-1, keepdim=True)
    z = torch.zeros_like(h)
    z[..., 2] = 1.0
    return torch.where(len2 > 1e-30, h * torch.rsqrt(len2.clamp_min(1e-30)), z)


PARITY_CASES = [
    ParityCase("saturate", (Arg(lo=-2, hi=2, adversarial=(0.0, 1.0, -0.0, 1e30, -1e30)),),
               atol=0.0, rtol=0.0, measured="exact",
               envelope="exact: clamp returns the input, 0 or 1"),
    ParityCase("half_vector",
               (Arg(kind="unit", components=3, adversarial=((0, 0, 1),)),
                Arg(kind="unit", components=3, adversarial=((0, 0, -1), (0, 0, 1)))),
               atol=1e-6, rtol=1e-5, measured="max abs 1.8e-7, max rel 2.4e-7 (seeds 0-7)",
               envelope="v + l (1 rounding per component, relative to the sum), dot (5 ops), "
                        "inversesqrt 2 ulp, 3 products: ~8 ulp both sides -> 9e-7 of the unit "
                        "result; v = -l gives +Z exactly"),
    ParityCase("sq", (Arg(lo=-4, hi=4, adversarial=(0.0, 1e-20, 1e18)),),
               atol=0.0, rtol=1e-7, measured="exact",
               envelope="exact: one correctly rounded product (nothing to contract or reorder)"),
]
