"""``relight reference`` itself: Mitsuba with our BSDF against physics identities, against the
rasteriser's Monte-Carlo model (same integrand, so equal in expectation), its two backends against
each other, resuming, and its one-line errors. Statistical checks are per-pixel z-tests with a
Bonferroni correction (``relight.reference.compare``): their false-alarm rate is at most alpha = 1 %
per test on any machine, because it depends only on the samples' own variance."""
import json

import numpy as np
import pytest
from scipy import stats

from relight.cli import main
from relight.reference import ReferenceOptions, read_reference, render_reference
from relight.reference import render as render_module
from relight.reference.bsdf import brdf_cos_numpy, directional_albedo_table
from relight.reference.compare import Reference, z_test
from viewer.scene.description import scene_from_dict


def _scene(env, material, size=24, light=None, center=(0.0, 0.0, 0.0), ms=False, objects=None,
           background="transparent"):
    d = {"camera": {"position": [0.0, 0.4, 3.2], "target": [0.0, 0.0, 0.0], "fov_y": 40,
                    "size": [size, size]},
         "environment": env,
         "render": {"multiscatter": ms, "ao": False, "tonemap": "none", "background": background},
         "objects": objects or [{"type": "sphere", "center": list(center), "material": material}]}
    if light:
        d["light"] = light
    return scene_from_dict(d)


def _constant(ref: Reference, value) -> np.ndarray:
    img = np.zeros_like(ref.radiance)
    img[..., :3] = value
    img[..., 3] = 1.0
    return img


@pytest.mark.parametrize("material, ms, expected", [
    ({"albedo": [0.8, 0.6, 0.4], "specular": 0.0}, False, [0.8, 0.6, 0.4]),  # Lambert
    ({"albedo": [1.0, 1.0, 1.0], "metallic": 1.0, "roughness": 0.7}, True, [1.0, 1.0, 1.0]),
])
def test_white_furnace(mitsuba_llvm, material, ms, expected):
    """Under a constant unit environment a convex object reflects exactly its directional albedo:
    the Lambert albedo, and 1 for a white conductor with multiple-scattering compensation (whose
    compensation comes from our DFG table, an independent float64 quadrature)."""
    scene = _scene({"procedural": "white", "width": 64}, material, ms=ms)
    ref = render_reference(scene, ReferenceOptions(spp=256, max_depth=2), progress=False)
    # the compensated conductor is energy-conserving only up to the DFG table's interpolation
    # (bilinear over a 65 x 65 grid of a smooth function: below 2e-3 relative), a floor
    floor = 2e-3 if ms else 0.0
    result = z_test(_constant(ref, expected), ref, floor=floor)
    assert result.passed, result


def test_bsdf_plugin_matches_independent_numpy_evaluation(mitsuba_llvm):
    """The Dr.Jit plugin's eval against a float64 numpy evaluation of the same formula (module
    docstring of relight.reference.bsdf) at random directions: float32 rounding only (1e-4)."""
    mi, dr, _ = mitsuba_llvm
    from relight.reference.bsdf import bsdf_class
    from viewer.scene.material import Material

    rng = np.random.default_rng(3)
    for mat in (Material(albedo=(0.9, 0.5, 0.2), roughness=0.4, metallic=0.3, specular=0.6),
                Material(albedo=(1.0, 1.0, 1.0), roughness=0.05, metallic=1.0)):
        bsdf = bsdf_class(mi, dr)().configure(mat, {}, multiscatter=True)
        nov = 0.6
        wo = rng.normal(size=(512, 3))
        wo[:, 2] = np.abs(wo[:, 2])
        wo /= np.linalg.norm(wo, axis=1, keepdims=True)
        si = dr.zeros(mi.SurfaceInteraction3f, 512)
        si.wi = mi.Vector3f(float(np.sqrt(1 - nov * nov)), 0.0, nov)
        si.sh_frame = mi.Frame3f(mi.Vector3f(0.0, 0.0, 1.0))
        wo_mi = mi.Vector3f(np.ascontiguousarray(wo.T, np.float32))
        got = np.array(bsdf.eval(mi.BSDFContext(), si, wo_mi)).T
        want = brdf_cos_numpy(mat.albedo, mat.roughness, mat.metallic, mat.specular, nov, wo,
                              multiscatter=True)
        np.testing.assert_allclose(got, want, rtol=2e-3, atol=1e-5)


def test_bsdf_plugin_is_exact_at_a_near_mirror_peak(mitsuba_llvm):
    """Directions inside a roughness-0.05 lobe (half vectors within a few alpha = 0.0025 of the
    normal), where D's bracket NoH^2 a^2 + (1 - NoH^2) is ~1e-5: written with 1 - NoH from a
    float32 NoH ~ 1 it kept a few digits (errors of several %, their sign set by the CPU's vector
    code, which biased the references of near-mirror scenes by 0.3 % on one machine and not on
    another); from h's tangential components it is exact to float32 rounding. Against the float64
    numpy evaluation of the same directions: 1e-3."""
    mi, dr, _ = mitsuba_llvm
    from relight.reference.bsdf import bsdf_class
    from viewer.scene.material import Material

    mat = Material(albedo=(0.95, 0.64, 0.54), roughness=0.05, metallic=1.0)
    a = mat.roughness ** 2
    rng = np.random.default_rng(4)
    bsdf = bsdf_class(mi, dr)().configure(mat, {}, multiscatter=True)
    for nov in (0.9, 0.5, 0.2):
        wi = np.array([np.sqrt(1 - nov * nov), 0.0, nov])
        h = np.concatenate([rng.normal(0.0, 2.0 * a, size=(512, 2)), np.ones((512, 1))], axis=1)
        h /= np.linalg.norm(h, axis=1, keepdims=True)
        wo = 2.0 * (h @ wi)[:, None] * h - wi
        wo = wo[wo[:, 2] > 0.0].astype(np.float32)
        si = dr.zeros(mi.SurfaceInteraction3f, len(wo))
        si.wi = mi.Vector3f(*(float(c) for c in wi.astype(np.float32)))
        si.sh_frame = mi.Frame3f(mi.Vector3f(0.0, 0.0, 1.0))
        got = np.array(bsdf.eval(mi.BSDFContext(), si,
                                 mi.Vector3f(np.ascontiguousarray(wo.T)))).T
        want = brdf_cos_numpy(mat.albedo, mat.roughness, mat.metallic, mat.specular,
                              float(np.float32(nov)), wo.astype(np.float64), multiscatter=True)
        np.testing.assert_allclose(got, want, rtol=1e-3)


def test_dfg_table_matches_the_renderers_lut(programs):
    """The reference's DFG table (float64 midpoint quadrature) against the renderer's LUT (4096
    Hammersley samples per texel on the GPU): two independent estimates of one integral. The LUT's
    own error is below 1e-2 (tests/shaders/test_ibl.py); grazing n.v < 0.06 is left out as there.
    Also the closed limit: a smooth conductor at normal incidence reflects everything."""
    from viewer.environment.ibl import IBLOptions, build_ibl

    t = directional_albedo_table()
    assert abs(t[3, -1, 1] - 1.0) < 2e-3  # r = 0.047 (the roughness clamp), n.v = 1
    ibl = build_ibl(programs, np.ones((32, 64, 3), np.float32), IBLOptions())
    try:
        lut = ibl.read_level("dfg")  # [roughness, n.v, 2]
    finally:
        ibl.release()
    n = t.shape[0]
    for i in range(2, n, 4):
        for j in range(4, n, 4):
            r, mu = i / (n - 1), j / (n - 1)
            li = r * (lut.shape[0] - 1)
            lj = mu * (lut.shape[1] - 1)
            i0, j0 = int(li), int(lj)
            fi, fj = li - i0, lj - j0
            i1, j1 = min(i0 + 1, lut.shape[0] - 1), min(j0 + 1, lut.shape[1] - 1)
            want = ((lut[i0, j0] * (1 - fj) + lut[i0, j1] * fj) * (1 - fi)
                    + (lut[i1, j0] * (1 - fj) + lut[i1, j1] * fj) * fi)
            assert np.abs(t[i, j] - want[:2]).max() < 1e-2, (r, mu, t[i, j], want)


def test_ggx_mc_agrees_with_mitsuba(mitsuba_llvm, renderer):
    """The rasteriser's Monte-Carlo model integrates the same BSDF over the same environment, so
    on a convex object it equals the path tracer in expectation. An off-centre sphere, a rotated
    environment and a directional light make any orientation error (equirect convention, rotation
    sign, light direction, camera handedness) a failure of this z-test."""
    scene = _scene({"path": _env("park"), "rotation_deg": 30.0},
                   {"albedo": [0.8, 0.5, 0.3], "roughness": 0.45, "specular": 0.5},
                   light={"direction": [0.6, 0.5, 0.4], "intensity": 2.0}, center=(0.3, 0.0, 0.0))
    ref = render_reference(scene, ReferenceOptions(spp=512, max_depth=2), progress=False)
    runs = [renderer.render(scene.with_render(model="ggx_mc", samples=512, sampling="mis",
                                              seed=s)).radiance for s in range(4)]
    mean = np.mean(runs, axis=0)
    se = np.std(np.asarray(runs)[..., :3], axis=0, ddof=1) / np.sqrt(len(runs))
    result = z_test(mean, ref, image_stderr=se)
    assert result.passed, result
    # and it is sensitive: the environment turned the other way is rejected
    wrong = renderer.render(scene.with_environment(rotation_deg=-30.0).with_render(
        model="ggx_mc", samples=512, sampling="mis")).radiance
    assert not z_test(wrong, ref, image_stderr=se).passed


def test_scalar_backend_agrees_with_llvm(mitsuba_llvm):
    """The fallback backend (no libLLVM) renders the same estimate: a z-test between the two."""
    scene = _scene({"procedural": "sky", "width": 64},
                   {"albedo": [0.7, 0.7, 0.7], "roughness": 0.5}, size=5)
    a = render_reference(scene, ReferenceOptions(spp=64, max_depth=2), progress=False)
    b = render_reference(scene, ReferenceOptions(spp=16, max_depth=2, variant="scalar_rgb"),
                         progress=False)
    assert b.meta["variant"] == "scalar_rgb"
    render_module.load_mitsuba("llvm_ad_rgb")  # leave the session on the fast backend
    # b's variance is estimated from 16 samples: Student-t, 15 degrees of freedom
    result = z_test(b.radiance, a, image_stderr=b.stderr,
                    quantile=lambda p: float(stats.t.isf(p, 15)))
    assert result.passed, result


def test_interrupted_render_resumes_to_the_same_result(mitsuba_llvm, tmp_path, monkeypatch):
    """A checkpoint after every batch; a render killed after its first batch resumes from it and
    ends bit-identical to an uninterrupted one (every batch has its own seed)."""
    scene = _scene({"procedural": "sky", "width": 64}, {"albedo": [0.5, 0.5, 0.5]}, size=8)
    options = ReferenceOptions(spp=12, max_depth=2, batch_spp=4)
    whole = render_reference(scene, options, progress=False)
    ckpt = tmp_path / "r.partial.npz"
    real = render_module._trace
    calls = {"n": 0}

    def failing(*args, **kwargs):
        calls["n"] += 1
        if calls["n"] == 2:
            raise KeyboardInterrupt
        return real(*args, **kwargs)

    monkeypatch.setattr(render_module, "_trace", failing)
    with pytest.raises(KeyboardInterrupt):
        render_reference(scene, options, checkpoint=ckpt, progress=False)
    assert ckpt.is_file()
    monkeypatch.setattr(render_module, "_trace", real)
    resumed = render_reference(scene, options, checkpoint=ckpt, progress=False)
    assert not ckpt.exists()
    np.testing.assert_array_equal(resumed.radiance, whole.radiance)
    np.testing.assert_array_equal(resumed.stderr, whole.stderr)


def test_cli_writes_image_stderr_metadata_and_skips_finished(mitsuba_llvm, tmp_path, capsys):
    scene = tmp_path / "s.toml"
    scene.write_text('[camera]\nsize = [6, 6]\n[environment]\nprocedural = "sky"\nwidth = 64\n'
                     '[[objects]]\ntype = "sphere"\n[[objects]]\ntype = "plane"\n'
                     'center = [0, -1, 0]\n')
    out = tmp_path / "ref.exr"
    assert main(["reference", str(scene), "--out", str(out), "--spp", "8", "--depth", "3",
                 "--aov", "normal,depth", "-q"]) == 0
    ref = read_reference(out)
    meta = json.loads((tmp_path / "ref.json").read_text())
    assert meta["spp"] == 8 and meta["max_depth"] == 3 and meta["rays"] == "pixel centre"
    assert meta["multiscatter"] is True  # the BSDF traced: the render setting's default
    assert ref.radiance.shape == (6, 6, 4) and np.isfinite(ref.stderr).all()
    assert (tmp_path / "ref.normal.exr").is_file() and (tmp_path / "ref.depth.exr").is_file()
    assert main(["reference", str(scene), "--out", str(out), "--spp", "8", "--depth", "3"]) == 0
    assert "up to date" in capsys.readouterr().out


def test_sharding_splits_scenes_over_ranks(mitsuba_llvm, tmp_path, monkeypatch):
    for name in ("a", "b", "c"):
        (tmp_path / f"{name}.toml").write_text(
            '[camera]\nsize = [4, 4]\n[environment]\nprocedural = "white"\nwidth = 16\n'
            '[[objects]]\ntype = "sphere"\n')
    monkeypatch.setenv("RANK", "1")
    monkeypatch.setenv("WORLD_SIZE", "2")
    out = tmp_path / "out"
    assert main(["reference", *(str(tmp_path / f"{n}.toml") for n in "abc"), "--out-dir",
                 str(out), "--spp", "4", "-q"]) == 0
    assert sorted(p.name for p in out.glob("*.json")) == ["b.json"]


def test_untraceable_scene_is_one_line_error(tmp_path, capsys):
    """Image-space stacks and splats have no geometry to path-trace: one line, status 2, checked
    before Mitsuba is even imported."""
    scene = tmp_path / "s.toml"
    scene.write_text('[[objects]]\ntype = "splats"\npath = "cloud.ply"\n')
    assert main(["reference", str(scene), "--out", str(tmp_path / "r.exr")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "splats" in err[0] and "no path-traceable geometry" in err[0]
    assert not (tmp_path / "r.exr").exists()


def _env(name):
    from assets import ASSET_ROOT

    return str(ASSET_ROOT / "environments" / f"{name}.exr")


def test_mitsuba_environment_equals_the_rasterisers_lookup(mitsuba_llvm):
    """Mitsuba's envmap, fed :func:`environment_bitmap`, returns the rasteriser's bilinear
    texel-centre lookup (u wraps, v clamps; ``equirect.glsl``) in every direction: float rounding
    only (1e-4 relative at the 99th percentile; the first, naive conversion erred by 26 %)."""
    mi, dr, _ = mitsuba_llvm
    from relight.reference.scene import environment_bitmap
    from viewer.environment.maps import load_environment

    scene = _scene({"procedural": "sky", "width": 64, "sun_radiance": 2e4}, {})
    env = load_environment(scene.environment).astype(np.float64)
    h, w = env.shape[:2]
    emitter = mi.load_dict({"type": "envmap", "bitmap": mi.Bitmap(environment_bitmap(scene))})
    d = np.random.default_rng(5).normal(size=(4096, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    si = dr.zeros(mi.SurfaceInteraction3f, len(d))
    si.wi = mi.Vector3f(np.ascontiguousarray(-d.T, np.float32))
    got = np.array(emitter.eval(si)).T
    x = (np.arctan2(d[:, 0], -d[:, 2]) / (2 * np.pi) + 0.5) * w - 0.5
    y = np.clip(np.arctan2(np.hypot(d[:, 0], d[:, 2]), d[:, 1]) / np.pi * h - 0.5, 0, h - 1)
    x0, y0 = np.floor(x).astype(int), np.minimum(np.floor(y).astype(int), h - 2)
    fx, fy = (x - x0)[:, None], (y - y0)[:, None]
    xa, xb = x0 % w, (x0 + 1) % w
    want = ((env[y0, xa] * (1 - fx) + env[y0, xb] * fx) * (1 - fy)
            + (env[y0 + 1, xa] * (1 - fx) + env[y0 + 1, xb] * fx) * fy)
    rel = np.abs(got - want).sum(1) / (want.sum(1) + 1e-6)
    assert np.percentile(rel, 99) < 1e-4 and rel.max() < 1e-2, (np.percentile(rel, 99), rel.max())


def test_textured_mesh_reads_its_texture_the_right_way_up(mitsuba_llvm, renderer, tmp_path):
    """An OBJ quad with a four-colour texture (red top-left, green top-right, blue bottom-left,
    yellow bottom-right) under the white furnace: each quadrant of the reference has the colour
    the rasteriser shows there (a flipped v or u would swap them)."""
    from PIL import Image

    from viewer.scene.description import load_scene

    img = np.zeros((8, 8, 3), np.uint8)
    img[:4, :4], img[:4, 4:] = (255, 0, 0), (0, 255, 0)
    img[4:, :4], img[4:, 4:] = (0, 0, 255), (255, 255, 0)
    Image.fromarray(img).save(tmp_path / "quad.png")
    (tmp_path / "quad.mtl").write_text("newmtl m\nKd 1 1 1\nmap_Kd quad.png\n")
    (tmp_path / "quad.obj").write_text(
        "mtllib quad.mtl\nv -1 -1 0\nv 1 -1 0\nv 1 1 0\nv -1 1 0\nvt 0 0\nvt 1 0\nvt 1 1\n"
        "vt 0 1\nvn 0 0 1\nusemtl m\nf 1/1/1 2/2/1 3/3/1\nf 1/1/1 3/3/1 4/4/1\n")
    (tmp_path / "s.toml").write_text(
        '[camera]\nposition = [0, 0, 3]\nsize = [16, 16]\nfov_y = 45\n[environment]\n'
        'procedural = "white"\nwidth = 32\n[[objects]]\ntype = "mesh"\npath = "quad.obj"\n'
        '[render]\nmultiscatter = false\nbackground = "transparent"\n')
    scene = load_scene(tmp_path / "s.toml")
    ref = render_reference(scene, ReferenceOptions(spp=64, max_depth=2), progress=False)
    ours = renderer.render(scene.with_render(model="ggx_split_sum")).radiance
    for i, j in ((4, 4), (4, 11), (11, 4), (11, 11)):
        assert np.argmax(ref.radiance[i, j, :3]) == np.argmax(ours[i, j, :3])
        np.testing.assert_allclose(ref.radiance[i, j, :3], ours[i, j, :3], rtol=0.15, atol=0.05)


def test_the_cache_key_follows_what_the_tracer_reads():
    """A cached truth is keyed by the scene and the options (``config_key``): the render settings
    the rasteriser alone reads (the rays' frames, SSAO, the model) keep the key, so a new one of
    them does not trace every cached truth again; those the tracer reads (the background's
    transparency, multiple scattering) and the scene itself change it."""
    from relight.reference.keys import TRACED_RENDER, config_key

    scene = scene_from_dict({"environment": {"procedural": "sky"},
                             "objects": [{"type": "sphere", "center": [0, 0, 0], "radius": 1}]})
    opts = ReferenceOptions()
    key = config_key(scene, opts)
    for change in ({"ray_still_frames": 2}, {"ssao": False}, {"model": "blinn_phong"},
                   {"raytrace": False}, {"shadow_proxy_snap": 0.0}):
        assert config_key(scene.with_render(**change), opts) == key, change
    assert set(TRACED_RENDER) == {"background", "multiscatter"}
    assert config_key(scene.with_render(background="transparent"), opts) != key
    assert config_key(scene.with_render(multiscatter=not scene.render.multiscatter), opts) != key
    assert config_key(scene.with_camera(size=(33, 17)), opts) != key
    assert config_key(scene, ReferenceOptions(max_depth=2)) != key
    assert config_key(scene, ReferenceOptions(spp=7)) == key  # a checkpoint's count, not its key
