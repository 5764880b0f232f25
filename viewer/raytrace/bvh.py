"""A bounding-volume hierarchy over triangles, built on the CPU with binned SAH (Wald 2007, "On
fast Construction of SAH-based Bounding Volume Hierarchies"): at each node the centroids are
binned along each axis into :data:`BINS` bins and the split of least surface-area cost is taken;
a node becomes a leaf when no split is cheaper than intersecting its triangles (at most
:data:`MAX_LEAF` of them) or when it reaches :data:`MAX_DEPTH` (the GLSL traversal stack's size).

The build is compiled with numba (the compilation is cached on disk): about 1.5 s for a
tessellated sphere of a million triangles and 3 s for a random soup of as many on llvmpipe's
2-core CI machine (``relight bench --suite path``). The layout is what ``shaders/passes/raytrace.glsl`` traverses:

=========== ============================================================================
array        per node ``i``
=========== ============================================================================
``lo[i]``    box minimum (float32 xyz)
``hi[i]``    box maximum
``first[i]`` interior: index of the left child (the right one is ``first + 1``);
             leaf: index of its first triangle in ``order``
``count[i]`` 0 for an interior node, else the leaf's triangle count
=========== ============================================================================

``order`` lists the triangles leaf by leaf, so a leaf's triangles are one contiguous range once
the triangle arrays are permuted by it. Node 0 is the root; an empty input has no nodes.

The GPU reads another layout of the same tree (:func:`child_pairs`): each interior node holds its
two children's boxes, so a visit reads the two boxes it tests and nothing else, and a leaf is a
child entry pointing at its triangles, never a node of its own (a node and its children took 6
reads where this takes 4; a leaf, 2 where this takes none).
"""
from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np
from numba import njit

BINS = 16          # centroid bins per axis
MAX_LEAF = 8       # a leaf holds at most this many triangles (unless MAX_DEPTH forces it)
MAX_DEPTH = 40     # the traversal stack in GLSL holds this many nodes (RAYTRACE_STACK)
TRAVERSAL_COST = 1.0  # SAH cost of visiting a node, relative to one triangle test (1.0)


@dataclass
class BVH:
    lo: np.ndarray      # [M, 3] float32 node boxes
    hi: np.ndarray      # [M, 3] float32
    first: np.ndarray   # [M] int32
    count: np.ndarray   # [M] int32
    order: np.ndarray   # [N] int32: triangle indices, leaf by leaf
    depth: int          # the deepest leaf's depth (root = 0)
    seconds: float      # build time (wall clock)

    @property
    def node_count(self) -> int:
        return int(self.first.shape[0])

    @property
    def nbytes(self) -> int:
        return int(self.lo.nbytes + self.hi.nbytes + self.first.nbytes + self.count.nbytes
                   + self.order.nbytes)

    def sah_cost(self) -> float:
        """The tree's SAH cost relative to its root's area: sum over interior nodes of
        TRAVERSAL_COST x area + over leaves of count x area, / the root's area (a quality
        measure for tests and the bench: lower is better)."""
        if self.node_count == 0:
            return 0.0
        ext = np.maximum(self.hi.astype(np.float64) - self.lo, 0.0)
        area = ext[:, 0] * ext[:, 1] + ext[:, 1] * ext[:, 2] + ext[:, 2] * ext[:, 0]
        cost = np.where(self.count > 0, self.count, TRAVERSAL_COST) * area
        return float(cost.sum() / max(area[0], 1e-30))


def build_bvh(lo: np.ndarray, hi: np.ndarray) -> BVH:
    """The BVH over boxes ``lo``, ``hi`` (``[N, 3]``, one per triangle; finite)."""
    lo = np.ascontiguousarray(lo, np.float32)
    hi = np.ascontiguousarray(hi, np.float32)
    t0 = time.perf_counter()
    n = lo.shape[0]
    if n == 0:
        z3, z = np.zeros((0, 3), np.float32), np.zeros(0, np.int32)
        return BVH(z3, z3.copy(), z, z.copy(), z.copy(), 0, 0.0)
    nlo, nhi, first, count, order, used, depth = _build(lo, hi, BINS, MAX_LEAF, MAX_DEPTH,
                                                         TRAVERSAL_COST)
    return BVH(nlo[:used].copy(), nhi[:used].copy(), first[:used].copy(), count[:used].copy(),
               order, int(depth), time.perf_counter() - t0)


def child_pairs(bvh: BVH) -> np.ndarray:
    """``[K, 16]`` float32: the tree as ``shaders/passes/raytrace.glsl`` reads it, one row per
    interior node (the root first, then the others in ``bvh``'s order): for its left and then its
    right child, ``lo xyz, ref, hi xyz, count`` (``ref`` and ``count`` int bits); ``count > 0``:
    a leaf of ``count`` triangles from ``ref``, ``count = 0``: the interior node of row ``ref``. A
    root that is itself a leaf gets one row whose two children are that leaf (a ray tests its
    triangles twice: the second finds nothing nearer). No nodes: no rows."""
    m = bvh.node_count
    if m == 0:
        return np.zeros((0, 16), np.float32)
    inner = np.flatnonzero(bvh.count == 0)
    if len(inner) == 0:  # the root is a leaf
        left = right = np.zeros(1, np.int64)
    else:
        left = bvh.first[inner].astype(np.int64)
        right = left + 1
    row = np.full(m, -1, np.int64)
    row[inner] = np.arange(len(inner))
    out = np.zeros((max(len(inner), 1), 16), np.float32)
    for c, at in ((left, 0), (right, 8)):
        leaf = bvh.count[c] > 0
        out[:, at:at + 3] = bvh.lo[c]
        out[:, at + 3] = np.where(leaf, bvh.first[c], row[c]).astype(np.int32).view(np.float32)
        out[:, at + 4:at + 7] = bvh.hi[c]
        out[:, at + 7] = bvh.count[c].astype(np.int32).view(np.float32)
    return out


def triangle_boxes(positions: np.ndarray, triangles: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Each triangle's box: ``positions [V, 3]``, ``triangles [N, 3]`` -> ``lo, hi [N, 3]``."""
    p = positions[triangles]  # [N, 3, 3]
    return p.min(axis=1), p.max(axis=1)


@njit(cache=True)
def _area(lo0, lo1, lo2, hi0, hi1, hi2):
    dx, dy, dz = hi0 - lo0, hi1 - lo1, hi2 - lo2
    if dx < 0.0:
        return 0.0
    return dx * dy + dy * dz + dz * dx


@njit(cache=True)
def _build(lo, hi, bins, max_leaf, max_depth, traversal_cost):  # pragma: no cover - compiled
    n = lo.shape[0]
    cen = (lo.astype(np.float64) + hi) * 0.5
    order = np.arange(n).astype(np.int32)
    cap = 2 * n
    nlo = np.empty((cap, 3), np.float32)
    nhi = np.empty((cap, 3), np.float32)
    first = np.zeros(cap, np.int32)
    count = np.zeros(cap, np.int32)
    # stack of (node, start, end, depth)
    st_node = np.empty(max_depth * 2 + 8, np.int64)
    st_start = np.empty(max_depth * 2 + 8, np.int64)
    st_end = np.empty(max_depth * 2 + 8, np.int64)
    st_depth = np.empty(max_depth * 2 + 8, np.int64)
    sp = 0
    st_node[0], st_start[0], st_end[0], st_depth[0] = 0, 0, n, 0
    sp = 1
    used = 1
    deepest = 0
    bcount = np.zeros((3, bins), np.int64)
    blo = np.empty((3, bins, 3))
    bhi = np.empty((3, bins, 3))
    rcost_area = np.empty(bins)
    rcnt = np.empty(bins, np.int64)
    while sp > 0:
        sp -= 1
        node, start, end, depth = st_node[sp], st_start[sp], st_end[sp], st_depth[sp]
        if depth > deepest:
            deepest = depth
        # the node's box and its centroids' box
        b0 = np.full(3, np.inf)
        b1 = np.full(3, -np.inf)
        c0 = np.full(3, np.inf)
        c1 = np.full(3, -np.inf)
        for k in range(start, end):
            t = order[k]
            for a in range(3):
                if lo[t, a] < b0[a]:
                    b0[a] = lo[t, a]
                if hi[t, a] > b1[a]:
                    b1[a] = hi[t, a]
                if cen[t, a] < c0[a]:
                    c0[a] = cen[t, a]
                if cen[t, a] > c1[a]:
                    c1[a] = cen[t, a]
        for a in range(3):
            nlo[node, a] = b0[a]
            nhi[node, a] = b1[a]
        cnt = end - start
        leaf = cnt <= 2 or depth >= max_depth
        best_axis, best_bin = -1, -1
        if not leaf:
            best = np.inf
            node_area = _area(b0[0], b0[1], b0[2], b1[0], b1[1], b1[2])
            for a in range(3):
                ext = c1[a] - c0[a]
                if ext <= 0.0:
                    continue
                scale = bins / ext
                for b in range(bins):
                    bcount[a, b] = 0
                    for j in range(3):
                        blo[a, b, j] = np.inf
                        bhi[a, b, j] = -np.inf
                for k in range(start, end):
                    t = order[k]
                    b = int((cen[t, a] - c0[a]) * scale)
                    if b >= bins:
                        b = bins - 1
                    bcount[a, b] += 1
                    for j in range(3):
                        if lo[t, j] < blo[a, b, j]:
                            blo[a, b, j] = lo[t, j]
                        if hi[t, j] > bhi[a, b, j]:
                            bhi[a, b, j] = hi[t, j]
                # sweep from the right: area and count of bins b..bins-1
                r0 = np.full(3, np.inf)
                r1 = np.full(3, -np.inf)
                rc = 0
                for b in range(bins - 1, 0, -1):
                    rc += bcount[a, b]
                    for j in range(3):
                        r0[j] = min(r0[j], blo[a, b, j])
                        r1[j] = max(r1[j], bhi[a, b, j])
                    rcost_area[b] = _area(r0[0], r0[1], r0[2], r1[0], r1[1], r1[2])
                    rcnt[b] = rc
                l0 = np.full(3, np.inf)
                l1 = np.full(3, -np.inf)
                lc = 0
                for b in range(bins - 1):  # split between bin b and b + 1
                    lc += bcount[a, b]
                    for j in range(3):
                        l0[j] = min(l0[j], blo[a, b, j])
                        l1[j] = max(l1[j], bhi[a, b, j])
                    if lc == 0 or rcnt[b + 1] == 0:
                        continue
                    c = (lc * _area(l0[0], l0[1], l0[2], l1[0], l1[1], l1[2])
                         + rcnt[b + 1] * rcost_area[b + 1])
                    if c < best:
                        best, best_axis, best_bin = c, a, b
            if best_axis < 0:
                leaf = True  # every centroid coincides: no split separates them
            elif node_area > 0.0 and cnt <= max_leaf and \
                    traversal_cost + best / node_area >= cnt:
                leaf = True
        mid = start
        if not leaf:
            a = best_axis
            scale = bins / (c1[a] - c0[a])
            i, j = start, end - 1
            while i <= j:
                b = int((cen[order[i], a] - c0[a]) * scale)
                if b >= bins:
                    b = bins - 1
                if b <= best_bin:
                    i += 1
                else:
                    tmp = order[i]
                    order[i] = order[j]
                    order[j] = tmp
                    j -= 1
            mid = i
            if mid == start or mid == end:
                leaf = True
        if leaf:
            first[node] = start
            count[node] = cnt
            continue
        left = used
        used += 2
        first[node] = left
        count[node] = 0
        # right pushed first: the left subtree is built (and laid out) first
        st_node[sp], st_start[sp], st_end[sp], st_depth[sp] = left + 1, mid, end, depth + 1
        sp += 1
        st_node[sp], st_start[sp], st_end[sp], st_depth[sp] = left, start, mid, depth + 1
        sp += 1
    return nlo, nhi, first, count, order, used, deepest
