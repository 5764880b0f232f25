"""``KHR_materials_anisotropy`` in :mod:`relight.reference.bsdf` (shaders/lib/anisotropy.glsl,
evaluated exactly): the base's specular lobe becomes the anisotropic GGX of the extension,

    D(h) = 1 / (pi a_t a_b ((h.t / a_t)^2 + (h.b / a_b)^2 + (h.n)^2)^2),
    V = 0.5 / (n.l |(a_t t.v, a_b b.v, n.v)| + n.v |(a_t t.l, a_b b.l, n.l)|),

a_t = mix(a, 1, s^2) along the direction t and a_b = a across it (a = r^2, the clamped
perceptual roughness; s the strength, times the map's B). t is the tangent space's direction
(cos, sin) of the rotation (with a map: its RG, x 2 - 1, normalised and turned by the rotation)
with the tangent space taken from the UVs (T along dp/du, B along -dp/dv: the spec's computed
tangents; a mesh's own TANGENT attribute is not read here: a warning), put into the plane of
the (normal-mapped) shading normal. The energy split (1 - E_spec(n.v)) and the lobe choice keep
the isotropic lobe's albedo, as the renderer's models do; the BTDF of a transmissive material
stays isotropic. Sampled by Mitsuba's anisotropic visible-normal GGX."""
from __future__ import annotations

import math

import numpy as np


def anisotropy_state(mi, dr, bsdf, si, frame, a):
    """The lobe at the hit: its frame (t, b, n in the mapped frame's local coordinates), the
    alphas and Mitsuba's anisotropic distribution; None for an isotropic material. ``frame``:
    the normal-mapped frame (None without a normal map), ``a``: the material's alpha."""
    m = bsdf.material
    if m is None or m.anisotropy_strength <= 0.0:
        return None
    strength = mi.Float(m.anisotropy_strength)
    c, s = math.cos(m.anisotropy_rotation), math.sin(m.anisotropy_rotation)
    dx, dy = mi.Float(c), mi.Float(s)
    if bsdf.anisotropy_texture is not None:
        texel = bsdf.anisotropy_texture.eval(si)
        x, y = 2.0 * texel.x - 1.0, 2.0 * texel.y - 1.0
        len2 = x * x + y * y
        ok = len2 > 1e-12
        inv = dr.rsqrt(dr.maximum(len2, 1e-24))
        x, y = dr.select(ok, x * inv, 1.0), dr.select(ok, y * inv, 0.0)
        dx, dy = c * x - s * y, s * x + c * y  # turned counter-clockwise by the rotation
        strength = strength * texel.z
    du = si.sh_frame.to_local(si.dp_du)
    dv = si.sh_frame.to_local(si.dp_dv)
    t = dr.normalize(mi.Vector3f(du.x, du.y, 0.0))
    b = mi.Vector3f(-t.y, t.x, 0.0)  # cross(n, t)
    b = dr.select(dr.dot(b, -mi.Vector3f(dv.x, dv.y, 0.0)) < 0.0, -b, b)  # mirrored UVs
    ta = t * dx + b * dy
    if frame is not None:
        ta = frame.to_local(ta)
    ta = dr.normalize(mi.Vector3f(ta.x, ta.y, 0.0))
    s2 = dr.square(dr.clip(strength, 0.0, 1.0))
    at = dr.lerp(a, 1.0, s2)
    lobe = mi.Frame3f(ta, mi.Vector3f(-ta.y, ta.x, 0.0), mi.Vector3f(0.0, 0.0, 1.0))
    return {"frame": lobe, "at": at, "ab": a,
            "distr": mi.MicrofacetDistribution(mi.MicrofacetType.GGX, at, a, True)}


def anisotropic_dv(mi, dr, an, wi, wo, h):
    """D(h) V(wi, wo) of the lobe ``an`` for directions in the mapped frame."""
    f = an["frame"]
    wi, wo, h = f.to_local(wi), f.to_local(wo), f.to_local(h)
    at, ab = an["at"], an["ab"]
    a2 = at * ab
    fx, fy, fz = ab * h.x, at * h.y, a2 * dr.clip(h.z, 0.0, 1.0)
    w2 = a2 / dr.maximum(fx * fx + fy * fy + fz * fz, 1e-30)
    d = a2 * w2 * w2 * dr.inv_pi
    nv, nl = dr.clip(wi.z, 0.0, 1.0), dr.clip(wo.z, 0.0, 1.0)
    gv = nl * dr.sqrt(dr.square(at * wi.x) + dr.square(ab * wi.y) + nv * nv)
    gl = nv * dr.sqrt(dr.square(at * wo.x) + dr.square(ab * wo.y) + nl * nl)
    return d * 0.5 / dr.maximum(gv + gl, 1e-8)


def anisotropic_pdf(mi, dr, an, wi, wo):
    """Density of ``wo`` under the lobe's visible-normal draw (mapped frame)."""
    f = an["frame"]
    wi_a, wo_a = f.to_local(wi), f.to_local(wo)
    h = dr.normalize(wi_a + wo_a)
    return an["distr"].pdf(wi_a, h) / dr.maximum(4.0 * dr.dot(wo_a, h), 1e-12)


def anisotropic_sample(mi, dr, an, wi, sample2):
    """A visible-normal draw of the lobe, reflected: wo in the mapped frame."""
    f = an["frame"]
    wi_a = f.to_local(wi)
    m, _ = an["distr"].sample(wi_a, sample2)
    return f.to_world(mi.reflect(wi_a, m))


def anisotropic_cos_numpy(f0, roughness, strength, n_dot_v, phi_v, wo) -> np.ndarray:
    """The anisotropic specular f cos (no energy split: a metal's whole BRDF) for local
    directions ``wo`` ``[N, 3]`` (z = the normal, x = the direction t), the view at n.v with
    azimuth ``phi_v`` from t; float64 -> ``[N, 3]``. For the white furnace test."""
    wo = np.asarray(wo, np.float64)
    st = math.sqrt(max(1.0 - n_dot_v ** 2, 0.0))
    wi = np.array([st * math.cos(phi_v), st * math.sin(phi_v), n_dot_v])
    r = min(max(roughness, 0.045), 1.0)
    a = r * r
    at, ab = a + (1.0 - a) * strength ** 2, a
    h = wo + wi
    h /= np.linalg.norm(h, axis=1, keepdims=True)
    a2 = at * ab
    w2 = a2 / ((ab * h[:, 0]) ** 2 + (at * h[:, 1]) ** 2 + (a2 * np.clip(h[:, 2], 0, 1)) ** 2)
    d = a2 * w2 * w2 / math.pi
    nl = np.clip(wo[:, 2], 0.0, 1.0)
    gv = nl * math.sqrt((at * wi[0]) ** 2 + (ab * wi[1]) ** 2 + n_dot_v ** 2)
    gl = n_dot_v * np.sqrt((at * wo[:, 0]) ** 2 + (ab * wo[:, 1]) ** 2 + nl ** 2)
    vis = 0.5 / np.maximum(gv + gl, 1e-12)
    voh = np.clip(h @ wi, 0.0, 1.0)
    f0 = np.asarray(f0, np.float64)
    fr = f0[None, :] + (1.0 - f0[None, :]) * ((1.0 - voh) ** 5)[:, None]
    return np.where((wo[:, 2] > 0)[:, None], (d * vis * nl)[:, None] * fr, 0.0)
