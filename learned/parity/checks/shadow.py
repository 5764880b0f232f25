"""The shadow-map lookups of ``lib/shadow.glsl`` (``passes/parity_shadow.comp``) against
:mod:`learned.twins.shadow` on the same map: a synthetic map with a disk occluder, steps and
noise, so blocker search and PCF see partial coverage."""
from __future__ import annotations

import numpy as np
import torch

from learned.twins.shadow import (
    shadow_blocker_depth,
    shadow_depth_at,
    shadow_depth_slope,
    shadow_pcf,
    shadow_visibility,
)
from viewer.gl.kernels import run_kernel

from ..results import compare
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


def checks() -> dict:
    found, register_pass_check = collector()

    @register_pass_check("shadow:lookups")
    def check_lookups(programs):
        ctx = programs.ctx
        depth_map = shadow_test_map()
        rng = np.random.default_rng(1)
        n = 2048
        # texel centres offset by a quarter texel: floor() never sits on a texel boundary
        uv = (rng.integers(-2, SIZE + 2, (n, 2)) + 0.25 + 0.5 * rng.random((n, 2))) / SIZE
        s = np.concatenate([uv, rng.uniform(0.05, 1.0, (n, 1))], axis=1)
        radius = rng.uniform(0.0, 0.15, n)
        angle = rng.uniform(0.0, 0.1, n)
        phi = rng.uniform(0.0, 6.2832, n)
        m = rng.normal(size=(n, 3))
        m[:, 2] = np.abs(m[:, 2]) * 3.0  # mostly facing the light; some grazing (clamped)
        m[: n // 8, :2] = 0.0  # facing it: no slope
        inputs = np.concatenate([s, radius[:, None], angle[:, None], phi[:, None], m],
                                axis=1).astype(np.float32)
        tex = ctx.texture((SIZE, SIZE), 1, depth_map.tobytes(), dtype="f4")
        tex.filter = (ctx.NEAREST, ctx.NEAREST)

        def setup(prog):
            tex.use(location=0)
            prog["u_map"].value = 0
            prog["u_depth_range"].value = DEPTH_RANGE
            prog["u_extent"].value = EXTENT

        try:
            gl = run_kernel(programs, "passes/parity_shadow.comp", inputs, 6, setup)
        finally:
            tex.release()
        t = {k: torch.from_numpy(np.ascontiguousarray(v, np.float32)) for k, v in
             (("map", depth_map), ("s", inputs[:, :3]), ("r", inputs[:, 3]),
              ("a", inputs[:, 4]), ("phi", inputs[:, 5]), ("m", inputs[:, 6:9]))}
        with torch.no_grad():
            dz = shadow_depth_slope(t["m"])
            uv, z = t["s"][:, :2], t["s"][:, 2]
            ref = [shadow_depth_at(t["map"], uv),
                   shadow_blocker_depth(t["map"], uv, z, dz, t["r"], t["phi"]),
                   shadow_pcf(t["map"], uv, z, dz, t["r"], t["phi"]),
                   shadow_visibility(t["map"], t["s"], dz, t["a"], DEPTH_RANGE, EXTENT, t["phi"]),
                   dz[:, 0], dz[:, 1]]
        envelope = ("texel indices from floor(uv size) of the same float32 uv: a sample's "
                    "offset r vogel(i) differs by trig's ~1e-6 abs x r <= 0.15 -> 1.5e-7 uv "
                    "= 1e-5 texel, so a disk sample lands in another texel only within 1e-5 "
                    "texel of a boundary (p ~ 2e-5 per sample); robust: 1 in 500 values may "
                    "differ by one sample's share (1/16 of the mean depth, 1/32 of the "
                    "fraction)")
        out = []
        for i, (name, step) in enumerate((("shadow_depth_at", 0.0),
                                          ("shadow_blocker_depth", 1.0),
                                          ("shadow_pcf", 1.0 / 32.0),
                                          ("shadow_visibility", 1.0 / 32.0),
                                          ("shadow_depth_slope.x", 0.0),
                                          ("shadow_depth_slope.y", 0.0))):
            ref_i = ref[i].numpy()
            diff = np.abs(gl[:, i] - ref_i)
            bad = diff > 1e-5 + 1e-5 * np.abs(ref_i)
            ok = bad.mean() <= 1.0 / 500.0 and (step == 0.0 and not bad.any() or
                                                (diff[bad] <= max(step, 1.0) + 1e-5).all())
            res = compare(name, gl[:, i][~bad], ref_i[~bad], atol=1e-5, rtol=1e-5, kind="pass",
                          measured=f"{int(bad.sum())} of {n} beyond 1e-5 on llvmpipe",
                          envelope=envelope)
            res.passed = bool(res.passed and ok)
            out.append(res)
        return out

    return found
