"""The GLSL splat pass: footprint and alpha rule, sorting, depth test against meshes, scenes."""
import numpy as np
import pytest

from relight.cli import main
from viewer.scene.camera import Camera
from viewer.splats import write_ply
from viewer.splats.data import make_splats


def _one_splat(opacity=0.8, sigma=(0.05, 0.02, 0.01), color=(0.9, 0.3, 0.1), z=0.0):
    return make_splats([[0.0, 0.0, z]], [sigma], [[1.0, 0.0, 0.0, 0.0]], [opacity],
                       albedo=[color], roughness=[0.3], metallic=[0.2])


CAM = Camera(position=(0.0, 0.0, 2.0), target=(0.0, 0.0, 0.0), fov_y=40.0, size=(64, 64))


def test_single_splat_alpha_footprint_and_channels(programs):
    from learned.parity.checks.splats import render_gl

    _, g = render_gl(programs, _one_splat(), CAM)
    a = g["alpha"][..., 0]
    # 64 px even: the centre lies on a pixel corner; the 4 nearest pixels share the peak
    peak = a.max()
    fx = 32 / np.tan(np.radians(20))
    sx, sy = (0.05 * fx / 2) ** 2 + 0.3, (0.02 * fx / 2) ** 2 + 0.3  # 2D variances, px^2
    d2 = 0.25 / sx + 0.25 / sy
    assert peak == pytest.approx(0.8 * np.exp(-0.5 * d2), rel=1e-5)
    # footprint: pixels with d^2 <= 8 and alpha >= 1/255
    j, i = np.meshgrid(np.arange(64) + 0.5 - 32, 32 - (np.arange(64) + 0.5))
    dd = j * j / sx + i * i / sy
    expect = (dd <= 8) & (0.8 * np.exp(-0.5 * dd) >= 1 / 255)
    assert np.array_equal(a > 0, expect)
    cov = a > 0
    np.testing.assert_allclose(g["depth"][cov], 2.0, rtol=1e-5)  # eq. 6.10 with one splat
    n = int(cov.sum())
    np.testing.assert_allclose(g["albedo"][cov], np.tile([0.9, 0.3, 0.1], (n, 1)), rtol=1e-5)
    np.testing.assert_allclose(g["roughness"][cov], 0.3, rtol=1e-5)
    np.testing.assert_allclose(g["normal"][cov], np.tile([0.0, 0.0, 1.0], (n, 1)), atol=1e-6)  # shortest axis, facing
    # baked colour = SH DC colour, premultiplied by alpha
    np.testing.assert_allclose(g["color"][cov], np.outer(a[cov], [0.9, 0.3, 0.1]), rtol=1e-5,
                               atol=1e-7)
    assert np.all(g["alpha"][~cov] == 0)


def test_cpu_and_gpu_sort_agree(programs):
    from learned.parity.checks.splats import parity_camera, random_scene, render_gl

    s = random_scene(3000, 5, sh_degree=1)
    _, cpu = render_gl(programs, s, parity_camera((48, 40)), sort="cpu")
    _, gpu = render_gl(programs, s, parity_camera((48, 40)), sort="gpu")
    for k in cpu:
        np.testing.assert_array_equal(cpu[k], gpu[k], err_msg=k)


def test_compositing_order_and_expected_depth(programs):
    from learned.parity.checks.splats import render_gl

    front = _one_splat(opacity=0.6, sigma=(0.2, 0.2, 0.01), color=(1, 0, 0), z=0.5)
    back = _one_splat(opacity=0.9, sigma=(0.2, 0.2, 0.01), color=(0, 0, 1), z=-0.5)
    from viewer.splats import concat

    _, g = render_gl(programs, concat([back, front]), CAM)
    c = g["alpha"][31, 31, 0], g["color"][31, 31], g["depth"][31, 31, 0]
    a1 = 0.6 * np.exp(-0.5 * 2 * 0.25 / ((0.2 * (32 / np.tan(np.radians(20))) / 1.5) ** 2 + 0.3))
    a2 = 0.9 * np.exp(-0.5 * 2 * 0.25 / ((0.2 * (32 / np.tan(np.radians(20))) / 2.5) ** 2 + 0.3))
    w1, w2 = a1, (1 - a1) * a2
    assert c[0] == pytest.approx(1 - (1 - a1) * (1 - a2), rel=1e-5)
    np.testing.assert_allclose(c[1], [w1, 0, w2], rtol=1e-4, atol=1e-6)
    assert c[2] == pytest.approx((w1 * 1.5 + w2 * 2.5) / (w1 + w2), rel=1e-5)


def test_splats_behind_a_mesh_are_hidden(programs):
    from learned.parity.checks.splats import render_gl
    from viewer.geometry import primitives
    from viewer.scene.material import Material

    wall = primitives.plane(center=(0, 0, 0.0), size=(4, 4), normal=(0, 0, 1),
                            material=Material(albedo=(0.2, 0.7, 0.2)))
    before, g = render_gl(programs, _one_splat(z=-0.3), CAM, meshes=[wall])
    np.testing.assert_allclose(g["albedo"], before["albedo"], atol=1e-6)
    np.testing.assert_allclose(g["color"], before["albedo"] * before["alpha"], atol=1e-6)
    before, g = render_gl(programs, _one_splat(z=0.3), CAM, meshes=[wall])
    assert g["albedo"][31, 31, 0] > 0.5 and np.all(g["alpha"] == 1.0)


SCENE = """
[camera]
position = [0, 0.2, 3]
fov_y = 40
size = [40, 32]
[environment]
procedural = "studio"
[[objects]]
type = "splats"
path = "{ply}"
[[objects]]
type = "plane"
center = [0, -0.9, 0]
"""


@pytest.fixture
def splat_scene(tmp_path):
    from viewer.splats.generate import sphere_splats

    write_ply(tmp_path / "s.ply", sphere_splats(600))
    p = tmp_path / "scene.toml"
    p.write_text(SCENE.format(ply="s.ply"))
    return p


@pytest.mark.parametrize("model", ["unlit", "blinn_phong", "ggx_split_sum"])
def test_render_splat_scene_every_model(ctx, splat_scene, model):
    from viewer.renderer import Renderer
    from viewer.scene.description import load_scene

    scene = load_scene(splat_scene).with_render(model=model, background="transparent")
    r = Renderer(ctx=ctx)
    try:
        f = r.render(scene, aovs=("color", "albedo", "alpha", "normal", "depth"))
    finally:
        r.release()
    assert np.all(np.isfinite(f.radiance))
    a = f.aovs["alpha"][..., 0]
    assert a[16, 20] > 0.9  # the sphere covers the centre
    if model == "unlit":  # mix(0, color / alpha, alpha): exactly the premultiplied colour
        np.testing.assert_allclose(f.radiance[..., :3], f.aovs["color"], rtol=1e-5, atol=1e-6)


def test_cli_render_and_bad_ply(tmp_path, splat_scene, capsys):
    out = tmp_path / "o.exr"
    assert main(["render", str(splat_scene), "--out", str(out), "--aov", "color", "-q"]) == 0
    assert out.exists() and (tmp_path / "o.color.exr").exists()
    (tmp_path / "s.ply").write_bytes(b"ply\nformat binary_little_endian 1.0\nelement vertex 9\n")
    out2 = tmp_path / "p.png"
    assert main(["render", str(splat_scene), "--out", str(out2), "-q"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("relight: error:") and "s.ply" in err and "\n" not in err
    assert not out2.exists()


def test_empty_splat_file_renders_the_rest(ctx, tmp_path):
    from viewer.renderer import Renderer
    from viewer.scene.description import load_scene
    from viewer.splats.data import empty_splats

    write_ply(tmp_path / "s.ply", empty_splats())
    p = tmp_path / "scene.toml"
    p.write_text(SCENE.format(ply="s.ply"))
    r = Renderer(ctx=ctx)
    try:
        with pytest.warns(UserWarning, match="no splats"):
            f = r.render(load_scene(p), aovs=("color",))
    finally:
        r.release()
    assert np.all(np.isfinite(f.radiance)) and np.all(np.isfinite(f.aovs["color"]))
    assert f.aovs["color"][-1, 20].max() > 0  # the plane's albedo
