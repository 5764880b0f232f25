"""Numerical stability at the extremes, on the GLSL path and its torch twin.

One image-space G-buffer holds every combination of extreme material and geometry values
(roughness 0, 1e-4, 0.045, 1; metallic 0/1; specular 0/1; albedo 0/1; normals facing, grazing
(n.v = 1e-6), back-facing, zero-length and NaN; depth at the near and far planes), shaded under
extreme environments (all zero, a 1e5 sun, texels above the half-float maximum, NaN/Inf texels) with
fields of view of 1 and 170 degrees. Everywhere: finite, non-negative, bounded by the brightest
environment texel (energy conservation), and GLSL == torch twin.
"""
import itertools
import math
import warnings

import numpy as np
import pytest
import torch

from learned.parity.checks.models import (
    MODEL_ATOL,
    MODEL_RTOL,
    env_from_ibl,
    gl_gbuffer,
)
from learned.twins.shade import shade
from viewer.geometry.imagespace import ImageGBuffer, view_dirs_cs
from viewer.imageio import write_exr
from viewer.passes.shade import shade_defines
from viewer.renderer import Renderer
from viewer.scene.description import ObjectSpec, Scene, scene_from_dict

ROUGHNESS = (0.0, 1e-4, 0.045, 1.0)
METALLIC = (0.0, 1.0)
SPECULAR = (0.0, 1.0)
ALBEDO = (0.0, 1.0)
NORMALS = ("facing", "grazing", "backfacing", "zero", "nan")


def extreme_gbuffer(fov_y: float, near: float = 1.0, far: float = 800.0) -> ImageGBuffer:
    combos = list(itertools.product(ROUGHNESS, METALLIC, SPECULAR, ALBEDO, NORMALS))
    w = 20
    h = math.ceil(len(combos) / w) + 1  # + one row of background
    v = -view_dirs_cs(w, h, fov_y)  # towards the viewer
    ch = {k: np.zeros((h, w, c), np.float32) for k, c in
          (("albedo", 3), ("normal", 3), ("roughness", 1), ("metallic", 1), ("specular", 1),
           ("ao", 1), ("depth", 1), ("alpha", 1))}
    ch["ao"][:] = 1.0
    for idx, (r, m, s, a, n) in enumerate(combos):
        y, x = divmod(idx, w)
        vv = v[y, x]
        t = np.cross(vv, [0.0, 1.0, 0.0] if abs(vv[1]) < 0.9 else [1.0, 0.0, 0.0])
        t /= np.linalg.norm(t)
        normal = {"facing": vv, "grazing": 1e-6 * vv + math.sqrt(1 - 1e-12) * t,
                  "backfacing": -vv, "zero": np.zeros(3), "nan": np.full(3, np.nan)}[n]
        ch["albedo"][y, x] = a
        ch["normal"][y, x] = normal
        ch["roughness"][y, x] = r
        ch["metallic"][y, x] = m
        ch["specular"][y, x] = s
        ch["depth"][y, x] = near if idx % 2 == 0 else far
        ch["alpha"][y, x] = 1.0
    return ImageGBuffer(channels=ch, fov_y=fov_y)


def environment_file(tmp_path, kind: str):
    w, h = 64, 32
    env = np.full((h, w, 3), 0.5, np.float32)
    if kind == "zero":
        env[:] = 0.0
    elif kind == "sun":
        env[6:8, 40:42] = 1e5
    elif kind == "above_half":
        env[10:12, 10:14] = 3e5  # > 65504, the half-float maximum
    elif kind == "nan_inf":
        env[3, 3] = np.nan
        env[4, 4] = np.inf
        env[5, 5] = -np.inf
        env[6, 6] = -2.0
    path = tmp_path / f"env_{kind}.exr"
    write_exr(path, env)
    return path, float(np.nanmax(np.where(np.isfinite(env), env, 0.0)))


@pytest.fixture(scope="module")
def renderer(ctx):
    r = Renderer(ctx=ctx)
    yield r
    r.release()


def render_extremes(renderer, tmp_path, env_kind, model, fov_y, aovs=(), **render):
    env_path, max_radiance = environment_file(tmp_path, env_kind)
    image = extreme_gbuffer(fov_y)
    obj = ObjectSpec("gbuffer", path=str(tmp_path / f"extremes_{fov_y}.exr"))
    renderer.add_geometry(obj, image)  # in-memory stack: skips the loader's NaN rejection on purpose
    base = scene_from_dict({"environment": {"path": str(env_path)},
                            "render": {"model": model, "tonemap": "none", **render}})
    scene = Scene(environment=base.environment, render=base.render, objects=(obj,))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the NaN/Inf environment warns by design
        targets = renderer.draw(scene, aovs=aovs)
    w, h = targets.radiance.size
    glsl = np.frombuffer(targets.radiance.read(), np.float32).reshape(h, w, 4)
    return scene, targets, glsl, max_radiance, image


@pytest.mark.parametrize("env_kind", ["zero", "sun", "above_half", "nan_inf"])
@pytest.mark.parametrize("model", ["ggx_split_sum", "blinn_phong", "unlit"])
@pytest.mark.parametrize("fov_y", [1.0, 170.0])
def test_extremes_are_finite_bounded_and_match_the_twin(renderer, tmp_path, env_kind, model, fov_y):
    scene, targets, glsl, max_radiance, image = render_extremes(renderer, tmp_path, env_kind,
                                                                model, fov_y)
    assert np.isfinite(glsl).all(), f"{int((~np.isfinite(glsl)).sum())} non-finite values"
    assert glsl.min() >= 0.0
    # energy conservation: nothing is brighter than the brightest environment texel (albedo <= 1);
    # SH irradiance rings for a tiny bright sun, so diffuse may overshoot by the clamped ringing.
    bound = max(max_radiance, 1.0 if model == "unlit" else 0.0) * (1.0 + 1e-3) + 1e-6
    assert glsl[..., :3].max() <= bound
    # the torch twin on the same G-buffer (read back from GL) and the same IBL resources
    ibl = renderer.ibl(scene)
    gb = gl_gbuffer(targets)
    env = env_from_ibl(ibl)
    with torch.no_grad():
        ref = shade(model, gb, targets.camera, env, 1.0, 0.0,
                    shade_defines(model, scene.render)).numpy()
    assert np.isfinite(ref).all()
    np.testing.assert_allclose(glsl, ref, atol=MODEL_ATOL * max(1.0, max_radiance), rtol=MODEL_RTOL)


def test_fp16_targets_stay_finite(renderer, tmp_path):
    """Half-float G-buffer targets: depth at the far plane and normals survive; nothing overflows."""
    scene, targets, glsl, max_radiance, _ = render_extremes(renderer, tmp_path, "sun",
                                                            "ggx_split_sum", 40.0, aovs=("depth",),
                                                            precision="fp16")
    assert targets.gbuffer.layout.dtype == "f2"
    assert np.isfinite(glsl).all() and glsl[..., :3].max() <= max_radiance * 1.001
    depth = targets.gbuffer.read()["depth"]
    assert np.isfinite(depth).all() and depth.max() == pytest.approx(800.0, rel=1e-3)
