"""Float64 numpy evaluations of :mod:`relight.reference.bsdf`'s formulas: the DFG table the
plugin reads (:func:`directional_albedo_table`) and its f cos (:func:`brdf_cos_numpy`), for the
plugin itself and for tests that check it against an independent evaluation."""
from __future__ import annotations

import functools
import math

import numpy as np

MIN_PERCEPTUAL_ROUGHNESS = 0.045  # shaders/lib/brdf.glsl
DFG_TABLE_SIZE = 65


@functools.lru_cache(maxsize=4)
def directional_albedo_table(n: int = DFG_TABLE_SIZE, nt: int = 768,
                             nphi: int = 96) -> np.ndarray:
    """``[n, n, 2]`` float32 (rows: perceptual roughness r = i / (n - 1); columns: n.v = j / (n -
    1)): (x, y) with y = E(n.v, r^2), the hemispherical integral of the single-scattering GGX
    (height-correlated Smith) f cos with F = 1, and x its Schlick (1 - v.h)^5 part. The DFG LUT's
    layout and texel-centre convention (``ibl_dfg``). A float64 midpoint rule over the GGX
    half-vector CDF (t, phi) with weight G2 (v.h) / ((n.v)(n.h)) where n.l > 0; n.v = 0 is taken
    at 1e-3 (the integral's limit is reached well before) and r is clamped as shading clamps it.
    """
    t = (np.arange(nt) + 0.5) / nt
    phi = (np.arange(nphi) + 0.5) / nphi * 2.0 * math.pi
    out = np.zeros((n, n, 2), np.float64)
    for i in range(n):
        r = max(i / (n - 1), MIN_PERCEPTUAL_ROUGHNESS)
        a2 = (r * r) ** 2
        cos2 = (1.0 - t) / (1.0 + (a2 - 1.0) * t)
        hz = np.sqrt(cos2)[:, None]
        hx = np.sqrt(1.0 - cos2)[:, None] * np.cos(phi)[None]
        for j in range(n):
            mu = max(j / (n - 1), 1e-3)
            voh = math.sqrt(1.0 - mu * mu) * hx + mu * hz
            nol = 2.0 * voh * hz - mu
            nl = np.clip(nol, 1e-12, 1.0)
            vis = 0.5 / (nl * math.sqrt(mu * mu * (1.0 - a2) + a2)
                         + mu * np.sqrt(nl * nl * (1.0 - a2) + a2))
            w = np.where(nol > 0.0, vis * 4.0 * mu * nl * voh / (mu * hz), 0.0)
            out[i, j, 1] = w.mean()
            out[i, j, 0] = (w * (1.0 - np.clip(voh, 0.0, 1.0)) ** 5).mean()
    return out.astype(np.float32)


def brdf_cos_numpy(albedo, roughness, metallic, specular, n_dot_v, wo, multiscatter=False,
                   dielectric=None):
    """Our f cos for local directions (shading frame, z = normal), in numpy float64: the same
    formula as :class:`WorkbenchBSDF`'s ``eval``, for tests that check the plugin against an
    independent evaluation. ``wo`` ``[N, 3]`` unit; the view direction is (sqrt(1 - n.v^2), 0,
    n.v). ``dielectric``: glTF's lobe, (F0 r, g, b, F90) (``Material.dielectric``), or None for
    Filament's from ``specular``. -> ``[N, 3]``."""
    albedo = np.asarray(albedo, np.float64)
    wo = np.asarray(wo, np.float64)
    wi = np.array([math.sqrt(max(1.0 - n_dot_v ** 2, 0.0)), 0.0, n_dot_v])
    r = min(max(roughness, MIN_PERCEPTUAL_ROUGHNESS), 1.0)
    a2 = (r * r) ** 2
    if dielectric is None or dielectric[3] < 0.0:
        f0 = 0.16 * specular ** 2 * (1 - metallic) + albedo * metallic
        f90 = min(max(16.5 * f0.sum(), 0.0), 1.0)
    else:
        f0 = np.asarray(dielectric[:3], np.float64) * (1 - metallic) + albedo * metallic
        f90 = dielectric[3] * (1 - metallic) + metallic
    table = directional_albedo_table()
    x, y = _bilinear(table, n_dot_v, r)
    c_ms = 1.0 + f0 * (1.0 / max(y, 1e-4) - 1.0) if multiscatter else np.ones(3)
    e_spec = (f0 * (y - x) + f90 * x) * c_ms
    kd = albedo * (1.0 - metallic) * np.maximum(1.0 - e_spec, 0.0)
    nol = wo[:, 2]
    h = wo + wi
    h /= np.linalg.norm(h, axis=1, keepdims=True)
    noh = np.clip(h[:, 2], 0, 1)
    voh = np.clip(h @ wi, 0, 1)
    f = noh * noh * a2 + (1 - noh) * (1 + noh)
    d = a2 / (math.pi * f * f)
    nl = np.clip(nol, 0, 1)
    v = 0.5 / (nl * math.sqrt(n_dot_v ** 2 * (1 - a2) + a2)
               + n_dot_v * np.sqrt(nl ** 2 * (1 - a2) + a2))
    fr = f0[None] + (f90 - f0[None]) * ((1 - voh) ** 5)[:, None]
    val = (kd[None] / math.pi + (d * v)[:, None] * fr * c_ms[None]) * nl[:, None]
    return np.where((nol > 0)[:, None], val, 0.0)


def _bilinear(table: np.ndarray, mu: float, r: float) -> tuple[float, float]:
    n = table.shape[0]
    x = min(max(mu, 0.0), 1.0) * (n - 1)
    y = min(max(r, 0.0), 1.0) * (n - 1)
    j0, i0 = min(int(x), n - 2), min(int(y), n - 2)
    fx, fy = x - j0, y - i0
    top = table[i0, j0] * (1 - fx) + table[i0, j0 + 1] * fx
    bottom = table[i0 + 1, j0] * (1 - fx) + table[i0 + 1, j0 + 1] * fx
    v = top * (1 - fy) + bottom * fy
    return float(v[0]), float(v[1])
