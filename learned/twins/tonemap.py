"""Twins of ``shaders/lib/tonemap.glsl``."""
from __future__ import annotations

import torch

from ._cases import Arg, ParityCase

_ACES_IN = torch.tensor([[0.59719, 0.35458, 0.04823],
                         [0.07600, 0.90834, 0.01566],
                         [0.02840, 0.13383, 0.83777]], dtype=torch.float32)
_ACES_OUT = torch.tensor([[1.60475, -0.53108, -0.07367],
                          [-0.10208, 1.10813, -0.00605],
                          [-0.00327, -0.07276, 1.07602]], dtype=torch.float32)


def apply_exposure(c: torch.Tensor, ev: torch.Tensor) -> torch.Tensor:
    """GLSL ``vec3 apply_exposure(vec3 c, float ev)``. c: [..., 3], ev: [...]."""
    return c * torch.exp2(ev)[..., None]


def rrt_odt_fit(v: torch.Tensor) -> torch.Tensor:
    """GLSL ``vec3 rrt_odt_fit(vec3 v)`` (Hill's ACES RRT+ODT fit)."""
    a = v * (v + 0.0245786) - 0.000090537
    b = v * (0.983729 * v + 0.4329510) + 0.238081
    return a / b


def tonemap_aces_fitted(c: torch.Tensor) -> torch.Tensor:
    """GLSL ``vec3 tonemap_aces_fitted(vec3 c)``. c: [..., 3] linear -> [..., 3] in [0, 1]."""
    v = c.clamp(0.0, 1e4) @ _ACES_IN.to(c).T
    return (rrt_odt_fit(v) @ _ACES_OUT.to(c).T).clamp(0.0, 1.0)


def tonemap_reinhard(c: torch.Tensor) -> torch.Tensor:
    """GLSL ``vec3 tonemap_reinhard(vec3 c)``."""
    x = c.clamp_min(0.0)
    return x / (1.0 + x)


def linear_to_srgb(c: torch.Tensor) -> torch.Tensor:
    """GLSL ``vec3 linear_to_srgb(vec3 c)`` (IEC 61966-2-1)."""
    x = c.clamp(0.0, 1.0)
    return torch.where(x <= 0.0031308, 12.92 * x, 1.055 * torch.pow(x, 1.0 / 2.4) - 0.055)


def srgb_to_linear(c: torch.Tensor) -> torch.Tensor:
    """GLSL ``vec3 srgb_to_linear(vec3 c)``."""
    x = c.clamp(0.0, 1.0)
    return torch.where(x <= 0.04045, x / 12.92, torch.pow((x + 0.055) / 1.055, 2.4))


_HDR = Arg(lo=0.0, hi=20.0, components=3,
           adversarial=((0, 0, 0), (1e-8, 1e-8, 1e-8), (65504, 1, 0), (1e5, 1e5, 1e5),
                        (-1, 0.5, 2)))
# Envelopes: u = 2^-24. "first-order on the draws": per-operation error bounds (GLSL 4.60
# table on the GL side, correct rounding / 1 ulp libm on the torch side) propagated to first
# order through the function at the drawn inputs; machine-independent.
PARITY_CASES = [
    ParityCase("apply_exposure", (_HDR, Arg(lo=-8, hi=8, adversarial=(0.0, -40.0, 40.0))),
               atol=1e-6, rtol=1.1e-5, measured="max rel 3.5e-7 (seeds 0-7)",
               envelope="exp2 (3 + 2|ev|) ulp: 83 ulp = 9.9e-6 at the adversarial ev = +-40 "
                        "(19 ulp = 2.3e-6 for |ev| <= 8) + product and torch's exp2 1 ulp -> "
                        "1.05e-5 rel (rtol widened from 2e-6)"),
    ParityCase("rrt_odt_fit", (Arg(lo=0.0, hi=50.0, components=3, adversarial=((0, 0, 0),)),),
               atol=1e-6, rtol=1e-5, measured="exact on llvmpipe (seeds 0-7); nosse: 2.4e-7",
               envelope="a / b: a = v (v + 0.0246) - 9.05e-5 cancels near v = 3.6e-3 (ulps of "
                        "terms <= 1e-4 over b >= 0.238), b sums terms >= 0, / 2.5 ulp: "
                        "first-order 1.2e-6 rel, 11% of the tolerance"),
    ParityCase("tonemap_aces_fitted", (_HDR,), atol=2e-6, rtol=1e-5,
               measured="max abs 4.2e-7 (seeds 0-7)",
               envelope="input matrix (terms >= 0), rrt_odt_fit, output matrix with negative "
                        "entries (cancels, any order/FMA), clamp: first-order uses 41% of the "
                        "tolerance"),
    ParityCase("tonemap_reinhard", (_HDR,), atol=1e-7, rtol=1e-6, measured="exact",
               envelope="x / (1 + x): add + division (2.5 ulp) + torch's 2 roundings -> 4 ulp "
                        "= 4.8e-7 rel"),
    ParityCase("linear_to_srgb", (Arg(lo=0.0, hi=1.2, components=3,
                                      adversarial=((0, 0.0031308, 1), (-1, 2, 0.5))),),
               atol=2e-6, rtol=1e-5, measured="max abs 2.4e-7, rel 7.2e-7 (pow; seeds 0-7)",
               envelope="pow = exp2(log2(x) / 2.4): log2 2^-21 abs in [0.5, 1] or 3 ulp, exp2 "
                        "3 ulp, then 1.055 p - 0.055 cancels (x2.4 at the knee): first-order "
                        "5.8e-6 rel, 11% of the tolerance; the knee compare uses the input"),
    ParityCase("srgb_to_linear", (Arg(lo=0.0, hi=1.0, components=3,
                                      adversarial=((0, 0.04045, 1),)),),
               atol=2e-6, rtol=1e-5, measured="max abs 3.6e-7, rel 6.8e-7 (pow; seeds 0-7)",
               envelope="q = (x + 0.055) / 1.055 (2.5 ulp, x2.4 through the power), pow = "
                        "exp2(2.4 log2 q): log2 2^-21 abs in [0.5, 1] else 3 ulp (|log2 q| <= "
                        "4.2) x 2.4 ln 2, exp2 3 ulp: first-order 6e-6 rel, 20% of the tolerance"),
]
