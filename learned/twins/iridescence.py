"""Twins of ``shaders/lib/iridescence.glsl``: KHR_materials_iridescence's thin-film Fresnel
(Belcour & Barla 2017, the glTF specification's form). Scalars ``[...]``, ``vec3``
``[..., 3]``."""
from __future__ import annotations

import math

import torch

from .brdf import f_schlick
from .common import PI, saturate, sq

IRIDESCENCE_FILM_RAMP_NM = 30.0
TWO_PI = 2.0 * math.pi
# the spec's Gaussian fit of the CIE 1931 XYZ sensitivities' Fourier transform
_VAL = (5.4856e-13, 4.4201e-13, 5.2481e-13)
_POS = (1.6810e+06, 1.7953e+06, 2.2084e+06)
_VAR = (4.3278e+09, 9.3046e+09, 6.6121e+09)
# linear Rec.709 from XYZ, rows (the GLSL mat3 is given column by column)
XYZ_TO_REC709 = ((3.2404542, -1.5371385, -0.4985314),
                 (-0.9692660, 1.8760108, 0.0415560),
                 (0.0556434, -0.2040259, 1.0572252))


def _mix(x, y, t):
    return x * (1.0 - t) + y * t


def ior_to_fresnel0(n_t: torch.Tensor, n_i: torch.Tensor) -> torch.Tensor:
    """GLSL ``vec3 ior_to_fresnel0(vec3 n_t, float n_i)``: ((n_t - n_i) / (n_t + n_i))^2."""
    r = (n_t - n_i[..., None]) / (n_t + n_i[..., None])
    return r * r


def fresnel0_to_ior(f0: torch.Tensor) -> torch.Tensor:
    """GLSL ``vec3 fresnel0_to_ior(vec3 f0)``: (1 + sqrt f0) / (1 - sqrt f0) as
    (1 + sqrt f0)^2 / (1 - f0), f0 <= 0.9999."""
    f = f0.clamp(0.0, 0.9999)
    s1 = 1.0 + torch.sqrt(f)
    return s1 * s1 / (1.0 - f)


def _smoothstep(e0: float, e1: float, x: torch.Tensor) -> torch.Tensor:
    t = ((x - e0) / (e1 - e0)).clamp(0.0, 1.0)
    return t * t * (3.0 - 2.0 * t)


def iridescence_film_ior(eta1: torch.Tensor, eta2: torch.Tensor,
                         thickness_nm: torch.Tensor) -> torch.Tensor:
    """GLSL ``float iridescence_film_ior(float eta1, float eta2, float thickness_nm)``."""
    return _mix(eta1, eta2, _smoothstep(0.0, IRIDESCENCE_FILM_RAMP_NM, thickness_nm))


def iridescence_sensitivity(opd: torch.Tensor, shift: torch.Tensor) -> torch.Tensor:
    """GLSL ``vec3 iridescence_sensitivity(float opd, vec3 shift)``: opd ``[...]`` (nm),
    shift ``[..., 3]`` -> linear Rec.709 ``[..., 3]``."""
    phase = (TWO_PI * opd * 1.0e-9)[..., None]
    val, pos, var = (torch.tensor(c, dtype=opd.dtype) for c in (_VAL, _POS, _VAR))
    xyz = val * torch.sqrt(TWO_PI * var) * torch.cos(pos * phase + shift) \
        * torch.exp(-phase * phase * var)
    extra = 9.7470e-14 * math.sqrt(TWO_PI * 4.5282e+09) \
        * torch.cos(2.2399e+06 * phase[..., 0] + shift[..., 0]) \
        * torch.exp(-4.5282e+09 * phase[..., 0] * phase[..., 0])
    xyz = torch.cat([xyz[..., :1] + extra[..., None], xyz[..., 1:]], -1) / 1.0685e-7
    m = torch.tensor(XYZ_TO_REC709, dtype=opd.dtype)
    return xyz @ m.T


def iridescence_fresnel(outside_ior: torch.Tensor, film_ior: torch.Tensor,
                        cos_theta1: torch.Tensor, thickness_nm: torch.Tensor,
                        base_f0: torch.Tensor) -> torch.Tensor:
    """GLSL ``vec3 iridescence_fresnel(float outside_ior, float film_ior, float cos_theta1,
    float thickness_nm, vec3 base_f0)`` (Belcour & Barla 2017, the spec's evalIridescence)."""
    c1 = saturate(cos_theta1)
    eta2 = iridescence_film_ior(outside_ior, film_ior, thickness_nm)
    cos2_theta2 = 1.0 - sq(outside_ior / eta2) * (1.0 - c1 * c1)
    tir = cos2_theta2 < 0.0
    c2 = torch.sqrt(cos2_theta2.clamp_min(0.0))
    r0 = ior_to_fresnel0(eta2[..., None], outside_ior)[..., 0]
    r12 = f_schlick(r0[..., None], torch.ones_like(c1), c1)[..., 0]
    t121 = 1.0 - r12
    phi12 = torch.where(eta2 < outside_ior, torch.full_like(eta2, PI), torch.zeros_like(eta2))
    phi21 = PI - phi12
    base_ior = fresnel0_to_ior(base_f0)
    r1 = ior_to_fresnel0(base_ior, eta2)
    r23 = f_schlick(r1, torch.ones_like(c2), c2)
    phi23 = torch.where(base_ior < eta2[..., None], torch.full_like(base_ior, PI),
                        torch.zeros_like(base_ior))
    opd = 2.0 * eta2 * thickness_nm * c2
    phi = phi21[..., None] + phi23
    r123 = (r12[..., None] * r23).clamp(1e-5, 0.9999)
    r123_sqrt = torch.sqrt(r123)
    rs = sq(t121)[..., None] * r23 / (1.0 - r123)
    i = r12[..., None] + rs
    cm = rs - t121[..., None]
    for m in (1, 2):
        cm = cm * r123_sqrt
        i = i + cm * 2.0 * iridescence_sensitivity(float(m) * opd, float(m) * phi)
    return torch.where(tir[..., None], torch.ones_like(i), i.clamp(0.0, 1.0))


def schlick_to_f0(f: torch.Tensor, f90: torch.Tensor, c: torch.Tensor) -> torch.Tensor:
    """GLSL ``vec3 schlick_to_f0(vec3 f, float f90, float c)``."""
    x = 1.0 - saturate(c)
    x2 = x * x
    x5 = x2 * x2 * x
    return ((f - (f90 * x5)[..., None]) / (1.0 - x5).clamp_min(1e-4)[..., None]).clamp(0.0, 1.0)


IRIDESCENCE_COAT_IOR = 1.5


def iridescence_outside_ior(clearcoat: torch.Tensor) -> torch.Tensor:
    """GLSL ``float iridescence_outside_ior(float clearcoat)``: mix(1, 1.5, clearcoat)."""
    return _mix(torch.ones_like(clearcoat), torch.full_like(clearcoat, IRIDESCENCE_COAT_IOR),
                saturate(clearcoat))


def iridescence_fresnel_mix(f0: torch.Tensor, f90: torch.Tensor, VoH: torch.Tensor,
                            iridescence: torch.Tensor, outside_ior: torch.Tensor) -> torch.Tensor:
    """GLSL ``vec3 iridescence_fresnel_mix(vec3 f0, float f90, float VoH, vec3 iridescence,
    float outside_ior)`` (iridescence: factor, thickness nm, film IOR)."""
    f = f_schlick(f0, f90, VoH)
    factor = iridescence[..., 0]
    film = iridescence_fresnel(outside_ior, iridescence[..., 2], VoH,
                               iridescence[..., 1], f0)
    mixed = _mix(f, film, saturate(factor)[..., None])
    return torch.where(((factor > 0.0) & (iridescence[..., 1] > 0.0))[..., None], mixed, f)


def iridescence_f0(f0: torch.Tensor, f90: torch.Tensor, NoV: torch.Tensor,
                   iridescence: torch.Tensor, outside_ior: torch.Tensor) -> torch.Tensor:
    """GLSL ``vec3 iridescence_f0(vec3 f0, float f90, float NoV, vec3 iridescence,
    float outside_ior)``."""
    factor = iridescence[..., 0]
    film = iridescence_fresnel(outside_ior, iridescence[..., 2], NoV,
                               iridescence[..., 1], f0)
    mixed = _mix(f0, schlick_to_f0(film, f90, NoV), saturate(factor)[..., None])
    return torch.where(((factor > 0.0) & (iridescence[..., 1] > 0.0))[..., None], mixed, f0)


IRIDESCENCE_ALBEDO_NODES = 32


def iridescence_albedo_delta(f0: torch.Tensor, f90: torch.Tensor, NoV: torch.Tensor,
                             a: torch.Tensor, iridescence: torch.Tensor,
                             outside_ior: torch.Tensor) -> torch.Tensor:
    """GLSL ``vec3 iridescence_albedo_delta(vec3 f0, float f90, float NoV, float a,
    vec3 iridescence, float outside_ior)``: f0 ``[..., 3]``, iridescence ``[..., 3]`` ->
    ``[..., 3]``."""
    from .brdf import v_smith_ggx_correlated

    c = saturate(NoV)
    a = a.clamp(1e-4, 1.0)
    a2 = a * a
    vx = torch.sqrt((1.0 - c * c).clamp_min(0.0))
    inv = torch.rsqrt(a2 * vx * vx + sq(c + 1e-7))
    vh_x, vh_y = a * vx * inv, (c + 1e-7) * inv
    lam = 2.0 * (c + torch.sqrt(a2 + (1.0 - a2) * c * c))
    total = torch.zeros_like(f0)
    for k in range(IRIDESCENCE_ALBEDO_NODES):
        phi = torch.tensor(TWO_PI * (k + 0.5) / IRIDESCENCE_ALBEDO_NODES, dtype=c.dtype)
        u1 = torch.tensor(k, dtype=torch.float32) * torch.tensor(0.6180339887498949,
                                                                  dtype=torch.float32)
        u1 = (u1 - torch.floor(u1)).to(c.dtype)
        z = (1.0 - u1) * (1.0 + vh_y) - vh_y
        sin_t = torch.sqrt((1.0 - z * z).clamp(0.0, 1.0))
        hx, hy, hz = a * (sin_t * torch.cos(phi) + vh_x), a * sin_t * torch.sin(phi), \
            (z + vh_y).clamp_min(0.0)
        n = torch.rsqrt((hx * hx + hy * hy + hz * hz).clamp_min(1e-30))
        hx, hz = hx * n, hz * n
        VoH = vx * hx + c * hz
        NoL = 2.0 * VoH * hz - c
        w = torch.where(NoL > 0.0, v_smith_ggx_correlated(c, NoL, a) * NoL * lam,
                        torch.zeros_like(NoL))
        film = iridescence_fresnel(outside_ior, iridescence[..., 2], VoH,
                                   iridescence[..., 1], f0)
        total = total + (film - f_schlick(f0, f90, VoH)) * w[..., None]
    factor = iridescence[..., 0]
    out = total * (saturate(factor) / IRIDESCENCE_ALBEDO_NODES)[..., None]
    return torch.where(((factor > 0.0) & (iridescence[..., 1] > 0.0))[..., None], out,
                       torch.zeros_like(out))
