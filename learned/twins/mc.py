"""Twins of ``shaders/lib/mc.glsl``: scrambled (0, 2)-sequences, hemisphere and GGX-VNDF sampling,
their pdfs, the GGX specular BRDF and MIS weights.

Integer functions run on int64 tensors holding uint32 values (products split so nothing overflows),
so the per-pixel sample sequence is bit-exact: a render's samples are a pure function of
(pixel, sample index, seed) in both languages.
"""
from __future__ import annotations

import math

import torch

from ._cases import Arg, ParityCase
from .brdf import BRDF_MIN_DENOM, d_ggx, f_schlick, v_smith_ggx_correlated
from .common import saturate, sq
from .sampling import _as_uint

_MASK32 = 0xFFFFFFFF
INV_PI = 1.0 / math.pi
_LUMA = (0.2126, 0.7152, 0.0722)


def _mul32(x: torch.Tensor, c: int) -> torch.Tensor:
    """(x * c) mod 2^32 for uint32 values in int64 without overflow."""
    lo = x * (c & 0xFFFF)
    hi = ((x * (c >> 16)) & 0xFFFF) << 16
    return (lo + hi) & _MASK32


def hash_u32(x: torch.Tensor) -> torch.Tensor:
    """GLSL ``uint hash_u32(uint x)`` (Wellons' lowbias32) on int64 tensors holding uint32."""
    x = _as_uint(x)
    x = x ^ (x >> 16)
    x = _mul32(x, 0x7FEB352D)
    x = x ^ (x >> 15)
    x = _mul32(x, 0x846CA68B)
    x = x ^ (x >> 16)
    return x


def mc_scramble(px, py, seed, dim) -> torch.Tensor:
    """GLSL ``uint mc_scramble(uint px, uint py, uint seed, uint dim)``."""
    px, py, seed, dim = (_as_uint(torch.as_tensor(t)) for t in (px, py, seed, dim))
    inner = hash_u32((dim + 0x9E3779B9) & _MASK32)
    return hash_u32(px ^ hash_u32(py ^ hash_u32(seed ^ inner)))


_SOBOL2_V = []
_v = 1 << 31
for _ in range(32):
    _SOBOL2_V.append(_v)
    _v ^= _v >> 1


def sobol2_bits(i: torch.Tensor) -> torch.Tensor:
    """GLSL ``uint sobol2_bits(uint i)``: Sobol' dimension 2 as 32 bits (Kollig & Keller 2002)."""
    i = _as_uint(i)
    r = torch.zeros_like(i)
    for k, v in enumerate(_SOBOL2_V):
        r = r ^ torch.where(((i >> k) & 1) != 0, torch.full_like(i, v), torch.zeros_like(i))
    return r


def _reverse_bits(b: torch.Tensor) -> torch.Tensor:
    b = ((b << 16) | (b >> 16)) & _MASK32
    b = ((b & 0x55555555) << 1) | ((b & 0xAAAAAAAA) >> 1)
    b = ((b & 0x33333333) << 2) | ((b & 0xCCCCCCCC) >> 2)
    b = ((b & 0x0F0F0F0F) << 4) | ((b & 0xF0F0F0F0) >> 4)
    b = ((b & 0x00FF00FF) << 8) | ((b & 0xFF00FF00) >> 8)
    return b


def sobol_2d(index, scramble_x, scramble_y) -> torch.Tensor:
    """GLSL ``vec2 sobol_2d(uint index, uint scramble_x, uint scramble_y)`` -> ``[..., 2]``."""
    i = _as_uint(torch.as_tensor(index))
    x = _reverse_bits(i) ^ _as_uint(torch.as_tensor(scramble_x))
    y = sobol2_bits(i) ^ _as_uint(torch.as_tensor(scramble_y))
    x, y = torch.broadcast_tensors(x, y)
    return torch.stack([(x >> 8).to(torch.float32), (y >> 8).to(torch.float32)], dim=-1) \
        * 5.9604644775390625e-08


def mc_sample_2d(px, py, index, seed, dim) -> torch.Tensor:
    """GLSL ``vec2 mc_sample_2d(uint px, uint py, uint index, uint seed, uint dim)``."""
    d = _as_uint(torch.as_tensor(dim))
    return sobol_2d(index, mc_scramble(px, py, seed, 2 * d), mc_scramble(px, py, seed, 2 * d + 1))


def sample_uniform_hemisphere(u: torch.Tensor) -> torch.Tensor:
    """GLSL ``vec3 sample_uniform_hemisphere(vec2 u)``: ``[..., 2]`` -> ``[..., 3]``."""
    z = u[..., 0]
    r = torch.sqrt((1.0 - z * z).clamp_min(0.0))
    phi = (2.0 * math.pi) * u[..., 1]
    return torch.stack([r * torch.cos(phi), r * torch.sin(phi), z], dim=-1)


def sample_cosine_hemisphere(u: torch.Tensor) -> torch.Tensor:
    """GLSL ``vec3 sample_cosine_hemisphere(vec2 u)``: ``[..., 2]`` -> ``[..., 3]``."""
    r = torch.sqrt(u[..., 0])
    phi = (2.0 * math.pi) * u[..., 1]
    return torch.stack([r * torch.cos(phi), r * torch.sin(phi),
                        torch.sqrt((1.0 - u[..., 0]).clamp_min(0.0))], dim=-1)


def pdf_cosine_hemisphere(NoL: torch.Tensor) -> torch.Tensor:
    """GLSL ``float pdf_cosine_hemisphere(float NoL)`` = max(NoL, 0) / pi."""
    return NoL.clamp_min(0.0) * INV_PI


def g1_smith_ggx(NoV: torch.Tensor, a: torch.Tensor) -> torch.Tensor:
    """GLSL ``float g1_smith_ggx(float NoV, float a)``."""
    NoV = saturate(NoV)
    a2 = sq(saturate(a))
    return 2.0 * NoV / (NoV + torch.sqrt(a2 + (1.0 - a2) * NoV * NoV)).clamp_min(BRDF_MIN_DENOM)


def _normalize(v: torch.Tensor) -> torch.Tensor:
    return v * torch.rsqrt((v * v).sum(-1, keepdim=True))


def sample_ggx_vndf(u: torch.Tensor, v: torch.Tensor, a: torch.Tensor) -> torch.Tensor:
    """GLSL ``vec3 sample_ggx_vndf(vec2 u, vec3 v, float a)`` (Dupuy & Benyoub 2023):
    u ``[..., 2]``, v ``[..., 3]`` (tangent space), a ``[...]`` -> unit half vector ``[..., 3]``."""
    a = saturate(a).clamp_min(1e-4)
    vh = _normalize(torch.stack([a * v[..., 0], a * v[..., 1], v[..., 2].clamp_min(0.0) + 1e-7],
                                dim=-1))
    phi = (2.0 * math.pi) * u[..., 0]
    z = (1.0 - u[..., 1]) * (1.0 + vh[..., 2]) - vh[..., 2]
    sin_theta = torch.sqrt((1.0 - z * z).clamp(0.0, 1.0))
    c = torch.stack([sin_theta * torch.cos(phi), sin_theta * torch.sin(phi), z], dim=-1)
    hh = c + vh
    h = torch.stack([a * hh[..., 0], a * hh[..., 1], hh[..., 2].clamp_min(0.0)], dim=-1)
    len2 = (h * h).sum(-1, keepdim=True)
    up = torch.zeros_like(h)
    up[..., 2] = 1.0
    return torch.where(len2 > 1e-30, h * torch.rsqrt(len2.clamp_min(1e-30)), up)


def pdf_ggx_vndf(NoV: torch.Tensor, NoH: torch.Tensor, a: torch.Tensor) -> torch.Tensor:
    """GLSL ``float pdf_ggx_vndf(float NoV, float NoH, float a)``: pdf of the reflected
    direction."""
    NoV = saturate(NoV)
    a2 = sq(saturate(a))
    denom = 2.0 * (NoV + torch.sqrt(a2 + (1.0 - a2) * NoV * NoV)).clamp_min(BRDF_MIN_DENOM)
    return torch.where(NoH > 0.0, d_ggx(NoH, a) / denom, torch.zeros_like(denom))


def ggx_specular_brdf(f0, f90, NoV, NoL, NoH, VoH, a) -> torch.Tensor:
    """GLSL ``vec3 ggx_specular_brdf(vec3 f0, float f90, float NoV, NoL, NoH, VoH, float a)``."""
    return (d_ggx(NoH, a) * v_smith_ggx_correlated(NoV, NoL, a))[..., None] \
        * f_schlick(f0, f90, VoH)


def specular_lobe_probability(diffuse, f0, f90, NoV) -> torch.Tensor:
    """GLSL ``float specular_lobe_probability(vec3 diffuse, vec3 f0, float f90, float NoV)``."""
    y = torch.tensor(_LUMA, dtype=torch.float32)
    s = (f_schlick(f0, f90, NoV) * y).sum(-1)
    d = (diffuse * y).sum(-1)
    return torch.where(s + d > 0.0, s / torch.where(s + d > 0.0, s + d, torch.ones_like(s)),
                       torch.full_like(s, 0.5))


def mis_weight(pdf_a, pdf_b, power) -> torch.Tensor:
    """GLSL ``float mis_weight(float pdf_a, float pdf_b, float power)``: power 2 -> power
    heuristic, else balance."""
    a = pdf_a.clamp_min(0.0)
    b = pdf_b.clamp_min(0.0)
    p2 = torch.as_tensor(power) > 1.5
    a = torch.where(p2, a * a, a)
    b = torch.where(p2, b * b, b)
    s = a + b
    return torch.where(s > 0.0, a / torch.where(s > 0.0, s, torch.ones_like(s)),
                       torch.zeros_like(s))


_UINT24 = Arg(kind="int", lo=0, hi=(1 << 24) - 1, adversarial=(0.0, 1.0, 16777215.0))
_SMALL = Arg(kind="int", lo=0, hi=4095, adversarial=(0.0, 4095.0))
_U2 = Arg(components=2, adversarial=((0.0, 0.0), (0.9999999, 0.9999999), (0.5, 0.0)))
_ALPHA = Arg(lo=0.0, hi=1.0, adversarial=(0.0, 1e-4, 0.002025, 1.0))
_DOT = Arg(lo=0.0, hi=1.0, adversarial=(0.0, 1e-6, 1.0))
_NOH = Arg(lo=-0.2, hi=1.0, adversarial=(-1.0, 0.0, 1e-6, 1.0))


# Envelopes: u = 2^-24. "first-order on the draws": per-operation error bounds (GLSL 4.60
# table on the GL side, correct rounding / 1 ulp libm on the torch side) propagated to first
# order through the function at the drawn inputs; machine-independent.
PARITY_CASES = [
    ParityCase("hash_u32", (_UINT24,), atol=0.0, rtol=0.0,
               measured="bit-exact (the float conversion of the uint result rounds alike)",
               envelope="exact: integer ops mod 2^32; uint -> float32 conversion correctly "
                        "rounded on both sides"),
    ParityCase("mc_scramble", (_SMALL, _SMALL, _SMALL, Arg(kind="int", lo=0, hi=16)),
               atol=0.0, rtol=0.0, measured="bit-exact", n=1024,
               envelope="exact: integer ops mod 2^32; uint -> float32 conversion correctly "
                        "rounded on both sides"),
    ParityCase("sobol2_bits", (_UINT24,), atol=0.0, rtol=0.0, measured="bit-exact",
               envelope="exact: integer ops; uint -> float32 conversion correctly rounded"),
    ParityCase("sobol_2d", (_UINT24, _UINT24, _UINT24), atol=0.0, rtol=0.0, measured="bit-exact",
               n=1024,
               envelope="exact: integer ops, 24-bit values convert exactly, x 2^-24 is exact"),
    ParityCase("mc_sample_2d", (_SMALL, _SMALL, _SMALL, _SMALL, Arg(kind="int", lo=0, hi=3)),
               atol=0.0, rtol=0.0, measured="bit-exact", n=1024,
               envelope="exact: integer ops, 24-bit values convert exactly, x 2^-24 is exact"),
    ParityCase("sample_uniform_hemisphere", (_U2,), atol=2e-6, rtol=1e-5,
               measured="max abs 1.2e-7 (seeds 0-7); nosse (x87): 6.8e-7",
               envelope="r (cos, sin) phi: trig ~1e-6 abs (assumed) + 2 pi u.y rounding 2.4e-7 "
                        "+ sqrt 5 ulp + product -> 2e-6 r; 1 - z z with FMA: z z's rounding is "
                        "<= min(2^-25, (1 - z)^2) -> <= 8e-7 in r (at 1 - z = 1.7e-4) -> 2e-6 "
                        "abs (atol widened from 1e-6); z exact"),
    ParityCase("sample_cosine_hemisphere", (_U2,), atol=2e-6, rtol=1e-5,
               measured="max abs 1.2e-7 (seeds 0-7); nosse (x87): 2.4e-7",
               envelope="r (cos, sin) phi, r = sqrt(u.x): trig ~1e-6 abs (assumed) + 2 pi u.y "
                        "rounding 2.4e-7 + sqrt 5 ulp + product -> 2e-6 abs (first-order on the "
                        "draws 1.75e-6; atol widened from 1e-6); z = sqrt(1 - u.x): 5 ulp rel"),
    ParityCase("pdf_cosine_hemisphere", (Arg(lo=-1.0, hi=1.0, adversarial=(0.0, 1.0)),),
               atol=0.0, rtol=1e-7, measured="exact",
               envelope="exact: one correctly rounded product with the same 1/pi literal"),
    ParityCase("g1_smith_ggx", (_DOT, _ALPHA), atol=1e-6, rtol=1e-5,
               measured="max abs 1.2e-7 (seeds 0-7)",
               envelope="sqrt (4.5 ulp) of a sum of terms >= 0, NoV + sqrt (no cancellation), "
                        "2 NoV / x (2.5 ulp): ~10 ulp both sides -> 1.2e-6 rel"),
    ParityCase("sample_ggx_vndf",
               (_U2, Arg(kind="hemisphere", components=3,
                         adversarial=((0.0, 0.0, 1.0), (1.0, 0.0, 0.0), (0.6, 0.8, 0.0))),
                _ALPHA),
               atol=8e-4, rtol=1e-5,
               measured="max abs 2.8e-5 (seeds 0-7) near the rim of the cap, where z = (1 - "
                        "u.y)(1 + v.z) - v.z cancels; typical 1e-7",
               envelope="h = normalize(a hh.xy, hh.z), hh = c + vh -> 0 at the cap's rim "
                        "(u.y -> 1): ulp errors of z ~ -1, 1 - z^2 and vh.z (inversesqrt 2 ulp) "
                        "move h by ~e / (a sin_theta); first-order over random draws (seeds "
                        "0-63): median 7e-5, max 7.9e-4 abs (atol widened from 1e-4; heavy "
                        "tail); NOT covered: grid u.y = 0.9999999, v = +Z, a <= 0.002 (~0.3)"),
    ParityCase("pdf_ggx_vndf", (_DOT, _NOH, _ALPHA), atol=1e-6, rtol=2e-5,
               measured="max rel 2.1e-7 (seeds 0-7; values to 1e7 at alpha 1e-4)",
               envelope="d_ggx (14 ulp) / (2 (NoV + sqrt(...))) (sqrt 4.5 ulp, / 2.5 ulp, no "
                        "cancellation): first-order 3e-6 rel; NoH > 0 compares the input"),
    ParityCase("ggx_specular_brdf",
               (Arg(components=3, adversarial=((0.04, 0.04, 0.04), (1.0, 1.0, 1.0))),
                Arg(adversarial=(0.0, 1.0)), _DOT, _DOT, _DOT, _DOT, _ALPHA),
               atol=1e-6, rtol=2e-5, measured="max rel 2.4e-7 (seeds 0-7)", n=1024,
               envelope="D (14 ulp) V (12 ulp) F (f_schlick, 24 x 2^-24 without cancellation): "
                        "first-order on the random draws <= 73% of the tolerance; NOT covered: "
                        "grid f0 = 1, f90 = 0, VoH = 1e-6, where F = 1 - x^5 cancels to 5e-6 and "
                        "D V ~1e11 make F's 1.3e-6 abs 24% (needs x..x^5 kept unrounded, as x87 "
                        "does; FMA cannot change products-only chains)"),
    ParityCase("specular_lobe_probability",
               (Arg(components=3, adversarial=((0.0, 0.0, 0.0),)),
                Arg(components=3, adversarial=((0.0, 0.0, 0.0), (1.0, 1.0, 1.0))),
                Arg(adversarial=(0.0, 1.0)), _DOT),
               atol=4e-6, rtol=1e-5, measured="max abs 1.2e-7 (seeds 0-7); nosse: 3e-7",
               envelope="s / (s + d): s = Y.F carries f_schlick's 1.3e-6 abs where f90 < f0 "
                        "cancels, so dp <= 1.3e-6 / (s + d) + 3 ulp; first-order on the draws "
                        "(seeds 0-63) 3.7e-6 abs (atol widened from 1e-6)"),
    ParityCase("mis_weight",
               (Arg(lo=0.0, hi=100.0, adversarial=(0.0, 1e-18, 1e8)),
                Arg(lo=0.0, hi=100.0, adversarial=(0.0, 1e8)),
                Arg(kind="int", lo=1, hi=2, adversarial=(1.0, 2.0))),
               atol=1e-7, rtol=1e-6, measured="exact (seeds 0-7)",
               envelope="a^2 / (a^2 + b^2) or a / (a + b), terms >= 0: 3 roundings + / 2.5 ulp "
                        "-> 7e-7 rel; tiny pdf 1e-18, not 1e-30, whose square underflows float32 "
                        "(weight 0) but not wider arithmetic (x87 nosse: 1)"),
]


# ---------------------------------------------------------------------------------------------
# the whole lighting pass (passes/shade_ggx_mc.frag), used by learned.twins.deferred.shade
# ---------------------------------------------------------------------------------------------

def _dot(a: torch.Tensor, b: torch.Tensor) -> torch.Tensor:
    return (a * b).sum(-1)


def shade_ggx_mc(n, v, g: dict, ao, env: dict, intensity: float, rotation_rad: float,
                 defines: dict, pixel: torch.Tensor, sample_start: int, sample_count: int,
                 seed: int) -> torch.Tensor:
    """Twin of ``main()`` of ``passes/shade_ggx_mc.frag`` for covered pixels: the mean of samples
    ``sample_start ..`` of each pixel. n, v ``[P, 3]`` (shading normal, towards the viewer), ``g``
    the G-buffer channels ``[P, C]``, ao ``[P]``, pixel ``[P, 2]`` int64 (GL order). ``env`` as in
    :func:`learned.twins.deferred.shade` plus ``marginal``, ``conditional``, ``pdf``.
    -> ``[P, 3]``."""
    from .brdf import clamp_perceptual_roughness, compute_f0, f90_from_f0
    from .deferred import env_dir, reflect
    from .env_sampling import env_pdf, sample_env
    from .equirect import equirect_uv, rotate_y
    from .ibl import ibl_dfg, ibl_energy_compensation, ibl_specular_dfg, sample_bilinear
    from .sampling import tangent_to_world
    from .shading import diffuse_color

    sampling = int(defines.get("SAMPLING", 4))
    power = float(defines.get("MIS_POWER", 2))
    P = n.shape[0]
    ex = torch.tensor([1.0, 0.0, 0.0]).expand(P, 3)
    ey = torch.tensor([0.0, 1.0, 0.0]).expand(P, 3)
    t = tangent_to_world(ex, n)
    b = tangent_to_world(ey, n)
    NoV = saturate(_dot(n, v))
    r = clamp_perceptual_roughness(g["roughness"][..., 0])
    a = r * r
    f0 = compute_f0(g["albedo"], g["metallic"][..., 0], g["specular"][..., 0])
    f90 = f90_from_f0(f0)
    dfg = ibl_dfg(env["dfg"], NoV, r)
    if defines.get("MULTISCATTER", 1):
        spec_scale = ibl_energy_compensation(dfg, f0)
    else:
        spec_scale = torch.ones_like(f0)
    e_spec = ibl_specular_dfg(dfg, f0, f90) * spec_scale
    diffuse = diffuse_color(g["albedo"], g["metallic"][..., 0]) * (1.0 - e_spec).clamp_min(0.0)
    p_spec = specular_lobe_probability(diffuse, f0, f90, NoV)
    diffuse = diffuse * ao[..., None]
    level0 = env["radiance"][0]

    def radiance(l):
        return sample_bilinear(level0, equirect_uv(env_dir(l, rotation_rad)))[..., :3] * intensity

    def brdf_cos(l):
        NoL = _dot(n, l)
        h = v + l
        h = h * torch.rsqrt((h * h).sum(-1, keepdim=True))
        NoH = saturate(_dot(n, h))
        VoH = saturate(_dot(v, h))
        spec = ggx_specular_brdf(f0, f90, NoV, NoL, NoH, VoH, a) * spec_scale
        out = (diffuse * INV_PI + spec) * NoL[..., None]
        return torch.where((NoL > 0.0)[..., None], out, torch.zeros_like(out))

    def brdf_pdf(l):
        NoL = _dot(n, l)
        h = v + l
        h = h * torch.rsqrt((h * h).sum(-1, keepdim=True))
        NoH = saturate(_dot(n, h))
        p = p_spec * pdf_ggx_vndf(NoV, NoH, a) + (1.0 - p_spec) * pdf_cosine_hemisphere(NoL)
        return torch.where(NoL > 0.0, p, torch.zeros_like(p))

    def sample_brdf(u):
        spec = u[..., 0] < p_spec
        us = torch.stack([u[..., 0] / torch.where(spec, p_spec, torch.ones_like(p_spec)),
                          u[..., 1]], dim=-1)
        v_t = torch.stack([_dot(v, t), _dot(v, b), NoV], dim=-1)
        h = tangent_to_world(sample_ggx_vndf(us, v_t, a), n)
        l_spec = reflect(-v, h)
        one_minus = 1.0 - p_spec
        ud = torch.stack([(u[..., 0] - p_spec) / torch.where(spec, torch.ones_like(p_spec),
                                                              one_minus), u[..., 1]], dim=-1)
        l_diff = tangent_to_world(sample_cosine_hemisphere(ud.clamp(0.0, 1.0)), n)
        return torch.where(spec[..., None], l_spec, l_diff)

    def env_sample(u):
        e = sample_env(env["marginal"], env["conditional"], env["pdf"], u)
        l = rotate_y(e[..., :3], torch.full(e.shape[:-1], rotation_rad, dtype=e.dtype))
        return l, e[..., 3]

    def weighted(l, pdf, w=None):
        c = radiance(l) * brdf_cos(l)
        scale = torch.where(pdf > 0.0, (w if w is not None else 1.0)
                            / torch.where(pdf > 0.0, pdf, torch.ones_like(pdf)),
                            torch.zeros_like(pdf))
        return c * scale[..., None]

    total = torch.zeros(P, 3)
    px, py = pixel[:, 0], pixel[:, 1]
    for k in range(sample_count):
        index = torch.full((P,), sample_start + k, dtype=torch.int64)
        u0 = mc_sample_2d(px, py, index, seed, 0)
        if sampling in (0, 1):
            if sampling == 0:
                l = tangent_to_world(sample_uniform_hemisphere(u0), n)
                pdf = torch.full((P,), 0.5 * INV_PI)
            else:
                l = tangent_to_world(sample_cosine_hemisphere(u0), n)
                pdf = pdf_cosine_hemisphere(_dot(n, l))
            c = weighted(l, pdf)
        elif sampling == 2:
            l, pdf = env_sample(u0)
            c = weighted(l, pdf)
        elif sampling == 3:
            l = sample_brdf(u0)
            c = weighted(l, brdf_pdf(l))
        else:
            lb = sample_brdf(u0)
            pb = brdf_pdf(lb)
            c = weighted(lb, pb, mis_weight(pb, env_pdf(env["pdf"], env_dir(lb, rotation_rad)),
                                            power))
            le, pe = env_sample(mc_sample_2d(px, py, index, seed, 1))
            c = c + weighted(le, pe, mis_weight(pe, brdf_pdf(le), power))
        c = torch.where(torch.isfinite(c).all(-1, keepdim=True), c, torch.zeros_like(c))
        total = total + c
    return total / float(max(sample_count, 1))
