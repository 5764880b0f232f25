"""Parity cases of ``shaders/lib/shadow.glsl`` against :mod:`learned.twins.shadow`. The lookups that
read the map (``shadow_depth_at``, ``shadow_sample``, ``shadow_blocker_depth``, ``shadow_pcf``,
``shadow_pcss``, ``shadow_visibility``) are the pass check ``shadow:lookups``;
``shadow_light_visibility``, ``shadow_cascade_visibility`` and ``shadow_tile_visibility`` (a mat4
argument) the pass check ``shadow:lights``; ``shadow_map_size``, ``shadow_tile_depth`` and
``shadow_atlas_depth`` (a sampler: the cube and cascade atlases' reads) ``shadow:lookups``."""
from __future__ import annotations

import numpy as np

from .base import Arg, ParityCase

PASS_LEVEL = ("shadow_depth_at", "shadow_sample", "shadow_blocker_depth", "shadow_pcf",
              "shadow_pcss", "shadow_visibility", "shadow_light_visibility", "shadow_map_size",
              "shadow_tile_depth", "shadow_atlas_depth", "shadow_cascade_visibility",
              "shadow_tile_visibility")


def _receiver_planes(args):
    """Consistent inputs of shadow_receiver_depth: a kind (1 orthographic, 2 perspective, 3
    cube) per row, a cube face only for cube maps (-1 otherwise), a positive near and range, a
    plane whose depth (or inverse distance) is positive at uv, offsets of a filter's size."""
    plane, lens, face, uv, o = (np.array(a, np.float32, copy=True) for a in args)
    kind = np.floor(lens[:, 0] * 2.999) + 1.0
    lens[:, 0] = kind
    face = np.where(kind == 3.0, np.clip(np.floor(face), 0, 5), -1.0).astype(np.float32)
    plane[:, 0] = np.abs(plane[:, 0]) + 0.05
    return [plane, lens, face, uv, o * 0.05]

def _cascade_boxes(args):
    """Cascade boxes (scale, u0, v0, 0) of shadow_cascade_index: scales 1..20 (a cascade's tile
    spans 1/scale of the whole-scene map), origins around the point so it falls inside some,
    a count of 1..4."""
    uv = np.array(args[0], np.float32, copy=True)
    boxes = []
    for c in args[1:5]:
        c = np.array(c, np.float32, copy=True)
        c[:, 0] = 1.0 + 19.0 * c[:, 0]
        c[:, 1:3] = uv - (0.5 + (c[:, 1:3] - 0.5) * 1.6) / c[:, 0:1]
        boxes.append(c)
    return [uv] + boxes + [args[5]]


PARITY_CASES = [
    ParityCase("vogel_disk", (Arg(kind="int", lo=0, hi=63), Arg(kind="int", lo=1, hi=64),
                              Arg(lo=0.0, hi=6.2832)),
               atol=2e-5, rtol=0.0,
               measured="max abs 2e-6 on llvmpipe; 1.3e-4 on the H200 before the angle was "
                        "reduced to a turn",
               envelope="sqrt of a quotient (3.5 ulp) times cos/sin of theta in [0, 2 pi): the "
                        "turns i 0.382 + phi / 2 pi (< 25: spacing 2^-19, two roundings or one "
                        "fused, 2e-6 turns = 1.2e-5 rad) and trigonometry ~1e-6 absolute "
                        "(assumed) -> 1.3e-5; a fract wrapping on one side only is a whole turn, "
                        "the same point"),
    ParityCase("shadow_phi", (Arg(kind="int", lo=0, hi=4096, components=2),),
               atol=1.1e-2, rtol=0.0, period=6.2831853,
               measured="max abs ~1e-5 on llvmpipe, 1.0e-2 on the H200",
               envelope="2 pi x contact_jitter's phase: 2 pi x 1.62e-3 = 1.02e-2 (a GPU's FMA "
                        "moves the inner sum, up to 300, by two half-spacings of 2^-15, and "
                        "52.98 amplifies it); compared modulo 2 pi, an angle"),
    ParityCase("shadow_depth_slope", (Arg(lo=-2.0, hi=2.0, components=3,
                                          adversarial=((0.0, 0.0, 1.0), (1.0, 0.5, 0.0),
                                                       (3.0, 4.0, 1.0))),),
               atol=1e-6, rtol=1e-5, measured="max abs 4.8e-7 on llvmpipe",
               envelope="-m.xy / m.z (2.5 ulp division) then a clamp to length 4 (a length: "
                        "sqrt ~3 ulp, a 4 / len division): 6 roundings on values <= 4"),
    ParityCase("shadow_receiver", (Arg(lo=-10.0, hi=10.0, components=3),
                                   Arg(kind="unit", components=3), Arg(kind="unit", components=3),
                                   Arg(lo=1e-4, hi=0.1)),
               atol=1e-6, rtol=1e-6, measured="exact on llvmpipe",
               envelope="p + n t (1.5 + 3 (1 - NoL)): a dot product and 4 roundings on "
                        "|p| <= 17: 5 ulp rel of p"),
    ParityCase("vogel_turn", (Arg(kind="unit", components=2),),
               atol=1e-6, rtol=0.0, measured="exact on llvmpipe",
               envelope="two products and a sum per component on a unit vector: 3 roundings "
                        "(or one fused) of values <= 1: 2e-7 abs"),
    ParityCase("shadow_taps", (Arg(lo=0.0, hi=0.02, adversarial=(0.0, 1.0)),
                               Arg(lo=64.0, hi=2048.0), Arg(kind="int", lo=1, hi=32)),
               atol=0.0, rtol=0.0,
               measured="exact on llvmpipe; off by 3 on the H200 where n_max < 4 made GLSL's "
                        "clamp undefined (now min of max)",
               envelope="an integer: ceil of 1.57 r^2 (3 roundings) differs only within 1e-6 of "
                        "an integer (p ~ 1e-6 per draw); min and max exact"),
    ParityCase("shadow_cube_face", (Arg(kind="unit", components=3,
                                        adversarial=((1, 0, 0), (0, -1, 0), (0, 0, 1))),),
               atol=1e-6, rtol=0.0, measured="exact on llvmpipe",
               envelope="0.5 +- 0.5 x / m: a 2.5 ulp division and 2 roundings on values <= 1; "
                        "the face index is exact (comparisons of the same floats)"),
    ParityCase("shadow_cube_dir", (Arg(kind="int", lo=0, hi=5), Arg(lo=-0.5, hi=1.5,
                                                                       components=2)),
               atol=1e-6, rtol=0.0, measured="exact on llvmpipe",
               envelope="uv 2 - 1: 2 roundings (or one fused) on values <= 3: 4e-7 abs"),
    ParityCase("shadow_plane_normal", (Arg(lo=-2.0, hi=2.0, components=3),
                                       Arg(lo=-2.0, hi=2.0, components=3),
                                       Arg(lo=-2.0, hi=2.0, components=3),
                                       Arg(kind="unit", components=3)),
               atol=1e-5, rtol=1e-5, measured="max abs 9.5e-7 on llvmpipe",
               envelope="a cross product (2 products, a difference) then a dot (3 products, 2 "
                        "sums) on values <= 2: terms <= 12, ~8 roundings: 1e-5 abs"),
    ParityCase("shadow_penumbra_uv", (Arg(lo=0.0, hi=1.0, components=4),
                                      Arg(lo=0.0, hi=1.0), Arg(lo=0.0, hi=1.0)),
               atol=1e-6, rtol=1e-5, measured="exact on llvmpipe",
               envelope="orthographic: 3 products; perspective: two 2.5 ulp reciprocals of "
                        "distances >= near and a difference, relative to their sum (near >= "
                        "0.05 after prepare): 1e-5 rel",
               prepare=lambda a: [np.column_stack([np.floor(a[0][:, 0] * 2.999) + 1.0,
                                                   a[0][:, 1], a[0][:, 2] + 0.05,
                                                   a[0][:, 3] + 0.05]).astype(np.float32),
                                  a[1], a[2]]),
    ParityCase("shadow_receiver_depth", (Arg(lo=-1.0, hi=1.0, components=3),
                                         Arg(lo=0.05, hi=1.0, components=4),
                                         Arg(lo=0.0, hi=6.0), Arg(lo=0.0, hi=1.0, components=2),
                                         Arg(lo=-1.0, hi=1.0, components=2)),
               atol=1e-5, rtol=1e-5, measured="max abs 3e-5 (rel 1.3e-6) on llvmpipe",
               envelope="orthographic: a dot and a sum; perspective and cube: a 2.5 ulp "
                        "reciprocal of the plane's inverse distance (>= 0.25 of the centre's), "
                        "a length (sqrt 3 ulp) and a division by the range: ~10 ulp rel",
               prepare=_receiver_planes),
    ParityCase("shadow_cascade_uv", (Arg(lo=-0.5, hi=1.5, components=3),
                                     Arg(lo=0.0, hi=20.0, components=4)),
               atol=1e-5, rtol=1e-6, measured="exact on llvmpipe",
               envelope="(uv - c.yz) c.x: a difference and a product (or one fused) on values "
                        "<= 40: 2 roundings, 5e-6 abs"),
    ParityCase("shadow_cascade_index", (Arg(components=2), Arg(components=4),
                                        Arg(components=4), Arg(components=4),
                                        Arg(components=4), Arg(kind="int", lo=1, hi=4)),
               atol=0.0, rtol=0.0, measured="exact on llvmpipe",
               envelope="an integer: comparisons of (uv - c.yz) c.x with the margin: the same "
                        "float32 expression both sides (a fused multiply-add could move a point "
                        "within 1e-6 of a tile's margin: p ~ 1e-5 per draw)",
               prepare=_cascade_boxes),
]
