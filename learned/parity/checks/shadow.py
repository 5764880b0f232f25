"""The shadow-map lookups of ``lib/shadow.glsl`` (``passes/parity_shadow.comp``) against
:mod:`learned.twins.shadow` on the same maps: synthetic maps (a disk occluder, steps and noise,
so blocker search and PCF see partial coverage) read as an orthographic map, a perspective one,
a cube atlas and a cascade atlas of 2 x 2 tiles (``shadow:lookups``); and the composed
``shadow_light_visibility`` of a rendered scene's lights, read from the lighting pass's output
(``shadow:lights``, :mod:`.shadow_lights`)."""
from __future__ import annotations

import numpy as np
import torch

from learned.twins.shadow import (
    SHADOW_PCF_SAMPLES,
    shadow_blocker_depth,
    shadow_depth_slope,
    shadow_map_size,
    shadow_pcf,
    shadow_pcss,
    shadow_sample,
    shadow_taps,
    shadow_visibility,
)
from viewer.gl.kernels import run_kernel

from ..results import ParityResult, compare
from . import collector

SIZE = 64
DEPTH_RANGE, EXTENT = 6.0, 4.0


def shadow_test_map(seed: int = 0) -> np.ndarray:
    """``[SIZE, SIZE]`` float32 depths: 1 (nothing), a disk occluder at 0.3, a step at 0.6 and
    noise, GL row order."""
    rng = np.random.default_rng(seed)
    y, x = np.mgrid[0:SIZE, 0:SIZE] + 0.5
    m = np.ones((SIZE, SIZE), np.float32)
    m[(x - 24) ** 2 + (y - 30) ** 2 < 12 ** 2] = 0.3
    m[:, 46:52] = 0.6
    noise = rng.random((SIZE, SIZE)) < 0.03
    m[noise] = rng.uniform(0.1, 0.9, noise.sum()).astype(np.float32)
    return m


# (name, lens (kind, scale, near, range), map tiles across, down): the three kinds of map
KINDS = (("ortho", (1.0, 0.02, 0.0, DEPTH_RANGE), 1, 1),
         ("perspective", (2.0, 0.05, 0.5, DEPTH_RANGE), 1, 1),
         ("cube", (3.0, 0.025, 0.5, DEPTH_RANGE), 3, 2),
         ("cascade", (1.0, 0.02, 0.0, DEPTH_RANGE), 2, 2))
ENVELOPE = ("texel indices from floor(uv size) of the same float32 uv: a sample's offset "
            "differs by the spiral's rounding (~1e-7 x r <= 0.15) -> 1e-5 texel, so a disk "
            "sample lands in another texel only within 1e-5 texel of a boundary (p ~ 2e-5 per "
            "sample); robust: 1 in 500 values may differ by what one flipped sample does (STEPS)")


# What one sample landing in another texel may change, per result (robust_lookups): nothing for
# the texel read and the slopes (no spiral); 1 / taps for PCF (one sample's share: 1/4 .. 1/32);
# the blocker search's mean depth by at most 1/2 while both sides find an occluder (one value of
# [0, 1] more or less among >= 2), up to 2 where one finds none (-1: the odd taps are skipped);
# the umbra flag by 1; PCSS (and the sun's visibility, its non-adaptive form) by 1/2: a search
# sample moves the mean blocker depth, so the PCF radius and taps, not only one share.
# Measured on llvmpipe: 0 of 2048 lookups beyond 1e-5 for all 23 results, over input seeds 1-20
# (40960 each). The twin with its uv moved by 1e-5 texel (the envelope): 3 of 163840 lookups of
# the four maps changed, each by one PCF share (1/32, 1/4); by 1e-3 texel (100x): pcf <= 0.25 (one
# share, or two of 32), blocker 0.001-0.20 where both find an occluder (56) and 1.1-1.76 where
# one finds none (34), pcss <= 0.5 (median 0.25), visibility <= 0.28 (median 1/32).
STEPS = {"shadow_sample": 0.0, "shadow_blocker_depth": "blocker",
         "shadow_blocker_depth.umbra": 1.0, "shadow_pcf": "1/taps", "shadow_visibility": 0.5,
         "shadow_pcss": 0.5, "shadow_depth_slope.x": 0.0, "shadow_depth_slope.y": 0.0}
MAX_OUTLIERS = 1.0 / 500.0


def _inputs(kind: str, n: int, rng) -> np.ndarray:
    """[n, 13] rows of parity_shadow.comp's inputs for a map of ``kind``."""
    uv = (rng.integers(-2, SIZE + 2, (n, 2)) + 0.25 + 0.5 * rng.random((n, 2))) / SIZE
    s = np.concatenate([uv, rng.uniform(0.05, 1.0, (n, 1))], axis=1)
    radius = rng.uniform(0.0, 0.15, n)
    angle = rng.uniform(0.0, 0.1, n)
    phi = rng.uniform(0.0, 6.2832, n)
    m = rng.normal(size=(n, 3))
    m[:, 2] = np.abs(m[:, 2]) * 3.0  # mostly facing the light; some grazing (clamped)
    m[: n // 8, :2] = 0.0  # facing it: no slope
    face = np.full(n, -1.0) if kind != "cube" else rng.integers(0, 6, n).astype(np.float64)
    if kind == "cascade":  # tile k of a cascade atlas: face -2 - k
        face = -2.0 - rng.integers(0, 4, n).astype(np.float64)
    if kind in ("ortho", "cascade"):
        plane = np.concatenate([s[:, 2:3], np.asarray(shadow_depth_slope(
            torch.from_numpy(m.astype(np.float32))))], axis=1)
    else:  # 1 / distance along the axis at uv and its slope
        near, rng_ = 0.5, DEPTH_RANGE
        inv = 1.0 / (near + s[:, 2] * rng_)
        plane = np.concatenate([inv[:, None], inv[:, None] * rng.normal(0, 0.5, (n, 2))], 1)
    return np.concatenate([s, radius[:, None], angle[:, None], phi[:, None], m, face[:, None],
                           plane], axis=1).astype(np.float32)


def _twins(depth_map, inputs, lens, kind):
    t = torch.from_numpy(np.ascontiguousarray(inputs))
    m = torch.from_numpy(np.ascontiguousarray(depth_map))
    s, r, a, phi = t[:, :3], t[:, 3], t[:, 4], t[:, 5]
    dz = shadow_depth_slope(t[:, 6:9])
    face = t[:, 9].long()
    plane = t[:, 10:13]
    lens_t = torch.tensor(lens, dtype=torch.float32).expand(len(t), 4)
    uv = s[:, :2]
    dir_ = torch.stack([torch.cos(phi), torch.sin(phi)], -1)
    size = shadow_map_size(m, face)
    blocker, umbra = shadow_blocker_depth(m, uv, plane, r, dir_, size, lens_t, face)
    vis = (shadow_visibility(m, s, dz, a, DEPTH_RANGE, EXTENT, phi) if kind == "ortho"
           else torch.zeros(len(t)))
    return [shadow_sample(m, uv, face), blocker, umbra.float(),
            shadow_pcf(m, uv, plane, r, dir_, size, lens_t, face), vis,
            shadow_pcss(m, s, plane, lens_t, phi, face), dz[:, 0], dz[:, 1]], \
        shadow_taps(r, size, SHADOW_PCF_SAMPLES)


def lookup_steps(name: str, gl: np.ndarray, ref: np.ndarray, pcf_taps: np.ndarray) -> np.ndarray:
    """Per lookup, what one flipped sample may change in result ``name`` (STEPS)."""
    step = STEPS[name]
    if step == "1/taps":
        return 1.0 / pcf_taps
    if step == "blocker":  # the mean of the found occluders, or -1 where none is
        return np.where((gl >= 0.0) == (ref >= 0.0), 0.5, 2.0)
    return np.full(ref.shape, float(step))


def robust_lookups(name: str, gl: np.ndarray, ref: np.ndarray, step: np.ndarray,
                   measured: str = "") -> ParityResult:
    """GLSL against the twin over a batch of lookups: at most MAX_OUTLIERS of them beyond 1e-5
    (abs + rel), each of those within its ``step`` (what one flipped sample may change)."""
    diff = np.abs(gl - ref)
    bad = diff > 1e-5 + 1e-5 * np.abs(ref)
    ok = bad.mean() <= MAX_OUTLIERS and bool((diff[bad] <= step[bad] + 1e-5).all())
    res = compare(name, gl[~bad], ref[~bad], atol=1e-5, rtol=1e-5, kind="pass",
                  measured=measured or f"{int(bad.sum())} of {len(ref)} beyond 1e-5 on llvmpipe",
                  envelope=ENVELOPE)
    res.tolerance += f"; {int(bad.sum())} outliers (<= {MAX_OUTLIERS:.1%}, each within one sample)"
    res.passed = bool(res.passed and ok)
    return res


def checks() -> dict:
    found, register_pass_check = collector()

    @register_pass_check("shadow:lookups")
    def check_lookups(programs):
        ctx = programs.ctx
        rng = np.random.default_rng(1)
        n = 2048
        out = []
        for kind, lens, across, down in KINDS:
            tiles = [[shadow_test_map(seed=across * y + x) for x in range(across)]
                     for y in range(down)]
            depth_map = np.ascontiguousarray(np.block(tiles), np.float32)
            inputs = _inputs(kind, n, rng)
            tex = ctx.texture((depth_map.shape[1], depth_map.shape[0]), 1, depth_map.tobytes(),
                              dtype="f4")
            tex.filter = (ctx.NEAREST, ctx.NEAREST)  # a shadow map's sampler (ShadowMapDesc)
            tex.repeat_x = tex.repeat_y = False

            def setup(prog, tex=tex, lens=lens):
                tex.use(location=0)
                prog["u_map"].value = 0
                prog["u_depth_range"].value = DEPTH_RANGE
                prog["u_extent"].value = EXTENT
                prog["u_lens"].value = lens

            try:
                gl = run_kernel(programs, "passes/parity_shadow.comp", inputs, 8, setup)
            finally:
                tex.release()
            with torch.no_grad():
                ref, taps = _twins(depth_map, inputs, lens, kind)
            for i, name in enumerate(STEPS):
                if kind != "ortho" and name.startswith(("shadow_visibility",
                                                        "shadow_depth_slope")):
                    continue  # orthographic only (the sun's lookup)
                ref_i = ref[i].numpy()
                out.append(robust_lookups(f"{name} ({kind})", gl[:, i], ref_i,
                                          lookup_steps(name, gl[:, i], ref_i, taps.numpy())))
        return out

    return found
