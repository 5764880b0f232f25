"""Twins of ``shaders/lib/bvh.glsl`` (a ray against a box, a triangle, an ellipsoid and a
Gaussian) and of the traversal in ``shaders/passes/raytrace.glsl`` (closest hit and
any hit over the BVH of :mod:`viewer.raytrace.bvh`, handed in as the arrays the GL buffers
hold)."""
from __future__ import annotations

import torch


RAY_MISS = 3.0e38
# rt_materials rows per material (raytrace.glsl RT_MATERIAL_ROWS: RT_ROW_SLOTS factor rows,
# then RT_MAP_SLOTS map slots of two rows; viewer/raytrace/scene.py MATERIAL_VEC4S)
ROW_SURFACE, ROW_SLOTS, MAP_SLOTS = 1, 11, 13
MATERIAL_ROWS = ROW_SLOTS + 2 * MAP_SLOTS
# the gathered opacity at which splats block a shadow ray: raytrace.glsl RT_OPAQUE_AT, the shadow
# maps' per-splat threshold (viewer.raytrace.splat_proxies.OPAQUE_AT; tested equal)
OPAQUE_AT = 0.5


def safe_inverse(d: torch.Tensor) -> torch.Tensor:
    """GLSL ``vec3 safe_inverse(vec3 d)``: ``[..., 3]`` -> 1 / d, a zero component as +-1e30."""
    tiny = torch.where(d >= 0.0, torch.full_like(d, 1.0e-30), torch.full_like(d, -1.0e-30))
    return 1.0 / torch.where(d.abs() < 1.0e-30, tiny, d)


def ray_aabb(o: torch.Tensor, inv_d: torch.Tensor, lo: torch.Tensor, hi: torch.Tensor,
             t_max: torch.Tensor) -> torch.Tensor:
    """GLSL ``float ray_aabb(vec3 o, vec3 inv_d, vec3 lo, vec3 hi, float t_max)``: the entry
    distance in [0, t_max] or RAY_MISS."""
    t0 = (lo - o) * inv_d
    t1 = (hi - o) * inv_d
    near = torch.minimum(t0, t1)
    far = torch.maximum(t0, t1)
    t_near = torch.maximum(torch.maximum(near[..., 0], near[..., 1]),
                           torch.clamp(near[..., 2], min=0.0))
    t_far = torch.minimum(torch.minimum(far[..., 0], far[..., 1]),
                          torch.minimum(far[..., 2], t_max))
    return torch.where(t_near <= t_far, t_near, torch.full_like(t_near, RAY_MISS))


def ray_triangle_edges(o: torch.Tensor, d: torch.Tensor, p0: torch.Tensor, e1: torch.Tensor,
                       e2: torch.Tensor) -> torch.Tensor:
    """GLSL ``vec3 ray_triangle_edges(vec3 o, vec3 d, vec3 p0, vec3 e1, vec3 e2)``
    (Moller-Trumbore on the triangle p0, p0 + e1, p0 + e2): ``(t, b1, b2)``, ``(-1, 0, 0)`` for a
    miss."""
    pv = torch.cross(d, e2, dim=-1)
    det = (e1 * pv).sum(-1)
    ok = det != 0.0
    inv_det = 1.0 / torch.where(ok, det, torch.ones_like(det))
    tv = o - p0
    b1 = (tv * pv).sum(-1) * inv_det
    qv = torch.cross(tv, e1, dim=-1)
    b2 = (d * qv).sum(-1) * inv_det
    t = (e2 * qv).sum(-1) * inv_det
    hit = ok & (b1 >= 0.0) & (b1 <= 1.0) & (b2 >= 0.0) & (b1 + b2 <= 1.0)
    zero = torch.zeros_like(t)
    return torch.stack([torch.where(hit, t, zero - 1.0), torch.where(hit, b1, zero),
                        torch.where(hit, b2, zero)], dim=-1)


def ray_triangle(o: torch.Tensor, d: torch.Tensor, p0: torch.Tensor, p1: torch.Tensor,
                 p2: torch.Tensor) -> torch.Tensor:
    """GLSL ``vec3 ray_triangle(vec3 o, vec3 d, vec3 p0, vec3 p1, vec3 p2)``: ray_triangle_edges
    with ``e1 = p1 - p0``, ``e2 = p2 - p0``."""
    return ray_triangle_edges(o, d, p0, p1 - p0, p2 - p0)


def ray_offset(p: torch.Tensor, ng: torch.Tensor, d: torch.Tensor) -> torch.Tensor:
    """GLSL ``vec3 ray_offset(vec3 p, vec3 ng, vec3 d)``: p moved off the surface towards d."""
    scale = 1.0e-4 * torch.clamp(p.abs().amax(-1), min=1.0)
    side = torch.where((ng * d).sum(-1) >= 0.0, scale, -scale)
    return p + ng * side[..., None]


def gaussian_ray_peak(o: torch.Tensor, d: torch.Tensor, t_max: torch.Tensor) -> torch.Tensor:
    """GLSL ``vec2 gaussian_ray_peak(vec3 o, vec3 d, float t_max)`` (o, d in a Gaussian's unit
    frame): ``[..., 2]`` (t of the peak along the ray within [0, t_max], q^2 there)."""
    dd = (d * d).sum(-1)
    t = torch.where(dd > 0.0, torch.minimum(torch.clamp(-(o * d).sum(-1)
                                                        / torch.where(dd > 0.0, dd, 1.0),
                                                        min=0.0), t_max),
                    torch.zeros_like(dd))
    x = o + t[..., None] * d
    return torch.stack([t, (x * x).sum(-1)], dim=-1)


def ellipsoid_entry(o: torch.Tensor, d: torch.Tensor, r2: torch.Tensor) -> torch.Tensor:
    """GLSL ``float ellipsoid_entry(vec3 o, vec3 d, float r2)``: where the ray enters the sphere
    of squared radius r2 (an ellipsoid's unit frame), -1 for a miss, a start inside, an entry
    behind o or r2 <= 0."""
    a = (d * d).sum(-1)
    b = (o * d).sum(-1)
    c = (o * o).sum(-1) - r2
    disc = b * b - a * c
    ok = (a > 0.0) & (r2 > 0.0) & (c > 0.0) & (b < 0.0) & (disc >= 0.0)
    t = c / (-b + torch.sqrt(torch.clamp(disc, min=0.0)))
    return torch.where(ok, t, torch.full_like(t, -1.0))


# ---- the traversal (passes/raytrace.glsl) -------------------------------------------------------

def _child(nodes: torch.Tensor, row: int, side: int):
    """Child ``side`` (0 left, 1 right) of interior row ``row``: lo, hi, ref, count."""
    a, c = nodes[4 * row + 2 * side], nodes[4 * row + 2 * side + 1]
    return a[:3], c[:3], int(a[3:4].view(torch.int32)), int(c[3:4].view(torch.int32))


def _solid(tri, materials) -> bool:
    """``rt_solid`` for the masks of the parity scenes: a MASK material's base alpha factor
    against its cutoff (the parity scenes have no maps)."""
    rows = materials[int(tri[3]) * MATERIAL_ROWS: int(tri[3]) * MATERIAL_ROWS + MATERIAL_ROWS]
    cutoff = float(rows[ROW_SURFACE, 3])
    if cutoff < 0.0:
        return True
    if float(rows[ROW_SLOTS, 3]) >= 0.0:  # slot 0, the base colour's map
        raise NotImplementedError("the twin tests masks by their factor only (no maps)")
    return float(rows[0, 3]) >= cutoff


def _entered_splat(edges, i: int, d) -> int:
    """``rt_entered_splat``: the splat whose proxy triangle ``i`` is a face of, entered along
    ``d`` (``edges [3N, 4]``: TraceGeometry.edges, the first texel's w 1 + the splat), -1 for
    any other triangle, -2 where the ray leaves the proxy through it."""
    if edges is None or float(edges[3 * i, 3]) < 0.5:
        return -1
    enters = float((torch.linalg.cross(edges[3 * i + 1, :3], edges[3 * i + 2, :3]) * d).sum()) < 0
    return int(edges[3 * i, 3]) - 1 if enters else -2


def _splat_ray(rows, o, d):
    """``rt_splat_ray``: the ray in the splat's unit-Gaussian frame."""
    return rows[:3, :3] @ o + rows[:3, 3], rows[:3, :3] @ d


def bvh_closest_hit(o: torch.Tensor, d: torch.Tensor, t_max: torch.Tensor, nodes, triangles,
                    vertices, materials, splats=None, edges=None) -> torch.Tensor:
    """``RayHit bvh_closest_hit(vec3 o, vec3 d, float t_max)`` over the buffers (``nodes [4K, 4]``
    float32 as uploaded: viewer/raytrace/bvh.py child_pairs, ``triangles [N, 4]`` int,
    ``vertices [2V, 4]``, ``materials [MATERIAL_ROWS K, 4]``; for splats ``splats [4S, 4]`` and
    ``edges [3N, 4]``: TraceGeometry.splats and .edges), ray by ray in the GLSL's order:
    ``[R, 4]`` (t, triangle index as float, b1, b2)."""
    out = torch.zeros(o.shape[0], 4, dtype=torch.float32)
    pos = vertices[0::2, :3]
    for r in range(o.shape[0]):
        oo, dd, best = o[r], d[r], float(t_max[r])
        tri_best, bb = -1, (0.0, 0.0)
        if nodes.shape[0] > 0:
            inv = safe_inverse(dd)
            stack = []
            cur = (0, 0)  # (ref, count): interior row 0, the root
            while cur is not None:
                ref, count = cur
                nxt = None
                if count > 0:
                    for i in range(ref, ref + count):
                        tri = triangles[i]
                        h = ray_triangle(oo, dd, pos[int(tri[0])], pos[int(tri[1])],
                                         pos[int(tri[2])])
                        t = float(h[0])
                        if not 0.0 < t < best:
                            continue
                        s = _entered_splat(edges, i, dd)
                        if s == -2:
                            continue  # leaves the proxy
                        if s >= 0:  # a splat: where the ray enters its opaque core
                            splat = splats[4 * s: 4 * s + 4]
                            oc, dc = _splat_ray(splat, oo, dd)
                            t = float(ellipsoid_entry(oc, dc, splat[3, 1]))
                            if not 0.0 < t < best:
                                continue
                        elif not _solid(tri, materials):
                            continue
                        best, tri_best, bb = t, i, (float(h[1]), float(h[2]))
                else:
                    tb = torch.tensor(best)
                    left, right = _child(nodes, ref, 0), _child(nodes, ref, 1)
                    tl = float(ray_aabb(oo, inv, left[0], left[1], tb))
                    tr = float(ray_aabb(oo, inv, right[0], right[1], tb))
                    near, far = (left, right) if tl <= tr else (right, left)
                    if min(tl, tr) < RAY_MISS:
                        if max(tl, tr) < RAY_MISS:
                            stack.append((far[2:], max(tl, tr)))
                        nxt = near[2:]
                if nxt is None:
                    while stack:
                        cand, t_near = stack.pop()
                        if t_near < best:
                            nxt = cand
                            break
                cur = nxt
        out[r] = torch.tensor([best, float(tri_best), bb[0], bb[1]])
    return out


def bvh_any_hit(o: torch.Tensor, d: torch.Tensor, t_max: torch.Tensor, nodes, triangles,
                vertices, materials, splats=None, edges=None) -> torch.Tensor:
    """``bool bvh_any_hit(vec3 o, vec3 d, float t_max)``: ``[R]`` float (1 blocked, 0 clear):
    blocked by a solid triangle, or once the product of what the entered splats let through
    falls to ``1 - OPAQUE_AT``. Every triangle on the ray is visited (the product does not
    depend on the order the GLSL walks in)."""
    pos = vertices[0::2, :3]
    out = torch.zeros(o.shape[0], dtype=torch.float32)
    p = pos[triangles[:, :3].long()]  # [N, 3, 3]
    for r in range(o.shape[0]):
        oo, dd, tm = o[r], d[r], t_max[r]
        h = ray_triangle(oo.expand(len(p), 3), dd.expand(len(p), 3), p[:, 0], p[:, 1], p[:, 2])
        seen = 1.0
        for i in torch.nonzero((h[:, 0] > 0.0) & (h[:, 0] < tm)).flatten().tolist():
            tri = triangles[i]
            s = _entered_splat(edges, i, dd)
            if s == -2:
                continue
            if s == -1:
                if _solid(tri, materials):
                    seen = 0.0
                    break
                continue
            splat = splats[4 * s: 4 * s + 4]
            oc, dc = _splat_ray(splat, oo, dd)
            q2 = gaussian_ray_peak(oc, dc, tm)[1]
            seen *= float(1.0 - splat[3, 0] * torch.exp(-0.5 * q2))
            if seen <= 1.0 - OPAQUE_AT:
                break
        out[r] = float(seen <= 1.0 - OPAQUE_AT)
    return out
