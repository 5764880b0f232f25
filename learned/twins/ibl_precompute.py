"""Twins of the IBL precompute passes (``shaders/passes/ibl_*.comp``): the radiance chain's
downsampling, the GGX prefilter by filtered importance sampling (``IBLOptions.prefilter_method =
"fis"``) with its GPU error envelope, the composition of a convolved level with the sun
(``ibl_compose.comp``, the ``"convolution"`` method), the SH projection and the DFG / dominant
direction LUTs. They use the same Hammersley sequences and the same operation order as the passes.
"""
from __future__ import annotations

import math

import torch

from .brdf import f_schlick, v_smith_ggx_correlated
from .equirect import equirect_dir, equirect_uv
from .filtering import (
    DIRECTION_ABS_ERROR,
    FILTER_WEIGHT_BITS,
    equirect_uv_error,
    sample_bilinear,
    sample_trilinear,
    sample_trilinear_envelope,
)
from .sampling import (
    ggx_sample_d,
    hammersley_sequence,
    importance_sample_ggx,
    tangent_to_world,
)
from .sh import sh_basis_all

# ---------------------------------------------------------------------------------------------
# Precompute passes
# ---------------------------------------------------------------------------------------------

def downsample_box(src: torch.Tensor) -> torch.Tensor:
    """Twin of ``passes/ibl_downsample.comp``: ``[h, w, C]`` -> ``[max(h/2,1), max(w/2,1), C]``,
    the 2x2 mean with each source row weighted by its texel solid angle (sin of the row centre's
    polar angle)."""
    h, w = src.shape[:2]
    ho, wo = max(1, h // 2), max(1, w // 2)
    ys = torch.arange(ho)
    xs = torch.arange(wo)
    y0, y1 = (2 * ys).clamp(max=h - 1), (2 * ys + 1).clamp(max=h - 1)
    x0, x1 = (2 * xs).clamp(max=w - 1), (2 * xs + 1).clamp(max=w - 1)
    a = src[y0][:, x0]
    b = src[y0][:, x1]
    c = src[y1][:, x0]
    d = src[y1][:, x1]
    inv_h = torch.tensor(1.0, dtype=torch.float32) / float(h)
    w0 = torch.sin(math.pi * ((y0.to(torch.float32) + 0.5) * inv_h))[:, None, None]
    w1 = torch.sin(math.pi * ((y1.to(torch.float32) + 0.5) * inv_h))[:, None, None]
    return ((a + b) * w0 + (c + d) * w1) * (0.5 / (w0 + w1))


def radiance_chain(env: torch.Tensor) -> list[torch.Tensor]:
    """The full box mip chain of ``env [H, W, C]`` down to 1x1 (what ``build_ibl`` uploads)."""
    chain = [env]
    while chain[-1].shape[:2] != (1, 1):
        chain.append(downsample_box(chain[-1]))
    return chain


def _texel_dirs(h: int, w: int) -> tuple[torch.Tensor, torch.Tensor]:
    """Texel-centre uv ``[h, w, 2]`` and directions ``[h, w, 3]`` (float32, as the passes)."""
    ys, xs = torch.meshgrid(torch.arange(h, dtype=torch.float32),
                            torch.arange(w, dtype=torch.float32), indexing="ij")
    uv = torch.stack([(xs + 0.5) / w, (ys + 0.5) / h], dim=-1)
    return uv, equirect_dir(uv)


def _dot(a: torch.Tensor, b: torch.Tensor) -> torch.Tensor:
    return a[..., 0] * b[..., 0] + a[..., 1] * b[..., 1] + a[..., 2] * b[..., 2]


def prefilter_level(chain: list[torch.Tensor], size: tuple[int, int], perceptual_roughness: float,
                    samples: int, weight_bits: int | None = None,
                    uv_offset: torch.Tensor | None = None) -> torch.Tensor:
    """Twin of one dispatch of ``passes/ibl_prefilter.comp``: a ``[h, w, C]`` prefiltered level.
    ``weight_bits`` and ``uv_offset`` (added to every lookup's uv) emulate a GPU's texture unit
    and trigonometry, to test :func:`prefilter_level_envelope` against them."""
    h, w = size
    h0, w0 = chain[0].shape[:2]
    omega_p = torch.tensor(4.0 * math.pi / (w0 * h0), dtype=torch.float32)
    max_lod = float(len(chain) - 1)
    _, n = _texel_dirs(h, w)
    n = n[:, :, None, :]  # [h, w, 1, 3]
    r = torch.tensor(perceptual_roughness, dtype=torch.float32)
    a = r * r
    xi = hammersley_sequence(samples)  # [S, 2]
    inv_samples = torch.tensor(1.0, dtype=torch.float32) / float(samples)
    hv = tangent_to_world(importance_sample_ggx(xi, a).expand(h, w, samples, 3),
                          n.expand(h, w, samples, 3))
    NoH = _dot(n, hv)
    l = 2.0 * NoH[..., None] * hv - n
    NoL = _dot(n, l)
    keep = NoL > 0.0
    pdf = ggx_sample_d(xi, a) * 0.25  # [S], from xi as the pass (not from NoH)
    omega_s = inv_samples / pdf.clamp_min(1e-30)
    lod = (0.5 * torch.log2(omega_s / omega_p)).clamp(0.0, max_lod)  # no +1 bias (the pass)
    uv = equirect_uv(l) if uv_offset is None else equirect_uv(l) + uv_offset
    rad = sample_trilinear(chain, uv, lod, weight_bits=weight_bits)  # [h, w, S, C]
    wgt = torch.where(keep, NoL, 0.0)
    total = (rad * wgt[..., None]).sum(dim=2)
    return total / wgt.sum(dim=2).clamp_min(1e-30)[..., None]


def prefilter_level_envelope(chain: list[torch.Tensor], size: tuple[int, int],
                             perceptual_roughness: float, samples: int,
                             weight_bits: int = FILTER_WEIGHT_BITS) -> torch.Tensor:
    """Bound ``[h, w, C]`` on |GPU - :func:`prefilter_level`|: the n.l-weighted mean of each
    sample's :func:`sample_trilinear_envelope` (the weights themselves are well conditioned: an
    ulp each), plus float32 summation of ``samples`` terms (2 S ulp of the result)."""
    h, w = size
    h0, w0 = chain[0].shape[:2]
    omega_p = torch.tensor(4.0 * math.pi / (w0 * h0), dtype=torch.float32)
    _, n = _texel_dirs(h, w)
    n = n[:, :, None, :]
    a = torch.tensor(perceptual_roughness, dtype=torch.float32) ** 2
    xi = hammersley_sequence(samples)
    hv = tangent_to_world(importance_sample_ggx(xi, a).expand(h, w, samples, 3),
                          n.expand(h, w, samples, 3))
    NoH = _dot(n, hv)
    l = 2.0 * NoH[..., None] * hv - n
    NoL = _dot(n, l)
    pdf = ggx_sample_d(xi, a) * 0.25
    omega_s = (1.0 / float(samples)) / pdf.clamp_min(1e-30)
    lod = (0.5 * torch.log2(omega_s / omega_p)).clamp(0.0, float(len(chain) - 1))
    # l = 2 (n.h) h - n: direction errors of n and h (sin/cos) add up to ~3x theirs
    err = sample_trilinear_envelope(chain, equirect_uv(l), lod,
                                    equirect_uv_error(l, 3.0 * DIRECTION_ABS_ERROR),
                                    weight_bits=weight_bits)
    wgt = torch.where(NoL > 0.0, NoL, 0.0)
    total = wgt.sum(dim=2).clamp_min(1e-30)[..., None]
    rad = sample_trilinear(chain, equirect_uv(l), lod)
    mean = (rad * wgt[..., None]).sum(dim=2) / total
    return (err * wgt[..., None]).sum(dim=2) / total + 2.0 * samples * 2.0 ** -24 * mean.abs()


def prefilter_environment(chain: list[torch.Tensor], roughness: list[float],
                          samples: list[int]) -> list[torch.Tensor]:
    """Twin of the prefiltered chain of ``build_ibl``: level 0 = ``chain[0]``, level k >= 1 = GGX
    prefiltered at perceptual roughness ``roughness[k]`` with ``samples[k]`` Hammersley points
    (the pass's uniforms: the renderer uses ``viewer.environment.ibl.prefilter_roughness(k, levels)`` and
    ``viewer.environment.ibl.prefilter_samples(k, options.prefilter_samples)``)."""
    out = [chain[0]]
    for k in range(1, len(roughness)):
        out.append(prefilter_level(chain, tuple(chain[k].shape[:2]), roughness[k], samples[k]))
    return out


def texel_solid_angle(h: int, w: int) -> torch.Tensor:
    """Exact solid angle ``[h]`` of one texel in each equirect row (float32, as ``ibl_sh.comp``)."""
    v = (torch.arange(h, dtype=torch.float32) + 0.5) / h
    return (2.0 * math.pi / w) * 2.0 * torch.sin(math.pi * v) * math.sin(0.5 * math.pi / h)


def sh_project(env: torch.Tensor) -> torch.Tensor:
    """Twin of ``passes/ibl_sh.comp`` + the float64 reduction: ``[H, W, 3]`` -> ``[9, 3]``
    radiance SH coefficients (float64)."""
    h, w = env.shape[:2]
    _, n = _texel_dirs(h, w)
    weighted = env[..., :3].to(torch.float32) * texel_solid_angle(h, w)[:, None, None]
    basis = sh_basis_all(n)  # [h, w, 9]
    return (weighted[:, :, None, :] * basis[..., None]).to(torch.float64).sum(dim=(0, 1))


def _lut_lobe_samples(size: int, samples: int, max_NoV: float = 1.0):
    """The GGX samples both outputs of ``passes/ibl_dfg.comp`` integrate over, per texel of a
    ``[size (roughness), size (n.v)]`` grid (n.v clamped to [1e-4, ``max_NoV``]): NoV and
    sin(theta_v) ``[size, size]``, the reflected directions l ``[size, size, S, 3]``, their
    weights G = V 4 (v.h) (n.l) / (n.h) and v.h ``[size, size, S]``, and where n.l > 0."""
    c = torch.arange(size, dtype=torch.float32) / float(size - 1)
    r, NoV = torch.meshgrid(c, c.clamp_min(1e-4).clamp_max(max_NoV), indexing="ij")
    a = (r * r)[..., None]
    NoV = NoV[..., None]
    sin_t = torch.sqrt((1.0 - NoV * NoV).clamp_min(0.0))
    v = torch.stack([sin_t, torch.zeros_like(NoV), NoV], dim=-1)  # [size, size, 1, 3]
    xi = hammersley_sequence(samples)
    hv = importance_sample_ggx(xi, a)  # [size, size, S, 3]
    VoH = _dot(v, hv)
    l = 2.0 * VoH[..., None] * hv - v
    NoL = l[..., 2]
    g = v_smith_ggx_correlated(NoV, NoL, a) * 4.0 * VoH.clamp_min(0.0) * NoL \
        / hv[..., 2].clamp_min(1e-30)
    return NoV[..., 0], sin_t[..., 0], l, g, VoH, NoL > 0.0


def dfg_lut(size: int, samples: int) -> torch.Tensor:
    """Twin of ``passes/ibl_dfg.comp``: ``[size (roughness), size (n.v), 2]`` float32."""
    _, _, _, g, VoH, keep = _lut_lobe_samples(size, samples)
    fc = f_schlick(torch.zeros(1, dtype=torch.float32), torch.ones_like(VoH), VoH)[..., 0]
    gx = torch.where(keep, g * fc, 0.0).sum(dim=-1)
    gy = torch.where(keep, g, 0.0).sum(dim=-1)
    gx = gx / float(max(samples, 1))
    gy = (gy / float(max(samples, 1))).clamp_max(1.0)
    return torch.stack([torch.minimum(gx, gy), gy], dim=-1)


def dominant_lut(size: int, samples: int) -> torch.Tensor:
    """Twin of ``passes/ibl_dfg.comp``'s second output: ``[size (roughness), size (n.v), 1]``
    float32, the lerp factor t of the f (n.l) lobe's mean direction m = sum G l (see the pass):
    t = m.x / (m.x (1 - n.v) - sin(theta_v) m.z) at n.v <= 0.999, clamped to [0, 1]."""
    NoV, sin_t, l, g, _, keep = _lut_lobe_samples(size, samples, max_NoV=0.999)
    mx = torch.where(keep, g * l[..., 0], 0.0).sum(dim=-1)
    mz = torch.where(keep, g * l[..., 2], 0.0).sum(dim=-1)
    t = mx / torch.clamp_max(mx * (1.0 - NoV) - sin_t * mz, -1e-30)
    return t.clamp(0.0, 1.0)[..., None]


# ---------------------------------------------------------------------------------------------
# ibl_compose.comp: a convolved level (viewer/environment/prefilter.py) resampled, plus the sun as points
# ---------------------------------------------------------------------------------------------

def compose_sample(work: torch.Tensor, uv: torch.Tensor) -> torch.Tensor:
    """Twin of ``compose_sample`` in ``passes/ibl_compose.comp``: ``work [h, w, C]`` bilinear at
    ``uv [..., 2]``, between the first (last) row's centre and the pole mixed with the same row
    half a turn round (continuous across the pole) -> ``[..., C]``."""
    h = work.shape[0]
    y = uv[..., 1] * float(h) - 0.5
    inside = (y >= 0.0) & (y <= float(h - 1))
    top = y < 0.0
    edge = torch.where(top, torch.full_like(y, 0.5 / h), torch.full_like(y, 1.0 - 0.5 / h))
    t = torch.where(top, -y, y - float(h - 1))[..., None]
    here = sample_bilinear(work, torch.stack([uv[..., 0], edge], dim=-1))
    across = sample_bilinear(work, torch.stack([uv[..., 0] + 0.5, edge], dim=-1))
    return torch.where(inside[..., None], sample_bilinear(work, uv), here + (across - here) * t)


def _compose_kernel(n: torch.Tensor, l: torch.Tensor, a2: float):
    """``compose_kernel`` of the pass: max(1 - u, 0) / (a^2 + u (1 - a^2) / 2)^2 with
    u = |n - l|^2 / 2; also returns u and the bracket (for the envelope)."""
    d = n - l
    u = 0.5 * (d * d).sum(-1)
    bracket = a2 + u * (0.5 * (1.0 - a2))
    return (1.0 - u).clamp_min(0.0) / (bracket * bracket), u, bracket


def compose_level(work: torch.Tensor, size: tuple[int, int], points: torch.Tensor,
                  a2: float) -> torch.Tensor:
    """Twin of one dispatch of ``passes/ibl_compose.comp``: an ``[h, w, 3]`` level (``size =
    (h, w)``) = :func:`compose_sample` of ``work`` at its texel centres + the sun points
    ``[P, 6]`` (direction, energy / Z) through the level's GGX kernel (alpha^2 = ``a2``)."""
    h, w = size
    uv, n = _texel_dirs(h, w)
    out = compose_sample(work, uv)[..., :3]
    if len(points):
        k, _, _ = _compose_kernel(n[:, :, None, :], points[:, :3], a2)  # [h, w, P]
        sun = (points[:, 3:6] * k[..., None]).sum(dim=2)
        out = out + sun * (a2 / math.pi)
    return out


def compose_level_envelope(work: torch.Tensor, size: tuple[int, int], points: torch.Tensor,
                           a2: float, weight_bits: int = FILTER_WEIGHT_BITS) -> torch.Tensor:
    """Bound ``[h, w, 3]`` on |GPU - :func:`compose_level`|: the resampling's filtered lookups
    (:func:`sample_trilinear_envelope` at lod 0, both taps where a pole row mixes two; uv is exact:
    texel centres of power-of-two sizes) + per sun point, the kernel's response to the texel
    direction's sin/cos error (|d ln k / du| |du|, |du| <= 2 |n - l| DIRECTION_ABS_ERROR) and 16
    ulp of its ~12 operations, summed over the points (+ P ulp of the sum)."""
    h, w = size
    uv, n = _texel_dirs(h, w)
    zero = torch.zeros(uv.shape[:-1])
    err0 = torch.zeros_like(uv)
    hh = work.shape[0]
    y = uv[..., 1] * float(hh) - 0.5
    edge_v = torch.where(y < 0.0, torch.full_like(y, 0.5 / hh), torch.full_like(y, 1.0 - 0.5 / hh))
    taps = [uv, torch.stack([uv[..., 0], edge_v], -1), torch.stack([uv[..., 0] + 0.5, edge_v], -1)]
    bound = sum(sample_trilinear_envelope([work], t, zero, err0, weight_bits=weight_bits)
                for t in taps)[..., :3]
    base = compose_level(work, size, points[:0], a2)
    bound = bound + 4.0 * 2.0 ** -24 * base.abs()
    if len(points):
        k, u, bracket = _compose_kernel(n[:, :, None, :], points[:, :3], a2)
        dist = torch.sqrt(2.0 * u)
        du = 2.0 * dist * DIRECTION_ABS_ERROR
        dlnk = (1.0 - a2) / bracket + 1.0 / (1.0 - u).clamp_min(1e-6)
        rel = du * dlnk + 16.0 * 2.0 ** -24
        terms = points[:, 3:6].abs() * (k * rel)[..., None]
        total = (points[:, 3:6].abs() * k[..., None]).sum(dim=2)
        bound = bound + (terms.sum(dim=2) + len(points) * 2.0 ** -24 * total) * (a2 / math.pi)
    return bound
