"""The ``KHR_materials_sheen`` lobe of :mod:`relight.reference.bsdf` in float64 (shaders/lib/layers.glsl
evaluated exactly), and the table of its directional albedo ``E(n.v, r)`` the rasteriser and this
plugin share (``shaders/lib/sheen_table.glsl``, written by :func:`write_table_glsl`).

The lobe (the glTF specification's sheen, as the Khronos sample viewer evaluates it):

    f_sheen cos = C D_charlie(n.h; a) V_charlie(n.v, n.l; a) (n.l),     a = r^2,
    D_charlie = (2 + 1/a) sin(theta_h)^(1/a) / (2 pi)            (Estevez & Kulla 2017),
    V_charlie = min(1 / ((1 + L(n.v) + L(n.l)) 4 (n.v) (n.l)), 1),

L the spec's fitted Charlie Lambda (``sheen_lambda``), C the sheen colour, r the sheen roughness
clamped to [0.07, 1] (three.js's clamp: ``pow(sin^2, 1/(2a))`` stays finite). The clamp of V at 1
is the sample viewer's. Cosines are floored at :data:`MIN_COS` inside V (E jumps at n.v = 0
exactly: the table would otherwise carry a value no open set of directions has).

Energy: with the fitted Lambda this lobe reflects more than it receives at grazing views when
r < 0.19 (its directional albedo peaks at 1.64 for r = 0.07, n.v = 0.001; 1.24 at r = 0.13; 2.5
without V's clamp; the spec's cheaper Ashikhmin visibility is worse). Below that roughness the
lobe is divided by N(r) = max over n.v of its albedo (a constant per material: reciprocity
kept), so its albedo never exceeds 1; at r >= 0.19 N = 1 and the lobe is the spec's.
:data:`SHEEN_NORMALIZATION` holds N at the table's roughness samples (linear in between; N is
convex, so the interpolated N is never below the true one).

The base under it keeps ``1 - max3(C) max(E(n.v), E(n.l))`` of itself (the spec's albedo scaling,
``min(1 - max3(C) E(VdotN), 1 - max3(C) E(LdotN))``): reciprocal, and with E <= 1 never more
than the base alone reflects plus the sheen's own albedo."""
from __future__ import annotations

import math
import re

import numpy as np

SHEEN_MIN_ROUGHNESS = 0.07
MIN_COS = 1e-4
# (n.v, r) samples a side: sqrt(n.v) uniform in [0, 1] (E varies fastest near grazing), r
# uniform in [0.07, 1]. Bilinear interpolation error measured against the quadrature at the cell
# midpoints of a table twice as fine: -0.0029 .. +0.0005 along n.v, -0.007 .. +0.0045 along r
TABLE_SIZE = 33


def sheen_lambda(cos_theta, a):
    """The spec's fitted Charlie Lambda(cos theta) at alpha ``a`` (``lambdaSheen``)."""
    def fit(x):
        t = (1.0 - a) ** 2
        return ((21.5473 + (25.3245 - 21.5473) * t) / (1.0 + (3.82987 + (3.32435 - 3.82987) * t)
                                                       * np.power(x, 0.19823 + (0.16801 - 0.19823) * t))
                + (-1.97760 + (-1.27393 + 1.97760) * t) * x + (-4.32054 + (-4.85967 + 4.32054) * t))
    c = np.abs(cos_theta)
    return np.where(c < 0.5, np.exp(fit(c)), np.exp(2.0 * fit(0.5) - fit(1.0 - c)))


def sheen_cos_numpy(color, roughness, n_dot_v, wo) -> np.ndarray:
    """C D V n.l / N(r) for local directions ``wo`` ``[N, 3]`` (z = the normal; the view
    (sqrt(1 - n.v^2), 0, n.v)), float64 -> ``[N, 3]`` (``color`` RGB)."""
    wo = np.asarray(wo, np.float64)
    wi = np.array([math.sqrt(max(1.0 - n_dot_v ** 2, 0.0)), 0.0, n_dot_v])
    return (np.asarray(color, np.float64)[None, :]
            * (_charlie_cos(wi, wo, roughness) / normalization(roughness))[:, None])


def normalization(roughness) -> float:
    """N(r) of the shipped table (lib/layers.glsl ``sheen_normalization``), float64."""
    _, rs = table_axes()
    return float(np.interp(min(max(roughness, SHEEN_MIN_ROUGHNESS), 1.0), rs,
                           read_table(normalization=True)))


def _charlie_cos(wi, wo, roughness):
    """D V n.l of the sheen lobe (colour 1) for ``wi`` [3] and ``wo`` [N, 3] (local)."""
    r = min(max(roughness, SHEEN_MIN_ROUGHNESS), 1.0)
    a = r * r
    h = wo + wi
    h = h / np.maximum(np.linalg.norm(h, axis=-1, keepdims=True), 1e-300)
    sin2 = np.maximum(1.0 - h[..., 2] ** 2, 0.0)
    d = (2.0 + 1.0 / a) * np.power(sin2, 0.5 / a) / (2.0 * math.pi)
    nv, nl = max(wi[2], MIN_COS), np.maximum(wo[..., 2], MIN_COS)
    v = np.minimum(1.0 / ((1.0 + sheen_lambda(nv, a) + sheen_lambda(nl, a)) * 4.0 * nv * nl), 1.0)
    return np.where(wo[..., 2] > 0.0, d * v * wo[..., 2], 0.0)


def sheen_albedo_quadrature(n_dot_v: float, roughness: float, cells: int = 512) -> float:
    """E(n.v, r): the spec lobe's directional albedo (colour 1, before N), a midpoint rule over
    the hemisphere in (cos theta, phi) with ``cells`` x ``cells / 2`` cells over phi in [0, pi]
    (the lobe is symmetric about the plane of incidence: twice that half)."""
    mu = (np.arange(cells) + 0.5) / cells
    phi = (np.arange(cells // 2) + 0.5) / (cells // 2) * math.pi
    m, p = np.meshgrid(mu, phi, indexing="ij")
    s = np.sqrt(1.0 - m * m)
    wo = np.stack([s * np.cos(p), s * np.sin(p), m], -1)
    nv = max(n_dot_v, MIN_COS)
    wi = np.array([math.sqrt(1.0 - nv * nv), 0.0, nv])
    return float(_charlie_cos(wi, wo, roughness).mean() * 2.0 * math.pi)


def table_axes(size: int = TABLE_SIZE) -> tuple[np.ndarray, np.ndarray]:
    """(n.v samples, r samples) of the table."""
    return np.linspace(0.0, 1.0, size) ** 2, np.linspace(SHEEN_MIN_ROUGHNESS, 1.0, size)


def compute_table(size: int = TABLE_SIZE, cells: int = 512) -> tuple[np.ndarray, np.ndarray]:
    """(``[size (r), size (n.v)]`` the albedo E / N of the normalised lobe, ``[size]`` N(r)),
    float64: :func:`sheen_albedo_quadrature` at every sample, N the maximum of E over the
    samples and a finer search of grazing views (n.v in [1e-4, 0.06]) (about 40 s)."""
    mus, rs = table_axes(size)
    grazing = np.geomspace(1e-4, 0.06, 40)
    raw = np.array([[sheen_albedo_quadrature(mu, r, cells) for mu in mus] for r in rs])
    peak = np.array([max(raw[k].max(), max(sheen_albedo_quadrature(mu, r, cells)
                                           for mu in grazing)) if r < 0.3 else raw[k].max()
                     for k, r in enumerate(rs)])
    norm = np.maximum(peak, 1.0)
    return raw / norm[:, None], norm


TABLE_FILE = "lib/sheen_table.glsl"


def write_table_glsl(path=None, tables=None) -> str:
    """Write ``shaders/lib/sheen_table.glsl`` (the constant arrays ``SHEEN_ALBEDO_TABLE``, rows
    of r, columns of sqrt(n.v), and ``SHEEN_NORMALIZATION``, N at each r) from
    :func:`compute_table`; returns its text."""
    from shaders import SHADER_ROOT

    table, norm = compute_table() if tables is None else tables
    n = table.shape[0]
    rows = ",\n".join("    " + ", ".join(f"{x:.7f}" for x in row) for row in table)
    norms = ",\n".join("    " + ", ".join(f"{x:.7f}" for x in norm[k:k + 11])
                        for k in range(0, n, 11))
    text = (f"// sheen_table.glsl - generated by relight.reference.sheen.write_table_glsl; do not "
            f"edit.\n// KHR_materials_sheen's directional albedo E(n.v, r) (lib/layers.glsl "
            f"sheen_albedo): {n} x {n}\n// samples, rows r = 0.07 .. 1, columns sqrt(n.v) = 0 .. 1 "
            f"(both uniform), each a float64 midpoint\n// quadrature (512 x 256 cells) of the "
            f"Charlie lobe with the clamped visibility, divided by N(r).\n"
            f"#define SHEEN_TABLE_SIZE {n}\n"
            f"const float SHEEN_ALBEDO_TABLE[{n * n}] = float[](\n{rows});\n"
            f"// N(r) = max(1, the spec lobe's largest albedo) at the same r samples\n"
            f"const float SHEEN_NORMALIZATION[{n}] = float[](\n{norms});\n")
    (path or SHADER_ROOT / TABLE_FILE).write_text(text)
    return text


def read_table(normalization: bool = False) -> np.ndarray:
    """The shipped table ``[size (r), size (n.v)]`` (or, with ``normalization``, N ``[size]``)
    as the shaders compile them (float32 values)."""
    from shaders import SHADER_ROOT

    parts = (SHADER_ROOT / TABLE_FILE).read_text().split("float[](")
    body = parts[2 if normalization else 1].split(")", 1)[0]
    values = np.array([float(x) for x in re.findall(r"-?\d+\.\d+(?:e-?\d+)?", body)], np.float32)
    if normalization:
        return values.astype(np.float64)
    n = int(round(math.sqrt(values.size)))
    return values.reshape(n, n).astype(np.float64)


def sheen_albedo_lookup(table: np.ndarray, n_dot_v, roughness):
    """Bilinear lookup of ``table`` (lib/layers.glsl ``sheen_albedo``), numpy."""
    n = table.shape[0]
    x = np.sqrt(np.clip(n_dot_v, 0.0, 1.0)) * (n - 1)
    y = (np.clip(roughness, SHEEN_MIN_ROUGHNESS, 1.0) - SHEEN_MIN_ROUGHNESS) \
        / (1.0 - SHEEN_MIN_ROUGHNESS) * (n - 1)
    i, j = np.minimum(np.floor(x), n - 2).astype(int), np.minimum(np.floor(y), n - 2).astype(int)
    fx, fy = x - i, y - j
    return ((table[j, i] * (1 - fx) + table[j, i + 1] * fx) * (1 - fy)
            + (table[j + 1, i] * (1 - fx) + table[j + 1, i + 1] * fx) * fy)


if __name__ == "__main__":  # regenerate the shaders' table
    write_table_glsl()


# ---- the Mitsuba plugin's share (Dr.Jit values; relight.reference.bsdf) -----------------------
def table_texture(mi, dr):
    """The shipped table as a bilinear ``mi.Texture2f`` (u = sqrt(n.v), v = the roughness axis;
    texel centres on the samples, as :func:`sheen_albedo_lookup`)."""
    t = read_table()
    return mi.Texture2f(mi.TensorXf(t.astype(np.float32)[..., None]), use_accel=False,
                        filter_mode=dr.FilterMode.Linear, wrap_mode=dr.WrapMode.Clamp)


def _albedo(mi, dr, table, cos_theta, r):
    n = TABLE_SIZE
    x = dr.sqrt(dr.clip(cos_theta, 0.0, 1.0))
    y = (r - SHEEN_MIN_ROUGHNESS) / (1.0 - SHEEN_MIN_ROUGHNESS)
    return table.eval(mi.Point2f((x * (n - 1) + 0.5) / n, (y * (n - 1) + 0.5) / n))[0]


def sheen_state(mi, dr, bsdf, si, wi, base_albedo):
    """The sheen at the hit: colour, roughness (clamped), E(n.v), the lobe probability against
    the base's albedo ``base_albedo`` (luminance); ``wi`` in the base's (mapped) frame. None for
    a material without a sheen."""
    m = bsdf.material
    if m is None or max(m.sheen_color) <= 0.0:
        return None
    color = mi.Color3f(*m.sheen_color)
    if bsdf.sheen_color_texture is not None:
        color = color * bsdf.sheen_color_texture.eval(si)
    rough = mi.Float(m.sheen_roughness)
    if bsdf.sheen_roughness_texture is not None:
        rough = rough * bsdf.sheen_roughness_texture.eval(si).x
    r = dr.clip(rough, SHEEN_MIN_ROUGHNESS, 1.0)
    norm = read_table(normalization=True)
    y = (r - SHEEN_MIN_ROUGHNESS) / (1.0 - SHEEN_MIN_ROUGHNESS) * (TABLE_SIZE - 1)
    j = dr.minimum(mi.UInt32(y), TABLE_SIZE - 2)
    table_n = mi.Float(norm.astype(np.float32))
    n_r = dr.lerp(dr.gather(mi.Float, table_n, j), dr.gather(mi.Float, table_n, j + 1),
                  y - mi.Float(j))
    e_v = _albedo(mi, dr, bsdf.sheen_table, mi.Frame3f.cos_theta(wi), r)
    c_max = dr.maximum(dr.maximum(color.x, color.y), color.z)
    e_sh = c_max * e_v
    under = (1.0 - e_sh) * base_albedo
    p = dr.select(e_sh + under > 0.0, e_sh / dr.maximum(e_sh + under, 1e-12), 0.0)
    p = dr.select((e_sh > 0.0) & (under > 0.0), dr.clip(p, 0.05, 0.95), p)
    return dict(color=color, r=r, a=r * r, e_v=e_v, c_max=c_max, p=p, norm=n_r)


def sheen_scaling(mi, dr, bsdf, st, wo):
    """The base's share 1 - max3(C) max(E(n.v), E(n.l)) for ``wo`` (the mapped frame)."""
    e_l = _albedo(mi, dr, bsdf.sheen_table, dr.abs(mi.Frame3f.cos_theta(wo)), st["r"])
    return 1.0 - st["c_max"] * dr.maximum(st["e_v"], e_l)


def _lambda(dr, c, a):
    t = (1.0 - a) * (1.0 - a)

    def fit(x):
        return ((21.5473 * (1 - t) + 25.3245 * t)
                / (1.0 + (3.82987 * (1 - t) + 3.32435 * t) * dr.power(x, 0.19823 * (1 - t)
                                                                      + 0.16801 * t))
                + (-1.97760 * (1 - t) - 1.27393 * t) * x + (-4.32054 * (1 - t) - 4.85967 * t))
    return dr.select(c < 0.5, dr.exp(fit(c)), dr.exp(2.0 * fit(0.5) - fit(1.0 - c)))


def sheen_eval(mi, dr, st, wi, wo):
    """C D_charlie V_charlie n.l for ``wo`` (``wi``, ``wo`` in the base's mapped frame)."""
    nol = mi.Frame3f.cos_theta(wo)
    nov = mi.Frame3f.cos_theta(wi)
    h = dr.normalize(wi + wo)
    a = st["a"]
    sin2 = dr.maximum(h.x * h.x + h.y * h.y, 0.0)
    d = (2.0 + 1.0 / a) * dr.power(sin2, 0.5 / a) / (2.0 * dr.pi)
    nv, nl = dr.clip(nov, MIN_COS, 1.0), dr.clip(nol, MIN_COS, 1.0)
    v = dr.minimum(1.0 / ((1.0 + _lambda(dr, nv, a) + _lambda(dr, nl, a)) * 4.0 * nv * nl), 1.0)
    return dr.select((nol > 0.0) & (nov > 0.0), st["color"] * (d * v * nol / st["norm"]), 0.0)


def sheen_pdf(mi, dr, wi, wo):
    """Density of the sheen's uniform hemisphere sampling."""
    return dr.select((mi.Frame3f.cos_theta(wo) > 0.0) & (mi.Frame3f.cos_theta(wi) > 0.0),
                     0.5 / dr.pi, 0.0)
