"""Point labels that do not overlap, for ``pareto.png`` (:func:`place_labels`).

Each label is tried at offsets on rings around its point (nearest ring first, sixteen directions
each); a place is allowed when the label's box stays inside the axes and overlaps no label placed
before it nor any box to avoid (the legend), and among the allowed places the one covering the
fewest markers and lines, then the nearest, wins. Labels are placed most crowded point first; one
set away from its point gets a thin leader line. All in display pixels, after the figure's layout
is final (call ``fig.canvas.draw()`` first, and save at the figure's own dpi).
"""
from __future__ import annotations

import math

import numpy as np

RINGS_PT = (3, 6, 10, 15, 22, 30, 40, 52, 66, 82, 100)  # offset radii, points
DIRECTIONS = 16
PAD_PX = 1.5  # clearance between a label and anything else


def _boxes_overlap(a, b, pad: float = PAD_PX) -> bool:
    return (a[0] < b[2] + pad and b[0] < a[2] + pad and a[1] < b[3] + pad and b[1] < a[3] + pad)


def _segment_hits_box(p, q, box, pad: float = PAD_PX) -> bool:
    """Whether the segment p-q passes through ``box`` (x0, y0, x1, y1): Liang-Barsky clipping."""
    x0, y0, x1, y1 = box[0] - pad, box[1] - pad, box[2] + pad, box[3] + pad
    dx, dy = q[0] - p[0], q[1] - p[1]
    t0, t1 = 0.0, 1.0
    for den, num in ((-dx, p[0] - x0), (dx, x1 - p[0]), (-dy, p[1] - y0), (dy, y1 - p[1])):
        if den == 0:
            if num < 0:
                return False
        else:
            t = num / den
            if den < 0:
                t0 = max(t0, t)
            else:
                t1 = min(t1, t)
            if t0 > t1:
                return False
    return True


def _alignment(c: float, s: float) -> tuple[str, str]:
    ha = "left" if c > 0.3 else "right" if c < -0.3 else "center"
    va = "bottom" if s > 0.3 else "top" if s < -0.3 else "center"
    return ha, va


def _box_at(anchor, size, ha: str, va: str):
    w, h = size
    x0 = anchor[0] - {"left": 0.0, "center": w / 2, "right": w}[ha]
    y0 = anchor[1] - {"bottom": 0.0, "center": h / 2, "top": h}[va]
    return (x0, y0, x0 + w, y0 + h)


def _obstacles(ax):
    """The axes' markers (centre, radius in px) and line segments, in display coordinates."""
    px = ax.figure.dpi / 72.0
    markers = []
    for c in ax.collections:
        offsets = np.asarray(c.get_offsets())
        if not len(offsets):
            continue
        sizes = np.asarray(c.get_sizes()) if len(c.get_sizes()) else np.array([36.0])
        radius = math.sqrt(float(sizes.max())) / 2 * px
        for xy in c.get_offset_transform().transform(offsets):
            markers.append((xy, radius))
    segments = []
    for line in ax.get_lines():
        v = line.get_transform().transform(np.column_stack(line.get_data()))
        v = v[np.isfinite(v).all(axis=1)]
        segments += [(v[i], v[i + 1]) for i in range(len(v) - 1)]
    return markers, segments


def place_labels(ax, points, labels, fontsize: float = 6, avoid=(), **text_kw) -> list:
    """Annotate ``points`` (data coordinates) of ``ax`` with ``labels`` so that no two labels
    overlap, every label lies inside the axes and clear of the display-space boxes in ``avoid``
    (e.g. the legend's ``get_window_extent()``). Returns the annotations. The figure must have
    been drawn (its layout final) before, and be saved at ``fig.dpi``."""
    fig = ax.figure
    renderer = fig.canvas.get_renderer()
    px = fig.dpi / 72.0
    frame = ax.get_window_extent(renderer)
    inside = (frame.x0 + 2, frame.y0 + 2, frame.x1 - 2, frame.y1 - 2)
    markers, segments = _obstacles(ax)
    blocked = [tuple(b.extents) if hasattr(b, "extents") else tuple(b) for b in avoid]
    xy = ax.transData.transform(np.asarray(points, dtype=float).reshape(-1, 2))
    # most crowded first: the points with the most neighbours within 40 px choose first
    crowd = [int((np.hypot(*(xy - p).T) < 40).sum()) for p in xy]
    order = sorted(range(len(xy)), key=lambda i: (-crowd[i], xy[i][0], xy[i][1]))
    placed: dict[int, object] = {}
    for i in order:
        probe = ax.annotate(labels[i], points[i], xytext=(0, 0), textcoords="offset points",
                            fontsize=fontsize, **text_kw)
        bb = probe.get_window_extent(renderer)
        size = (bb.width, bb.height)
        probe.remove()
        best = None
        for ring, r in enumerate(RINGS_PT):
            for k in range(DIRECTIONS):
                angle = math.pi / 4 + 2 * math.pi * k / DIRECTIONS  # up-right first
                c, s = math.cos(angle), math.sin(angle)
                ha, va = _alignment(c, s)
                box = _box_at((xy[i][0] + r * c * px, xy[i][1] + r * s * px), size, ha, va)
                if not (box[0] >= inside[0] and box[1] >= inside[1] and box[2] <= inside[2]
                        and box[3] <= inside[3]):
                    continue
                if any(_boxes_overlap(box, b) for b in blocked):
                    continue
                covered = sum(_boxes_overlap(box, (m[0] - rad, m[1] - rad, m[0] + rad,
                                                   m[1] + rad)) for m, rad in markers)
                crossed = sum(_segment_hits_box(p, q, box) for p, q in segments)
                cost = (10 * covered + 3 * crossed, ring, k)
                if best is None or cost < best[0]:
                    best = (cost, r * c, r * s, ha, va, box)
            if best is not None and best[0][0] == 0:
                break  # a clear place on this ring: farther rings are only farther
        if best is None:  # nowhere inside the axes is free: keep the first place, say so
            best = ((0, 0, 0), 3.0, 3.0, "left", "bottom", None)
        _, dx, dy, ha, va, box = best
        leader = (dict(arrowstyle="-", lw=0.4, color="0.45", shrinkA=0, shrinkB=2)
                  if math.hypot(dx, dy) > 8 else None)  # far from its point: a leader line
        ann = ax.annotate(labels[i], points[i], xytext=(dx, dy), textcoords="offset points",
                          fontsize=fontsize, ha=ha, va=va, arrowprops=leader, **text_kw)
        if box is not None:
            blocked.append(box)
        placed[i] = ann
    return [placed[i] for i in range(len(xy))]
