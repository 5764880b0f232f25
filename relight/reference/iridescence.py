"""The ``KHR_materials_iridescence`` thin film of :mod:`relight.reference.bsdf`
(shaders/lib/iridescence.glsl evaluated per half vector): the glTF specification's form of
Belcour & Barla 2017, one function written once for numpy (float64, :data:`NUMPY`) and for
Dr.Jit (the plugin, :func:`drjit_ops`), channel by channel.

The surface's Fresnel becomes ``mix(F_Schlick(f0, f90, v.h), F_film(v.h), factor)`` with
``F_film`` the reflectance of a film of IOR ``film_ior`` and thickness ``d`` nm over a base of
normal-incidence reflectance ``f0`` seen from air (:func:`film_fresnel`), or under a
``KHR_materials_clearcoat`` coat from the coat's IOR: the spec's "Clearcoat" section evaluates
the coat before the film, whose outside IOR becomes the coat's 1.5, ``mix(1, 1.5, clearcoat)``
for partial coats (OpenPBR, Babylon: :func:`outside_ior`); the factor is
``iridescenceFactor`` times its map's R, the thickness ``mix(min, max, G)`` of the thickness map
(``max`` without it). A film of thickness 0 is none (three.js), and the film's IOR is blended in
from the outside's over its first 30 nm (:data:`FILM_RAMP_NM`), so it fades continuously.

The diffuse keeps ``1 - E_spec(n.v)`` of itself, as without the film, E_spec the lobe's
directional albedo with the film's Fresnel: the DFG table's Schlick albedo plus what the film
changes (:func:`albedo_delta`, a fixed 32-point quadrature over the visible normals, shared with
the path tracer: lib/iridescence.glsl ``iridescence_albedo_delta``), a per-pixel constant. (The
split sum keeps three.js's cheaper F0 of the film's Fresnel at n.v, :func:`split_sum_f0`, for
its specular and its diffuse alike: under it a white base reflects up to 1.15 at grazing views
of rough films, which the quadrature keeps within 1.01.)"""
from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np

from .layers import coat_factor

FILM_RAMP_NM = 30.0  # lib/iridescence.glsl IRIDESCENCE_FILM_RAMP_NM
_VAL = (5.4856e-13, 4.4201e-13, 5.2481e-13)
_POS = (1.6810e+06, 1.7953e+06, 2.2084e+06)
_VAR = (4.3278e+09, 9.3046e+09, 6.6121e+09)
XYZ_TO_REC709 = ((3.2404542, -1.5371385, -0.4985314),
                 (-0.9692660, 1.8760108, 0.0415560),
                 (0.0556434, -0.2040259, 1.0572252))

NUMPY = SimpleNamespace(sqrt=np.sqrt, cos=np.cos, sin=np.sin, exp=np.exp, select=np.where,
                        clip=np.clip, maximum=np.maximum)
ALBEDO_NODES = 32  # lib/iridescence.glsl IRIDESCENCE_ALBEDO_NODES
COAT_IOR = 1.5  # lib/iridescence.glsl IRIDESCENCE_COAT_IOR: KHR_materials_clearcoat's coat


def outside_ior(clearcoat):
    """lib/iridescence.glsl ``iridescence_outside_ior``: the IOR the film is seen from under a
    coat of factor ``clearcoat`` in [0, 1] (0: air), ``mix(1, 1.5, clearcoat)`` (numpy or
    Dr.Jit values; the caller clamps)."""
    return 1.0 + (COAT_IOR - 1.0) * clearcoat


def drjit_ops(dr):
    """The operations :func:`film_fresnel` needs, from Dr.Jit."""
    return SimpleNamespace(sqrt=dr.sqrt, cos=dr.cos, sin=dr.sin, exp=dr.exp, select=dr.select,
                           clip=dr.clip, maximum=dr.maximum)


def albedo_node(k: int, nodes: int = ALBEDO_NODES) -> tuple[float, float]:
    """The k-th of the albedo quadrature's fixed 2D points: ((k + 1/2) / K, frac(k phi^-1))."""
    return (k + 0.5) / nodes, float(np.float32(k) * np.float32(0.6180339887498949) % 1.0)


def _node_term(ops, f0, f90, c, a, vx, vh, lam, u0, u1, thickness_nm, film_ior, outside=1.0):
    """One point's (F_film - F_Schlick)(v.h) f cos / pdf (:func:`albedo_delta`), 3 values."""
    a2 = a * a
    phi = 2.0 * math.pi * u0
    z = (1.0 - u1) * (1.0 + vh[1]) - vh[1]
    sin_t = ops.sqrt(ops.clip(1.0 - z * z, 0.0, 1.0))
    hx, hy, hz = a * (sin_t * ops.cos(phi) + vh[0]), a * (sin_t * ops.sin(phi)), \
        ops.maximum(z + vh[1], 0.0)
    inv = 1.0 / ops.sqrt(ops.maximum(hx * hx + hy * hy + hz * hz, 1e-30))
    hx, hz = hx * inv, hz * inv
    voh = vx * hx + c * hz
    nol = 2.0 * voh * hz - c
    nl = ops.clip(nol, 0.0, 1.0)
    vis = 0.5 / ops.maximum(nl * ops.sqrt(c * c * (1.0 - a2) + a2)
                            + c * ops.sqrt(nl * nl * (1.0 - a2) + a2), 1e-8)
    weight = ops.select(nol > 0.0, vis * nl * lam, 0.0)
    film = film_fresnel(ops, voh, thickness_nm, film_ior, f0, outside)
    x = 1.0 - ops.clip(voh, 0.0, 1.0)
    x5 = x * x * x * x * x
    return [(film[ch] - (f0[ch] + (f90 - f0[ch]) * x5)) * weight for ch in range(3)]


def _view(ops, nov, a):
    c = ops.clip(nov, 0.0, 1.0)
    a = ops.clip(a, 1e-4, 1.0)
    vx = ops.sqrt(ops.maximum(1.0 - c * c, 0.0))
    norm = ops.sqrt(a * a * vx * vx + (c + 1e-7) ** 2)
    lam = 2.0 * (c + ops.sqrt(a * a + (1.0 - a * a) * c * c))  # 1 / (pdf / D) of the reflected l
    return c, a, vx, (a * vx / norm, (c + 1e-7) / norm), lam  # vh: the stretched view (y = 0)


def albedo_delta(ops, f0, f90, nov, a, factor, thickness_nm, film_ior, nodes=ALBEDO_NODES,
                 outside=1.0):
    """lib/iridescence.glsl ``iridescence_albedo_delta``: what the film changes in the specular
    lobe's directional albedo, factor x mean over :func:`albedo_node` of (F_film - F_Schlick)(v.h)
    f cos / pdf at the visible normals those points draw (sample_ggx_vndf, Dupuy & Benyoub
    2023), 3 values, the film seen from IOR ``outside``. Added to the DFG table's E_spec it is
    the energy split's E_spec."""
    c, a, vx, vh, lam = _view(ops, nov, a)
    out = [0.0, 0.0, 0.0]
    for k in range(nodes):
        u0, u1 = albedo_node(k, nodes)
        term = _node_term(ops, f0, f90, c, a, vx, vh, lam, u0, u1, thickness_nm, film_ior,
                          outside)
        out = [out[ch] + term[ch] for ch in range(3)]
    w = ops.select(thickness_nm > 0.0, ops.clip(factor, 0.0, 1.0), 0.0)
    return [out[ch] * (w / nodes) for ch in range(3)]
def _schlick(ops, f0, c):
    x = 1.0 - ops.clip(c, 0.0, 1.0)
    return f0 + (1.0 - f0) * (x * x * x * x * x)


def sensitivity(ops, opd, shift):
    """The spec's evalSensitivity at optical path difference ``opd`` (nm) with per-channel
    phase ``shift`` (3 values): linear Rec.709, 3 values."""
    phase = 2.0 * math.pi * opd * 1.0e-9
    xyz = [_VAL[k] * math.sqrt(2.0 * math.pi * _VAR[k]) * ops.cos(_POS[k] * phase + shift[k])
           * ops.exp(-phase * phase * _VAR[k]) for k in range(3)]
    xyz[0] = xyz[0] + 9.7470e-14 * math.sqrt(2.0 * math.pi * 4.5282e+09) \
        * ops.cos(2.2399e+06 * phase + shift[0]) * ops.exp(-4.5282e+09 * phase * phase)
    xyz = [x / 1.0685e-7 for x in xyz]
    return [XYZ_TO_REC709[r][0] * xyz[0] + XYZ_TO_REC709[r][1] * xyz[1]
            + XYZ_TO_REC709[r][2] * xyz[2] for r in range(3)]


def film_fresnel(ops, cos_theta1, thickness_nm, film_ior, base_f0, outside_ior=1.0):
    """lib/iridescence.glsl ``iridescence_fresnel``: the film's reflectance, 3 values (one per
    RGB channel of ``base_f0``), clamped to [0, 1] (the spec's formula leaves the gamut at
    grazing views over bright bases: up to 1.75); 1 on total internal reflection in the film."""
    c1 = ops.clip(cos_theta1, 0.0, 1.0)
    t = ops.clip(thickness_nm / FILM_RAMP_NM, 0.0, 1.0)
    eta2 = outside_ior + (film_ior - outside_ior) * (t * t * (3.0 - 2.0 * t))
    cos2_theta2 = 1.0 - (outside_ior / eta2) ** 2 * (1.0 - c1 * c1)
    tir = cos2_theta2 < 0.0
    c2 = ops.sqrt(ops.maximum(cos2_theta2, 0.0))
    r0 = ((eta2 - outside_ior) / (eta2 + outside_ior)) ** 2
    r12 = _schlick(ops, r0, c1)
    t121 = 1.0 - r12
    phi21 = math.pi - ops.select(eta2 < outside_ior, math.pi, 0.0)
    opd = 2.0 * eta2 * thickness_nm * c2
    out = []
    for k in range(3):
        s = ops.sqrt(ops.clip(base_f0[k], 0.0, 0.9999))
        base_ior = (1.0 + s) / (1.0 - s)
        r1 = ((base_ior - eta2) / (base_ior + eta2)) ** 2
        r23 = _schlick(ops, r1, c2)
        phi = phi21 + ops.select(base_ior < eta2, math.pi, 0.0)
        r123 = ops.clip(r12 * r23, 1e-5, 0.9999)
        rs = t121 * t121 * r23 / (1.0 - r123)
        out.append((r12 + rs, rs - t121, ops.sqrt(r123), phi))
    i = [o[0] for o in out]
    cm = [o[1] for o in out]
    for m in (1, 2):
        cm = [cm[k] * out[k][2] for k in range(3)]
        sens = sensitivity(ops, m * opd, [m * out[k][3] for k in range(3)])
        i = [i[k] + cm[k] * 2.0 * sens[k] for k in range(3)]
    return [ops.select(tir, 1.0, ops.clip(i[k], 0.0, 1.0)) for k in range(3)]


def fresnel_mix(ops, f0, f90, voh, factor, thickness_nm, film_ior, outside=1.0):
    """lib/iridescence.glsl ``iridescence_fresnel_mix`` (3 values per channel; ``f0`` 3 values,
    the rest scalars): Schlick's Fresnel mixed with the film's (seen from IOR ``outside``) by the
    factor."""
    x = 1.0 - ops.clip(voh, 0.0, 1.0)
    x5 = x * x * x * x * x
    film = film_fresnel(ops, voh, thickness_nm, film_ior, f0, outside)
    w = ops.select(thickness_nm > 0.0, ops.clip(factor, 0.0, 1.0), 0.0)
    return [(f0[k] + (f90 - f0[k]) * x5) * (1.0 - w) + film[k] * w for k in range(3)]


def split_sum_f0(ops, f0, f90, nov, factor, thickness_nm, film_ior, outside=1.0):
    """lib/iridescence.glsl ``iridescence_f0``: the F0 that reproduces the film's Fresnel at n.v
    (seen from IOR ``outside``) under Schlick with this f90 (three.js's Schlick_to_F0), mixed by
    the factor."""
    x = 1.0 - ops.clip(nov, 0.0, 1.0)
    x5 = x * x * x * x * x
    film = film_fresnel(ops, nov, thickness_nm, film_ior, f0, outside)
    w = ops.select(thickness_nm > 0.0, ops.clip(factor, 0.0, 1.0), 0.0)
    return [f0[k] * (1.0 - w) + ops.clip((film[k] - f90 * x5) / ops.maximum(1.0 - x5, 1e-4),
                                         0.0, 1.0) * w for k in range(3)]


def film_state(mi, dr, bsdf, si):
    """The film at the hit: (factor, thickness nm, IOR) as Dr.Jit floats, the factor times the
    map's R, the thickness ``mix(min, max, G)`` of the thickness map (``max`` without it), and
    the IOR it is seen from (``outside``: :func:`outside_ior` of the clearcoat factor times its
    map's R, :func:`relight.reference.layers.coat_factor`; 1.0 without a coat); None for a
    material without a film."""
    m = bsdf.material
    if m is None or m.iridescence <= 0.0:
        return None
    factor = mi.Float(m.iridescence)
    if bsdf.iridescence_texture is not None:
        factor = factor * bsdf.iridescence_texture.eval(si).x
    thickness = mi.Float(m.iridescence_thickness_max)
    if bsdf.iridescence_thickness_texture is not None:
        g = bsdf.iridescence_thickness_texture.eval(si).x  # the map's G (scene.py keeps it)
        thickness = dr.lerp(mi.Float(m.iridescence_thickness_min), thickness, g)
    coat = coat_factor(mi, dr, bsdf, si)
    outside = 1.0 if coat is None else outside_ior(coat)
    return {"factor": factor, "thickness": thickness, "ior": float(m.iridescence_ior),
            "outside": outside}


def film_fresnel_mix(mi, dr, film, f0, f90, voh):
    """The surface's Fresnel at v.h with the film (:func:`fresnel_mix`), an ``mi.Color3f``."""
    c = fresnel_mix(drjit_ops(dr), [f0.x, f0.y, f0.z], f90, voh, film["factor"],
                    film["thickness"], film["ior"], film["outside"])
    return mi.Color3f(c[0], c[1], c[2])


def film_albedo_delta(mi, dr, film, f0, f90, nov, a):
    """:func:`albedo_delta` as an ``mi.Color3f``, its points in one symbolic Dr.Jit loop (the
    unrolled sum made the plugin's kernel 32 films long: a minute of LLVM compilation)."""
    ops = drjit_ops(dr)
    c, a, vx, vh, lam = _view(ops, nov, a)
    f0c = [f0.x, f0.y, f0.z]

    def body(k, r, g, b):
        t = mi.Float(k) * 0.6180339887498949  # float32, as the GLSL's fract(float(k) x ...)
        term = _node_term(ops, f0c, f90, c, a, vx, vh, lam, (mi.Float(k) + 0.5) / ALBEDO_NODES,
                          t - dr.floor(t), film["thickness"], film["ior"], film["outside"])
        return k + 1, r + term[0], g + term[1], b + term[2]

    zero = dr.zeros(mi.Float, dr.width(c))
    _, r, g, b = dr.while_loop((mi.UInt32(0), zero, mi.Float(zero), mi.Float(zero)),
                               lambda k, r, g, b: k < ALBEDO_NODES, body)
    w = dr.select(film["thickness"] > 0.0, dr.clip(film["factor"], 0.0, 1.0), 0.0) / ALBEDO_NODES
    return mi.Color3f(r * w, g * w, b * w)
