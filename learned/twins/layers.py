"""Twins of ``shaders/lib/layers.glsl``: material layers over the base BRDF (KHR_materials_clearcoat,
KHR_materials_sheen) and the octahedral normal encoding. Scalars ``[...]``, ``vec3`` ``[..., 3]``."""
from __future__ import annotations

import functools
import math
import re

import torch

from shaders import SHADER_ROOT

from .brdf import d_ggx, v_smith_ggx_correlated
from .common import INV_PI, half_vector, saturate, sq

CLEARCOAT_F0 = 0.04
SHEEN_MIN_ROUGHNESS = 0.07
SHEEN_MIN_COS = 1e-4


@functools.lru_cache(maxsize=2)  # one entry per value of normalization
def sheen_table(normalization: bool = False) -> torch.Tensor:
    """``SHEEN_ALBEDO_TABLE`` of ``shaders/lib/sheen_table.glsl``, float32 ``[size * size]``
    (with ``normalization``: ``SHEEN_NORMALIZATION`` ``[size]``)."""
    text = (SHADER_ROOT / "lib" / "sheen_table.glsl").read_text().split("float[](")
    body = text[2 if normalization else 1].split(")", 1)[0]
    return torch.tensor([float(x) for x in re.findall(r"-?\d+\.\d+(?:e-?\d+)?", body)],
                        dtype=torch.float32)


def sheen_normalization(r: torch.Tensor) -> torch.Tensor:
    """GLSL ``float sheen_normalization(float r)``: N(r), linear in the table's r samples."""
    norm = sheen_table(True)
    n = norm.numel()
    y = (r.clamp(SHEEN_MIN_ROUGHNESS, 1.0) - SHEEN_MIN_ROUGHNESS) / (1.0 - SHEEN_MIN_ROUGHNESS) \
        * float(n - 1)
    j = y.to(torch.int64).clamp_max(n - 2)
    return _mix(norm[j], norm[j + 1], y - j.to(y.dtype))


def d_charlie(NoH: torch.Tensor, a: torch.Tensor) -> torch.Tensor:
    """GLSL ``float d_charlie(float NoH, float a)`` (Estevez & Kulla 2017)."""
    inv_a = 1.0 / a
    sin2h = (1.0 - NoH * NoH).clamp_min(0.0)
    return (2.0 + inv_a) * torch.pow(sin2h, 0.5 * inv_a) * (0.5 * INV_PI)


def _mix(x, y, t):
    return x * (1.0 - t) + y * t


def sheen_lambda_fit(x: torch.Tensor, a: torch.Tensor) -> torch.Tensor:
    """GLSL ``float sheen_lambda_fit(float x, float a)``: the spec's l(x, alphaG)."""
    t = sq(1.0 - a)
    ca, cb, cc = _mix(21.5473, 25.3245, t), _mix(3.82987, 3.32435, t), _mix(0.19823, 0.16801, t)
    cd, ce = _mix(-1.97760, -1.27393, t), _mix(-4.32054, -4.85967, t)
    return ca / (1.0 + cb * torch.pow(x, cc)) + cd * x + ce


def sheen_lambda(cos_theta: torch.Tensor, a: torch.Tensor) -> torch.Tensor:
    """GLSL ``float sheen_lambda(float cos_theta, float a)``."""
    c = cos_theta.abs()
    half = torch.full_like(c, 0.5)
    return torch.where(c < 0.5, torch.exp(sheen_lambda_fit(c, a)),
                       torch.exp(2.0 * sheen_lambda_fit(half, a) - sheen_lambda_fit(1.0 - c, a)))


def v_charlie(NoV: torch.Tensor, NoL: torch.Tensor, a: torch.Tensor) -> torch.Tensor:
    """GLSL ``float v_charlie(float NoV, float NoL, float a)``: clamped at 1."""
    NoV, NoL = NoV.clamp(SHEEN_MIN_COS, 1.0), NoL.clamp(SHEEN_MIN_COS, 1.0)
    return (1.0 / ((1.0 + sheen_lambda(NoV, a) + sheen_lambda(NoL, a)) * (4.0 * NoV * NoL))
            ).clamp_max(1.0)


def sheen_albedo(NoV: torch.Tensor, r: torch.Tensor) -> torch.Tensor:
    """GLSL ``float sheen_albedo(float NoV, float r)``: bilinear in the table."""
    table = sheen_table()
    n = int(round(math.sqrt(table.numel())))
    x = torch.sqrt(saturate(NoV)) * float(n - 1)
    y = (r.clamp(SHEEN_MIN_ROUGHNESS, 1.0) - SHEEN_MIN_ROUGHNESS) / (1.0 - SHEEN_MIN_ROUGHNESS) \
        * float(n - 1)
    i = x.to(torch.int64).clamp_max(n - 2)
    j = y.to(torch.int64).clamp_max(n - 2)
    fx, fy = x - i.to(x.dtype), y - j.to(y.dtype)
    k = j * n + i
    lo = _mix(table[k], table[k + 1], fx)
    hi = _mix(table[k + n], table[k + n + 1], fx)
    return _mix(lo, hi, fy)


def sheen_scaling(color: torch.Tensor, e_v: torch.Tensor, e_l: torch.Tensor) -> torch.Tensor:
    """GLSL ``float sheen_scaling(vec3 color, float e_v, float e_l)``: 1 - max3(C) max(e_v, e_l)."""
    return 1.0 - color.amax(-1) * torch.maximum(e_v, e_l)


def sheen_split_sum(color: torch.Tensor, e: torch.Tensor, prefiltered: torch.Tensor
                    ) -> torch.Tensor:
    """GLSL ``vec3 sheen_split_sum(vec3 color, float e, vec3 prefiltered)``: C E P."""
    return color * e[..., None] * prefiltered


def sheen_light(color: torch.Tensor, r: torch.Tensor, n: torch.Tensor, v: torch.Tensor,
                l: torch.Tensor) -> torch.Tensor:
    """GLSL ``vec3 sheen_light(vec3 color, float r, vec3 n, vec3 v, vec3 l)``: C D V n.l, 0 where
    n.l <= 0."""
    NoL = (n * l).sum(-1)
    a = sq(r.clamp(SHEEN_MIN_ROUGHNESS, 1.0))
    h = half_vector(v, l)
    out = color * (d_charlie(saturate((n * h).sum(-1)), a)
                   * v_charlie(saturate((n * v).sum(-1)), NoL, a) * NoL
                   / sheen_normalization(r))[..., None]
    return torch.where((NoL > 0.0)[..., None], out, torch.zeros_like(out))


def clearcoat_weight(clearcoat: torch.Tensor, NoV: torch.Tensor) -> torch.Tensor:
    """GLSL ``float clearcoat_weight(float clearcoat, float NoV)``: c F_c(n_c.v), Schlick with
    F0 = 0.04."""
    x = 1.0 - saturate(NoV)
    x2 = x * x
    return saturate(clearcoat) * (CLEARCOAT_F0 + (1.0 - CLEARCOAT_F0) * (x2 * x2 * x))


def clearcoat_split_sum(w: torch.Tensor, dfg: torch.Tensor, prefiltered: torch.Tensor
                        ) -> torch.Tensor:
    """GLSL ``vec3 clearcoat_split_sum(float w, vec2 dfg, vec3 prefiltered)``: w dfg.y P."""
    return (w * dfg[..., 1])[..., None] * prefiltered


def clearcoat_light(w: torch.Tensor, a: torch.Tensor, n: torch.Tensor, v: torch.Tensor,
                    l: torch.Tensor) -> torch.Tensor:
    """GLSL ``float clearcoat_light(float w, float a, vec3 n, vec3 v, vec3 l)``: w D V n.l, 0
    where n.l <= 0."""
    NoL = (n * l).sum(-1)
    h = half_vector(v, l)
    NoV = saturate((n * v).sum(-1))
    out = w * d_ggx(saturate((n * h).sum(-1)), a) * v_smith_ggx_correlated(NoV, NoL, a) * NoL
    return torch.where(NoL > 0.0, out, torch.zeros_like(out))


def _sign_not_neg(x: torch.Tensor) -> torch.Tensor:
    return torch.where(x >= 0.0, torch.ones_like(x), -torch.ones_like(x))


def oct_encode(n: torch.Tensor) -> torch.Tensor:
    """GLSL ``vec2 oct_encode(vec3 n)`` (Cigolle et al. 2014). [..., 3] -> [..., 2]."""
    a = n.abs()
    p = n[..., :2] / (a[..., 0] + a[..., 1] + a[..., 2]).clamp_min(1e-30)[..., None]
    folded = (1.0 - p.flip(-1).abs()) * _sign_not_neg(p)
    return torch.where((n[..., 2] < 0.0)[..., None], folded, p)


def oct_decode(e: torch.Tensor) -> torch.Tensor:
    """GLSL ``vec3 oct_decode(vec2 e)``: the unit vector. [..., 2] -> [..., 3]."""
    z = 1.0 - e[..., 0].abs() - e[..., 1].abs()
    folded = (1.0 - e.flip(-1).abs()) * _sign_not_neg(e)
    xy = torch.where((z < 0.0)[..., None], folded, e)
    n = torch.cat([xy, z[..., None]], -1)
    return n / torch.linalg.vector_norm(n, dim=-1, keepdim=True)
