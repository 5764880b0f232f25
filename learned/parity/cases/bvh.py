"""Parity cases of ``shaders/lib/bvh.glsl`` against :mod:`learned.twins.bvh`: rays against boxes,
triangles, ellipsoids and Gaussians. The traversal over a whole BVH (``passes/raytrace.glsl``)
is a pass check (:mod:`learned.parity.checks.raytrace`)."""
from __future__ import annotations

import numpy as np

from .base import Arg, ParityCase


def _away_from_edges(args: list[np.ndarray]) -> list[np.ndarray]:
    """Rays aimed at the triangle's interior or well outside it: a ray through an edge is a hit
    on one GL and a miss on another (the barycentric's last rounding), which no tolerance on the
    value can guard; the edges are the BVH check's business. Rays within ~6 deg of the plane are
    moved off it (the hit's error grows as 1 / |sin| of that angle; grazing rays are measured by
    the envelope, not tested)."""
    o, d, p0, p1, p2 = args
    rng = np.random.default_rng(11)
    n = len(o)
    w = rng.dirichlet((1.0, 1.0, 1.0), size=n).astype(np.float32)
    outside = rng.uniform(size=n) < 0.3  # a third of the targets well outside (w < -0.05)
    w[outside, 0] = -0.05 - rng.uniform(0.0, 1.0, size=outside.sum()).astype(np.float32)
    w[outside, 1] = 1.0 - w[outside, 0] - w[outside, 2]
    inside = ~outside
    w[inside] = np.clip(w[inside], 0.02, None)
    w[inside] /= w[inside].sum(axis=1, keepdims=True)
    target = w[:, :1] * p0 + w[:, 1:2] * p1 + w[:, 2:3] * p2
    normal = np.cross(p1 - p0, p2 - p0)
    normal /= np.linalg.norm(normal, axis=1, keepdims=True) + 1e-30
    d = target - o
    grazing = np.abs((normal * d).sum(1)) < 0.1 * np.linalg.norm(d, axis=1)
    side = np.where((normal * (o - target)).sum(1) >= 0.0, 1.0, -1.0)[:, None]
    o = np.where(grazing[:, None], o + normal * side * 1.5, o).astype(np.float32)
    d = target - o
    d /= np.linalg.norm(d, axis=1, keepdims=True) + 1e-30
    return [o, d.astype(np.float32), p0, p1, p2]


def _edges_away_from_edges(args: list[np.ndarray]) -> list[np.ndarray]:
    """:func:`_away_from_edges` on the triangle (p0, p0 + e1, p0 + e2), handed back as its edges
    (float32 differences, as viewer/raytrace/scene.py uploads them)."""
    o, d, p0, e1, e2 = args
    o, d, p0, p1, p2 = _away_from_edges([o, d, p0, p0 + e1, p0 + e2])
    return [o, d, p0, (p1 - p0).astype(np.float32), (p2 - p0).astype(np.float32)]


def _boxes(args: list[np.ndarray]) -> list[np.ndarray]:
    """Boxes with lo <= hi, rays' inverse directions as safe_inverse makes them, entry and exit
    at least 1e-3 apart or 1e-3 from t_max (a grazing ray is a hit on one GL and a miss on
    another)."""
    o, inv_d, lo, hi, t_max = args
    a, b = np.minimum(lo, hi), np.maximum(lo, hi) + 0.05
    t0, t1 = (a - o) * inv_d, (b - o) * inv_d
    near = np.maximum(np.minimum(t0, t1).max(axis=1), 0.0)
    far = np.minimum(np.maximum(t0, t1).min(axis=1), t_max)
    clear = np.abs(far - near) > 1e-3 * (1.0 + np.abs(near))
    keep = np.where(clear)[0]
    pick = keep[np.arange(len(o)) % max(len(keep), 1)] if len(keep) else np.arange(len(o))
    return [o[pick], inv_d[pick], a[pick], b[pick], t_max[pick]]


def _clear_of_tangents(args: list[np.ndarray]) -> list[np.ndarray]:
    """Rays that clearly miss, clearly enter or start clearly inside the sphere: a ray within
    float32 rounding of its tangent (the discriminant ~0), of its surface (c ~ 0) or of being
    perpendicular to o (b ~ 0) is an entry on one GL and a miss on another, which no tolerance on
    the value guards; kept are rays with |disc|, |c|, |b| >= 2 % of their scale."""
    o, d, r2 = args
    a = (d * d).sum(1)
    b = (o * d).sum(1)
    c = (o * o).sum(1) - r2
    disc = b * b - a * c
    scale = a * np.maximum(r2, (o * o).sum(1))
    clear = ((np.abs(disc) > 0.02 * scale) & (np.abs(c) > 0.02 * np.maximum(r2, 1e-3))
             & (np.abs(b) > 0.02 * np.sqrt(scale)))
    keep = np.where(clear)[0]
    pick = keep[np.arange(len(o)) % max(len(keep), 1)] if len(keep) else np.arange(len(o))
    return [o[pick], d[pick], r2[pick]]


PARITY_CASES = [
    ParityCase("gaussian_ray_peak",
               (Arg(lo=-4.0, hi=4.0, components=3), Arg(lo=-30.0, hi=30.0, components=3,
                                                         adversarial=((0.0, 0.0, 0.0),)),
                Arg(lo=0.0, hi=3.0, adversarial=(0.0, 1e30))),
               atol=2e-5, rtol=2e-5,
               measured="max abs 5.7e-6, max rel 1.6e-5 (t, q^2 <= 48; seed 0)",
               envelope="t* = -(o.d) / (d.d): two dot products (3 roundings each, FMA may "
                        "contract) and a division (2.5 ulp): ~1e-6 relative; q^2 = |o + t d|^2 "
                        "cancels where the ray passes near the centre, so its error is ~1e-6 "
                        "of |o|^2 <= 48: 5e-5 abs at worst; 2e-5 + 2e-5 rel covers the "
                        "drawn inputs (the largest relative error is at q^2 ~ 0.3); d = 0 "
                        "(adversarial) gives t = 0 and |o|^2 both sides, t_max = 1e30 no "
                        "clamp"),
    ParityCase("ellipsoid_entry",
               (Arg(lo=-4.0, hi=4.0, components=3), Arg(lo=-30.0, hi=30.0, components=3),
                Arg(lo=0.05, hi=9.0, adversarial=(0.0, -1.0))),
               atol=2e-6, rtol=5e-5, prepare=_clear_of_tangents,
               measured="max abs 1.5e-7, max rel 2.9e-6 (seed 0)",
               envelope="c / (-b + sqrt(b^2 - a c)): no cancellation (b < 0 where it "
                        "enters), ~10 roundings and a sqrt (as 1 / inversesqrt, 3 ulp): "
                        "~1e-6 relative, / the discriminant's relative size where it is small: "
                        "prepare keeps it >= 2 % of a max(r2, |o|^2), so <= 5e-5 rel; the same "
                        "bounds keep entry and miss apart"),
    ParityCase("safe_inverse",
               (Arg(lo=-4.0, hi=4.0, components=3,
                    adversarial=((0.0, 1.0, -1.0), (1e-31, -1e-31, 2.0), (-0.0, 0.5, 1e-20))),),
               atol=0.0, rtol=3e-7, measured="max rel 0 (1 / d is correctly rounded here)",
               envelope="one division, 2.5 ulp by GLSL (llvmpipe and torch round correctly): "
                        "rel 1.5e-7; the zero components map to exactly +-1e30"),
    ParityCase("ray_aabb",
               (Arg(lo=-2.0, hi=2.0, components=3), Arg(lo=-8.0, hi=8.0, components=3),
                Arg(lo=-1.5, hi=1.5, components=3), Arg(lo=-1.5, hi=1.5, components=3),
                Arg(lo=0.5, hi=20.0)),
               atol=1e-6, rtol=1e-5, prepare=_boxes,
               measured="max abs 0, max rel 0 (same roundings both sides)",
               envelope="(lo - o) inv_d: a subtraction and a product, each 0.5 ulp, FMA may "
                        "contract them (1 ulp): rel 2.4e-7 of a distance <= 60; hits and misses "
                        "agree because entry and exit are kept >= 1e-3 apart (prepare)"),
    ParityCase("ray_triangle",
               (Arg(lo=-3.0, hi=3.0, components=3), Arg(kind="unit", components=3),
                Arg(lo=-1.0, hi=1.0, components=3), Arg(lo=-1.0, hi=1.0, components=3),
                Arg(lo=-1.0, hi=1.0, components=3)),
               atol=6e-5, rtol=2e-4, prepare=_away_from_edges,
               measured="max abs 2.4e-5 on t ~ 5, barycentrics 1e-5 (seeds 0-3)",
               envelope="two cross products and three dots (each ~3 roundings, FMA may "
                        "contract) over det: ~1e-6 relative to the operands' scale (3) / |sin| "
                        "of the ray's angle with the plane; prepare keeps |sin| >= 0.1 -> 3e-5 "
                        "abs on t and the barycentrics, doubled for the contraction choices; "
                        "targets keep barycentrics >= 0.02 inside or <= -0.05 outside, so hit "
                        "and miss agree"),
    ParityCase("ray_triangle_edges",
               (Arg(lo=-3.0, hi=3.0, components=3), Arg(kind="unit", components=3),
                Arg(lo=-1.0, hi=1.0, components=3), Arg(lo=-1.0, hi=1.0, components=3),
                Arg(lo=-1.0, hi=1.0, components=3)),
               atol=6e-5, rtol=2e-4, prepare=_edges_away_from_edges,
               measured="max abs 2.4e-5 on t ~ 5, barycentrics 1e-5 (ray_triangle's seeds)",
               envelope="ray_triangle's: the same arithmetic once the edges are taken"),
    ParityCase("ray_offset",
               (Arg(lo=-50.0, hi=50.0, components=3), Arg(kind="unit", components=3),
                Arg(kind="unit", components=3)),
               atol=1e-6, rtol=1e-6, measured="max abs 0 (same roundings)",
               envelope="p + ng scale: one product and one sum per component, 1 ulp of |p| "
                        "<= 50: 6e-6 abs at worst, rel 1.2e-7"),
]
