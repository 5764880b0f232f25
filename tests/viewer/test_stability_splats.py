"""Degenerate splats on the GLSL splat pass and its torch twin: no NaN or Inf, bounded outputs.

Each scene mixes 300 ordinary splats with one kind of degenerate splat, handed to the rasterizers
in memory (the PLY loader drops or clamps some of these, the rasterizers must not rely on it):
sigma 1e-8 and exactly 0, sigma 1e4 (isotropic, discs and needles), zero quaternions, opacity
exactly 0 and 1, centres behind the camera and exactly at it, many splats straddling the near
plane, and SH coefficients of +-1e30. Checked everywhere: every G-buffer channel finite, coverage
in [0, 1], depth >= 0, normals unit where covered and zero elsewhere, materials in [0, 1], and
GLSL == twin within PARITY_ATOL on the pixels the splats project to (minus the ambiguous ones,
counted, see ``learned.parity.checks.splats.ambiguous_pixels``). Then all kinds in one scene through
the real renderer with every classical shading model (and the shading twin), and through the
loader from a PLY file.
"""
import warnings

import numpy as np
import pytest
import torch

from learned.parity.checks.splats import PARITY_ATOL, ambiguous_pixels, render_gl
from learned.splats.rasterize import rasterize, splat_tensors
from viewer.scene.camera import Camera
from viewer.splats import concat, write_ply
from viewer.splats.data import make_splats

CAMERA = Camera(position=(0.3, 0.2, 3.0), target=(0.0, 0.0, 0.0), fov_y=50.0, size=(48, 40),
                near=0.05)
KINDS = ("sigma_1e-8", "sigma_0", "sigma_1e4", "disc_1e4", "needle_1e4", "zero_quaternion",
         "opacity_0_and_1", "behind_camera", "at_camera", "straddling_near", "extreme_sh")


def _cloud(rng, n, means=None, scales=None, rotations=None, opacities=None, sh=None,
           normals=None):
    """n splats with random materials; any attribute can be given (the rest random, ordinary)."""
    means = rng.uniform(-1.0, 1.0, (n, 3)) if means is None else means
    if scales is None:
        scales = np.exp(rng.uniform(np.log(0.01), np.log(0.12), (n, 3)))
    rotations = rng.normal(size=(n, 4)) if rotations is None else rotations
    opacities = rng.uniform(0.05, 1.0, n) if opacities is None else opacities
    if sh is None:
        sh = rng.normal(0.0, 0.25, (n, 16, 3))
        sh[:, 0] += rng.uniform(-1.5, 1.5, (n, 3))
    if normals is None:
        normals = rng.normal(size=(n, 3))
        normals[: n // 2] = 0.0  # half use the shortest axis
    return make_splats(means, scales, rotations, opacities, sh=sh,
                       albedo=rng.uniform(0, 1, (n, 3)), roughness=rng.uniform(0, 1, n),
                       metallic=rng.uniform(0, 1, n), normals=normals)


def degenerate(kind: str, seed: int = 0):
    """Only the degenerate splats of ``kind`` (centres in view unless the kind says otherwise)."""
    rng = np.random.default_rng(100 + KINDS.index(kind))
    eye = np.asarray(CAMERA.position)
    fwd = -eye / np.linalg.norm(eye)
    n = 40
    if kind == "sigma_1e-8":
        return _cloud(rng, n, scales=np.full((n, 3), 1e-8))
    if kind == "sigma_0":
        s = np.exp(rng.uniform(np.log(0.01), np.log(0.12), (n, 3)))
        s[:, rng.integers(0, 3, n)] = 0.0
        s[: n // 2] = 0.0
        return _cloud(rng, n, scales=s)
    if kind == "sigma_1e4":
        return _cloud(rng, 3, scales=np.full((3, 3), 1e4), opacities=np.array([0.3, 0.6, 1.0]))
    if kind == "disc_1e4":
        return _cloud(rng, 3, scales=np.tile([1e4, 1e4, 1e-8], (3, 1)))
    if kind == "needle_1e4":
        return _cloud(rng, 6, scales=np.tile([1e4, 1e-8, 1e-8], (6, 1)))
    if kind == "zero_quaternion":  # stored normals for half, the shortest axis for the rest
        return _cloud(rng, n, rotations=np.zeros((n, 4)))
    if kind == "opacity_0_and_1":
        return _cloud(rng, n, opacities=np.repeat([0.0, 1.0], n // 2))
    if kind == "behind_camera":  # up to 2 units behind, wide enough to reach in front
        lateral = rng.normal(0.0, 0.3, (n, 3))
        lateral -= (lateral @ fwd)[:, None] * fwd
        return _cloud(rng, n, means=eye - fwd * rng.uniform(0.0, 2.0, (n, 1)) + lateral,
                      scales=np.full((n, 3), 0.5))
    if kind == "at_camera":
        return _cloud(rng, n, means=np.tile(eye, (n, 1)),
                      scales=np.exp(rng.uniform(np.log(1e-3), np.log(1.0), (n, 3))))
    if kind == "straddling_near":  # centres within +-near of the near plane, wider than that
        n = 120
        lateral = rng.normal(0.0, 0.03, (n, 3))
        lateral -= (lateral @ fwd)[:, None] * fwd
        depth = CAMERA.near + rng.uniform(-1.0, 1.0, n) * CAMERA.near
        depth[:10] = CAMERA.near  # exactly on the plane
        return _cloud(rng, n, means=eye + depth[:, None] * fwd + lateral,
                      scales=np.exp(rng.uniform(np.log(0.01), np.log(0.5), (n, 3))))
    if kind == "extreme_sh":
        sh = rng.choice([-1e30, 1e30], size=(n, 16, 3))
        sh[: n // 2, 0] = 1e30  # bright for sure (the rest may clamp to 0)
        return _cloud(rng, n, sh=sh)
    raise ValueError(kind)


def mixed(kind: str):
    return concat([_cloud(np.random.default_rng(7), 300), degenerate(kind)])


def assert_bounded(g: dict, where: str) -> None:
    """G-buffer channels (name -> [H, W, C]) finite and physically bounded."""
    for name, arr in g.items():
        assert np.isfinite(arr).all(), f"{where}: {name} has {int((~np.isfinite(arr)).sum())} NaN/Inf"
    a = g["alpha"][..., 0]
    assert a.min() >= 0.0 and a.max() <= 1.0 + 1e-6, where
    assert g["depth"].min() >= 0.0, where
    for name in ("albedo", "roughness", "metallic", "specular", "ao"):
        assert g[name].min() >= -1e-6 and g[name].max() <= 1.0 + 1e-5, (where, name)
    assert g["color"].min() >= 0.0, where
    length = np.linalg.norm(g["normal"], axis=-1)
    covered = a > 0
    np.testing.assert_allclose(length[covered], 1.0, atol=1e-5, err_msg=where)
    assert np.all(length[~covered] == 0.0), where


@pytest.mark.parametrize("kind", KINDS)
def test_degenerate_splats_glsl_and_twin(programs, kind):
    splats = mixed(kind)
    _, gl = render_gl(programs, splats, CAMERA)
    t = splat_tensors(splats)
    with torch.no_grad():
        ref = {k: v.numpy() for k, v in rasterize(t, CAMERA).items()}
    assert_bounded(gl, f"GLSL {kind}")
    assert_bounded(ref, f"torch {kind}")
    amb = ambiguous_pixels(t, CAMERA).numpy()
    assert amb.mean() < 0.03, f"{kind}: {int(amb.sum())} ambiguous pixels"
    keep = ~amb & ((gl["alpha"][..., 0] > 0) | (ref["alpha"][..., 0] > 0))
    assert keep.sum() > 200, kind
    for name in gl:
        g, r = gl[name][keep], ref[name][keep]
        # the baked colour of +-1e30 SH is ~1e31: compared relative to its magnitude
        tol = PARITY_ATOL * np.maximum(1.0, np.abs(r)) if name == "color" else PARITY_ATOL
        bad = np.abs(g - r) > tol
        assert not bad.any(), (kind, name, float(np.abs(g - r).max()), int(bad.sum()))


def test_degenerate_kinds_do_what_they_should(programs):
    """Culled kinds leave the ordinary cloud untouched; zero quaternions render as axis-aligned
    Gaussians (identity rotation, as in the reference 3DGS code), not as nothing."""
    base = _cloud(np.random.default_rng(7), 300)
    _, only_base = render_gl(programs, base, CAMERA)
    for kind in ("behind_camera", "at_camera"):
        _, g = render_gl(programs, mixed(kind), CAMERA)
        np.testing.assert_array_equal(g["alpha"], only_base["alpha"], err_msg=kind)
    zq = degenerate("zero_quaternion")
    identity = zq.rotations.copy()
    identity[:, 0] = 1.0
    from dataclasses import replace

    _, g0 = render_gl(programs, zq, CAMERA)
    _, g1 = render_gl(programs, replace(zq, rotations=identity), CAMERA)
    assert (g0["alpha"] > 0).sum() > 50
    for name in g0:
        np.testing.assert_allclose(g0[name], g1[name], atol=1e-6, err_msg=name)


# ---- the real renderer: every classical model, and its shading twin ---------------------------

@pytest.fixture(scope="module")
def renderer(ctx):
    from viewer.renderer import Renderer

    r = Renderer(ctx=ctx)
    yield r
    r.release()


def _scene(tmp_path, model, splats_obj, **render):
    from viewer.scene.description import Scene, scene_from_dict

    base = scene_from_dict({
        "camera": {"position": list(CAMERA.position), "target": [0, 0, 0], "fov_y": 50.0,
                   "size": list(CAMERA.size), "near": CAMERA.near},
        "environment": {"procedural": "sky", "width": 64},
        "render": {"model": model, "tonemap": "aces", **render},
        "objects": [{"type": "plane", "center": [0, -1.2, 0], "size": [6, 6]}]})
    return Scene(camera=base.camera, environment=base.environment, render=base.render,
                 objects=base.objects + (splats_obj,))


@pytest.mark.parametrize("model", ["unlit", "blinn_phong", "ggx_split_sum", "ggx_mc"])
def test_every_kind_at_once_through_the_renderer(renderer, tmp_path, model):
    from learned.parity.checks.models import (
        MODEL_ATOL,
        MODEL_RTOL,
        env_from_ibl,
        gl_gbuffer,
    )
    from learned.twins.shade import shade
    from viewer.passes.shade import shade_defines
    from viewer.scene.description import ObjectSpec

    splats = concat([_cloud(np.random.default_rng(7), 300)] + [degenerate(k) for k in KINDS])
    obj = ObjectSpec("splats", path=str(tmp_path / "in_memory.ply"))
    renderer.add_geometry(obj, splats)  # in memory: skips the loader's validation on purpose
    scene = _scene(tmp_path, model, obj, **({"samples": 4} if model == "ggx_mc" else {}))
    aovs = ("albedo", "alpha", "normal", "roughness", "metallic", "specular", "ao", "depth",
            "color")
    frame = renderer.render(scene, aovs=aovs)
    assert_bounded({k: frame.aovs[k] for k in aovs}, f"renderer {model}")
    rad = frame.radiance
    assert np.isfinite(rad).all() and rad.min() >= 0.0, model
    env_max = float(renderer.ibl(scene).read_level("radiance", 0).max())
    if model != "unlit":  # lit models ignore the baked colour: bounded by the environment
        assert rad[..., :3].max() <= env_max * 1.001, model
    if model == "ggx_mc":
        return
    # the shading twin on the G-buffer the splat pass produced; the twin has no rays (the default
    # render's rays see the splats' opaque cores and shadow the floor: compared without them)
    scene = scene.with_render(raytrace=False)
    rad = renderer.render(scene).radiance
    targets = renderer.draw(scene, aovs=aovs)
    ibl = renderer.ibl(scene)
    gb = gl_gbuffer(targets)
    env = env_from_ibl(ibl)
    with torch.no_grad():
        ref = shade(model, gb, targets.camera, env, 1.0, 0.0,
                    shade_defines(model, scene.render)).numpy()[::-1]
    assert np.isfinite(ref).all()
    scale = np.maximum(1.0, np.abs(ref)) if model == "unlit" else max(1.0, env_max)
    assert np.all(np.abs(rad - ref) <= MODEL_ATOL * scale + MODEL_RTOL * np.abs(ref)), model


def test_degenerate_ply_through_the_loader(renderer, tmp_path):
    """The same kinds written to a PLY (where the format can hold them) and loaded: the loader
    drops or clamps what it must, with warnings; the render is finite."""
    from viewer.scene.description import ObjectSpec

    parts = [degenerate(k) for k in ("sigma_1e-8", "sigma_1e4", "zero_quaternion",
                                     "opacity_0_and_1", "straddling_near", "extreme_sh")]
    splats = concat([_cloud(np.random.default_rng(7), 300)] + parts)
    path = tmp_path / "degenerate.ply"
    with np.errstate(divide="ignore"):  # log(0) scales and logit(0/1) opacities: written as +-inf
        write_ply(path, splats)
    obj = ObjectSpec("splats", path=str(path))
    scene = _scene(tmp_path, "ggx_split_sum", obj)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        frame = renderer.render(scene, aovs=("alpha", "normal", "depth", "color"))
    assert any("dropped" in str(w.message) for w in caught)
    assert np.isfinite(frame.radiance).all()
    assert_bounded({**{k: frame.aovs[k] for k in ("alpha", "normal", "depth", "color")},
                    **{k: np.zeros((1, 1, 1), np.float32) for k in
                       ("albedo", "roughness", "metallic", "specular", "ao")}}, "loader")
