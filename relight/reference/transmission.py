"""``KHR_materials_transmission`` and ``_volume`` in :mod:`relight.reference.bsdf`
(shaders/lib/transmission.glsl, evaluated exactly): the base's non-specular part split by the
factor T,

    f cos = f_spec cos + kd [(1 - T) n.l / pi]  (l above)
          + kd T f_t |n.l|                      (l below),   kd = (1 - metallic) albedo (1 - E_spec),

f_t the thin wall's GGX lobe mirrored through the surface (no volume), or Walter et al. 2007's
rough dielectric BTDF with eta = eta_l / eta_v (a volume), both without a Fresnel factor or
radiance scale of their own (the shader's comment says why). A transmissive surface is seen
from both sides, whatever its doubleSided: from the back the frame is mirrored (z -> -z), a
volume's eta inverted, and what reaches the back face of a volume has crossed it, attenuated by
exp(-sigma t) over the ray's length t (``si.t``; the volume holds nothing else). Mitsuba's
``roughdielectric`` and ``thindielectric`` are not used: they weight reflection and
transmission by the exact dielectric Fresnel per microfacet and scale radiance by eta^2,
where glTF's mix keeps the base's Schlick split (the spec's fresnel_mix) and thindielectric
has no roughness at all. The BTDF is sampled through Mitsuba's visible-normal GGX: the
normal is mirrored (thin) or refracted through (volume), by probability (1 - p_spec) T."""
from __future__ import annotations

import math

import numpy as np

MIN_PERCEPTUAL_ROUGHNESS = 0.045


def transmission_state(mi, dr, material, si, texture=None):
    """The transmission at ``si``: factor (times ``texture``'s R, the transmissionTexture, when
    given), whether a volume, its IOR, sigma and whether ``si`` is seen from the back (inside);
    None for an opaque material."""
    if material is None or material.transmission <= 0.0:
        return None
    inside = mi.Frame3f.cos_theta(si.wi) < 0.0
    factor = float(material.transmission)
    if texture is not None:
        factor = factor * texture.eval(si).x
    iors = dispersion_iors(material.volume_ior(), material.dispersion) \
        if material.has_dispersion else None
    return dict(T=factor, volume=bool(material.volume),
                ior=float(material.volume_ior()), inside=inside, iors=iors,
                sigma=mi.Color3f(*material.attenuation_coefficient()))


def dispersion_iors(ior: float, dispersion: float) -> tuple[float, float, float]:
    """lib/transmission.glsl ``dispersion_iors``: KHR_materials_dispersion's red, green and
    blue IORs, ior -/+ (ior - 1) 0.025 dispersion (three.js's spread)."""
    half = (ior - 1.0) * 0.025 * dispersion
    return (ior - half, ior, ior + half)


def facing(mi, dr, t, si):
    """``si`` with its shading frame mirrored (z -> -z) where seen from the back, so the
    material is evaluated from the side the viewer is on; and the eta of that side."""
    s = mi.SurfaceInteraction3f(si)
    flip = t["inside"]
    n = si.sh_frame.n
    s.sh_frame = mi.Frame3f(si.sh_frame.s, si.sh_frame.t, dr.select(flip, -n, n))
    s.wi = mi.Vector3f(si.wi.x, si.wi.y, dr.select(flip, -si.wi.z, si.wi.z))
    eta = dr.select(flip, 1.0 / t["ior"], t["ior"]) if t["volume"] else mi.Float(0.0)
    if t.get("iors") is not None:  # KHR_materials_dispersion: each channel's own eta
        t["etas"] = [dr.select(flip, 1.0 / ior, ior) for ior in t["iors"]]
    return s, eta


def mirror_z(mi, dr, t, v):
    """A local direction in the mirrored frame of :func:`facing` (its own inverse)."""
    return mi.Vector3f(v.x, v.y, dr.select(t["inside"], -v.z, v.z))


def attenuation(mi, dr, t, si):
    """exp(-sigma t) where the ray reached a volume's back face (it crossed the volume)."""
    if not t["volume"]:
        return mi.Color3f(1.0)
    return dr.select(t["inside"], dr.exp(-t["sigma"] * si.t), mi.Color3f(1.0))


def _ggx_d(dr, a2, h):
    noh = dr.clip(h.z, 0.0, 1.0)
    f = noh * noh * a2 + (h.x * h.x + h.y * h.y)
    return a2 / (dr.pi * f * f)


def _vis(dr, a2, nv, nl):
    return 0.5 / dr.maximum(nl * dr.sqrt(nv * nv * (1.0 - a2) + a2)
                            + nv * dr.sqrt(nl * nl * (1.0 - a2) + a2), 1e-8)


def _refraction_half(mi, dr, wi, wo, eta):
    h = wi + eta * wo
    ok = dr.squared_norm(h) > 1e-12
    h = dr.normalize(h)
    return dr.select(h.z < 0.0, -h, h), ok


def btdf_cos(mi, dr, a, eta, volume: bool, wi, wo):
    """f_t |n.l| for ``wo`` below (local, ``wi`` above): lib/transmission.glsl
    ``thin_transmission_cos`` or ``rough_refraction_cos``."""
    a2 = dr.maximum(a * a, 1e-8)
    nv = dr.clip(wi.z, 0.0, 1.0)
    nl = -wo.z
    if not volume:
        h = dr.normalize(wi + mi.Vector3f(wo.x, wo.y, -wo.z))
        value = _ggx_d(dr, a2, h) * _vis(dr, a2, nv, dr.clip(nl, 0.0, 1.0)) * nl
        return dr.select((nl > 0.0) & (wi.z > 0.0), value, 0.0)
    h, ok = _refraction_half(mi, dr, wi, wo, eta)
    voh, loh = dr.dot(wi, h), dr.dot(wo, h)
    denom = voh + eta * loh
    jac = eta * eta * (-loh) / dr.maximum(denom * denom, 1e-20)
    value = 4.0 * _vis(dr, a2, nv, dr.clip(nl, 0.0, 1.0)) * nl * _ggx_d(dr, a2, h) * voh * jac
    return dr.select(ok & (nl > 0.0) & (wi.z > 0.0) & (voh > 0.0) & (loh < 0.0), value, 0.0)


def btdf_pdf(mi, dr, distr, eta, volume: bool, wi, wo):
    """The density of ``wo`` under :func:`btdf_sample`."""
    if not volume:
        wr = mi.Vector3f(wo.x, wo.y, -wo.z)
        h = dr.normalize(wi + wr)
        p = distr.pdf(wi, h) / dr.maximum(4.0 * dr.dot(wr, h), 1e-12)
        return dr.select((wo.z < 0.0) & (wi.z > 0.0), p, 0.0)
    h, ok = _refraction_half(mi, dr, wi, wo, eta)
    voh, loh = dr.dot(wi, h), dr.dot(wo, h)
    denom = voh + eta * loh
    jac = eta * eta * (-loh) / dr.maximum(denom * denom, 1e-20)
    p = distr.pdf(wi, h) * jac
    return dr.select(ok & (wo.z < 0.0) & (wi.z > 0.0) & (voh > 0.0) & (loh < 0.0), p, 0.0)


def btdf_sample(mi, dr, distr, eta, volume: bool, wi, sample2):
    """A direction below: a visible normal m mirrored (thin) or refracted through (volume;
    total internal reflection gives (0, 0, 0), density 0)."""
    m, _ = distr.sample(wi, sample2)
    if not volume:
        r = mi.reflect(wi, m)
        return mi.Vector3f(r.x, r.y, -r.z)
    c = dr.dot(wi, m)
    k = 1.0 - (1.0 - c * c) / (eta * eta)
    wo = -wi / eta + (c / eta - dr.sqrt(dr.maximum(k, 0.0))) * m
    return dr.select(k > 0.0, wo, mi.Vector3f(0.0))


# ---- KHR_materials_dispersion: the BTDF per colour channel ----------------------------------
# A dispersive volume (t["etas"]: one eta per channel) refracts each channel by its own eta:
# the BTDF is evaluated per channel, a direction is drawn by a channel chosen uniformly
# (then that channel's visible-normal refraction), and its density is the mean of the three
# channels' (one-sample MIS with the balance heuristic over the three draws: f_k / mean_c pdf_c
# is an unbiased estimate of every channel k). The path tracer draws the channels in
# proportion to the path's throughput instead (passes/surface_dispersion.glsl), which a BSDF
# plugin cannot see: as unbiased, less noisy. Without dispersion these are btdf_cos / _pdf /
# _sample of the one eta.

def btdf_cos_rgb(mi, dr, a, t, wi, wo):
    """f_t |n.l| per channel (``mi.Color3f``)."""
    if t.get("etas") is None:
        return mi.Color3f(btdf_cos(mi, dr, a, t["eta"], t["volume"], wi, wo))
    return mi.Color3f(*[btdf_cos(mi, dr, a, eta, True, wi, wo) for eta in t["etas"]])


def btdf_pdf_rgb(mi, dr, distr, t, wi, wo):
    """The density of ``wo`` under :func:`btdf_sample_rgb`."""
    if t.get("etas") is None:
        return btdf_pdf(mi, dr, distr, t["eta"], t["volume"], wi, wo)
    return sum(btdf_pdf(mi, dr, distr, eta, True, wi, wo) for eta in t["etas"]) / 3.0


def btdf_sample_rgb(mi, dr, distr, t, wi, sample2, u_channel):
    """A direction below: :func:`btdf_sample` with the eta of the channel ``u_channel`` (in
    [0, 1)) picks uniformly."""
    if t.get("etas") is None:
        return btdf_sample(mi, dr, distr, t["eta"], t["volume"], wi, sample2)
    r, g, b = t["etas"]
    eta = dr.select(u_channel < 1.0 / 3.0, r, dr.select(u_channel < 2.0 / 3.0, g, b))
    return btdf_sample(mi, dr, distr, eta, True, wi, sample2)


# ---- numpy, for the furnace tests ---------------------------------------------------------

def btdf_cos_numpy(roughness: float, n_dot_v: float, wo, eta: float | None) -> np.ndarray:
    """f_t |n.l| for local directions ``wo`` ``[N, 3]`` (the view (sqrt(1 - n.v^2), 0, n.v));
    ``eta`` None for the thin wall, float64 -> ``[N]``."""
    wo = np.asarray(wo, np.float64)
    wi = np.array([math.sqrt(max(1.0 - n_dot_v ** 2, 0.0)), 0.0, n_dot_v])
    r = min(max(roughness, MIN_PERCEPTUAL_ROUGHNESS), 1.0)
    a2 = (r * r) ** 2
    nl = -wo[:, 2]
    nlc = np.clip(nl, 0.0, 1.0)
    vis = 0.5 / (nlc * math.sqrt(n_dot_v ** 2 * (1 - a2) + a2)
                 + n_dot_v * np.sqrt(nlc ** 2 * (1 - a2) + a2))
    if eta is None:
        h = wo * np.array([1.0, 1.0, -1.0]) + wi
        h /= np.linalg.norm(h, axis=1, keepdims=True)
        ok = nl > 0
        jac_term = 1.0
    else:
        h = wi + eta * wo
        h /= np.maximum(np.linalg.norm(h, axis=1, keepdims=True), 1e-30)
        h = np.where(h[:, 2:3] < 0, -h, h)
        voh, loh = h @ wi, (h * wo).sum(1)
        ok = (nl > 0) & (voh > 0) & (loh < 0)
        jac_term = 4.0 * voh * eta * eta * (-loh) / np.maximum((voh + eta * loh) ** 2, 1e-20)
    noh = np.clip(h[:, 2], 0, 1)
    f = noh * noh * a2 + (1 - noh) * (1 + noh)
    d = a2 / (math.pi * f * f)
    return np.where(ok, d * vis * nlc * jac_term, 0.0)
