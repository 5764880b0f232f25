"""The material layers of :mod:`relight.reference.bsdf` (shaders/lib/layers.glsl, evaluated
exactly): the ``KHR_materials_clearcoat`` coat, a GGX lobe of IOR 1.5 layered by the spec's
fresnel_coat,

    f cos = (1 - w) f_base cos + w D_GGX(h; a_c) V_SmithGGXCorrelated(v, l; a_c) (n.l),
    w = c (0.04 + 0.96 (1 - n.v)^5),

c the clearcoat factor (times its map's R), a_c = r_c^2 with r_c the coat's perceptual roughness
(times its map's G) clamped to 0.045 as the base's. The coat's normal is the shading frame's (the
interpolated vertex normal): the reference does not read the coat's normal map (a warning). The
coat is sampled with probability proportional to its albedo w dfg.y (Mitsuba's visible-normal
GGX), the base with the rest."""
from __future__ import annotations

import math

import numpy as np

MIN_PERCEPTUAL_ROUGHNESS = 0.045
CLEARCOAT_F0 = 0.04


def clearcoat_weight(clearcoat, nov):
    """c F_c(n.v) (lib/layers.glsl ``clearcoat_weight``), numpy or Dr.Jit values."""
    x = 1.0 - nov
    return clearcoat * (CLEARCOAT_F0 + (1.0 - CLEARCOAT_F0) * x * x * x * x * x)


def coat_cos_numpy(clearcoat, roughness, n_dot_v, wo) -> np.ndarray:
    """The coat's f cos for local directions ``wo`` ``[N, 3]`` (z = the normal; the view
    (sqrt(1 - n.v^2), 0, n.v)), float64 -> ``[N]``; the base's share is (1 - w) of its own."""
    wo = np.asarray(wo, np.float64)
    wi = np.array([math.sqrt(max(1.0 - n_dot_v ** 2, 0.0)), 0.0, n_dot_v])
    r = min(max(roughness, MIN_PERCEPTUAL_ROUGHNESS), 1.0)
    a2 = (r * r) ** 2
    w = clearcoat_weight(clearcoat, n_dot_v)
    h = wo + wi
    h /= np.linalg.norm(h, axis=1, keepdims=True)
    noh = np.clip(h[:, 2], 0, 1)
    f = noh * noh * a2 + (1 - noh) * (1 + noh)
    d = a2 / (math.pi * f * f)
    nl = np.clip(wo[:, 2], 0, 1)
    vis = 0.5 / (nl * math.sqrt(n_dot_v ** 2 * (1 - a2) + a2)
                 + n_dot_v * np.sqrt(nl ** 2 * (1 - a2) + a2))
    return np.where(wo[:, 2] > 0, w * d * vis * nl, 0.0)


def coat_factor(mi, dr, bsdf, si):
    """KHR_materials_clearcoat's factor at the hit, times its map's R, in [0, 1] (a Dr.Jit
    float); None for a material without a coat."""
    m = bsdf.material
    if m is None or m.clearcoat <= 0.0:
        return None
    c = mi.Float(m.clearcoat)
    if bsdf.clearcoat_texture is not None:
        c = c * bsdf.clearcoat_texture.eval(si).x
    return dr.clip(c, 0.0, 1.0)


def coat_state(mi, dr, bsdf, si, dfg, table_size: int):
    """The coat at the hit: its weight w, alpha, albedo w dfg.y (``dfg``: the plugin's table
    texture of ``table_size`` texels a side), n.v and distribution; None for a material
    without a coat."""
    c = coat_factor(mi, dr, bsdf, si)
    if c is None:
        return None
    m = bsdf.material
    rough = mi.Float(m.clearcoat_roughness)
    if bsdf.clearcoat_roughness_texture is not None:
        rough = rough * bsdf.clearcoat_roughness_texture.eval(si).y
    r = dr.clip(rough, MIN_PERCEPTUAL_ROUGHNESS, 1.0)
    nov = dr.clip(mi.Frame3f.cos_theta(si.wi), 0.0, 1.0)
    w = clearcoat_weight(c, nov)
    _, y = dfg.eval(mi.Point2f((nov * (table_size - 1) + 0.5) / table_size,
                               (r * (table_size - 1) + 0.5) / table_size))
    return dict(w=w, a=r * r, albedo=w * y, nov=nov,
                distr=mi.MicrofacetDistribution(mi.MicrofacetType.GGX, r * r, True))


def coat_eval(mi, dr, coat, wi, wo):
    """w D V n.l for ``wo`` (the shading frame's local coordinates, as ``wi``)."""
    nol = mi.Frame3f.cos_theta(wo)
    h = dr.normalize(wi + wo)
    noh = dr.clip(mi.Frame3f.cos_theta(h), 0.0, 1.0)
    a2 = dr.maximum(coat["a"] * coat["a"], 1e-8)
    f = noh * noh * a2 + (h.x * h.x + h.y * h.y)  # as the base's D: exact near the peak
    d = a2 / (dr.pi * f * f)
    nl = dr.clip(nol, 0.0, 1.0)
    nv = coat["nov"]
    vis = 0.5 / dr.maximum(nl * dr.sqrt(nv * nv * (1.0 - a2) + a2)
                           + nv * dr.sqrt(nl * nl * (1.0 - a2) + a2), 1e-8)
    return dr.select((nol > 0.0) & (nv > 0.0), coat["w"] * d * vis * nl, 0.0)


def coat_pdf(mi, dr, coat, wi, wo):
    """Density of ``wo`` under the coat's visible-normal sampling (reflected)."""
    h = dr.normalize(wi + wo)
    p = coat["distr"].pdf(wi, h) / dr.maximum(4.0 * dr.dot(wo, h), 1e-12)
    return dr.select((mi.Frame3f.cos_theta(wo) > 0.0) & (mi.Frame3f.cos_theta(wi) > 0.0), p, 0.0)
