"""``relight render|view|scene ASSET...``: asset files open in one command, framed and upright;
an 8-bit environment renders as its linear EXR twin; ``relight scene`` round-trips; bad input is
one line."""
import numpy as np
import pytest
from asset_files import GREEN, box_gltf, capture_ply, capture_splat

from relight.cli import main
from viewer.imageio import read_image

SIZE = ["--size", "64x48"]


def _render(tmp_path, name, *args, aovs="alpha,albedo"):
    out = tmp_path / f"{name}.exr"
    assert main(["render", *map(str, args), "--out", str(out), "--aov", aovs, "-q"]) == 0
    rad, _ = read_image(out)
    alpha, _ = read_image(tmp_path / f"{name}.alpha.exr")
    albedo = read_image(tmp_path / f"{name}.albedo.exr")[0] if "albedo" in aovs else None
    return rad, alpha[..., 0], albedo


def _extent(mask):
    """(rows spanned / H, columns spanned / W, touches the border)."""
    rows, cols = np.nonzero(mask)
    h, w = mask.shape
    border = mask[0].any() or mask[-1].any() or mask[:, 0].any() or mask[:, -1].any()
    return (rows.max() - rows.min() + 1) / h, (cols.max() - cols.min() + 1) / w, border


def test_gltf_renders_framed_without_a_scene_file(tmp_path, capsys):
    glb = box_gltf(tmp_path / "model.glb")
    env = tmp_path / "env.exr"
    from viewer.environment.maps import sky_environment
    from viewer.imageio import write_exr

    write_exr(env, sky_environment(64))
    png = tmp_path / "h.png"
    assert main(["render", str(glb), "--env", str(env), "--out", str(png), *SIZE]) == 0
    assert read_image(png)[0].shape == (48, 64, 3)
    _, alpha, _ = _render(tmp_path, "h", glb, "--env", env, *SIZE)
    rows, cols, border = _extent(alpha > 0.5)
    assert max(rows, cols) > 0.8 and not border  # fills the frame, nothing cut off
    err = capsys.readouterr().err
    assert "Warning" not in err and "note:" not in err  # glTF: +Y by spec, nothing assumed


def _upright_and_framed(alpha, albedo):
    """The capture's ball is red above its equator and blue below; ground grey; outliers green."""
    red = (albedo[..., 0] > 0.6) & (albedo[..., 2] < 0.3)
    blue = (albedo[..., 2] > 0.6) & (albedo[..., 0] < 0.3)
    green = (albedo[..., 1] > 0.6) & (albedo[..., 0] < 0.3)
    assert red.sum() > 20 and blue.sum() > 5
    rows = np.arange(alpha.shape[0])[:, None]
    assert (rows * red).sum() / red.sum() < (rows * blue).sum() / blue.sum() - 2  # red on top
    rows_span, cols_span, border = _extent((alpha > 0.5) & ~green)
    assert max(rows_span, cols_span) > 0.7 and not border


@pytest.mark.parametrize("name, marker", [("marked", ["up +Z"]), ("unmarked", [])])
def test_z_up_splat_ply_renders_upright(tmp_path, capsys, name, marker):
    ply = capture_ply(tmp_path / f"{name}.ply", "+Z", comments=marker)
    _, alpha, albedo = _render(tmp_path, name, ply, "--model", "unlit", "--env", "white", *SIZE)
    _upright_and_framed(alpha, albedo)
    notes = [ln for ln in capsys.readouterr().err.splitlines() if "note:" in ln]
    assert len(notes) == 1 and notes[0].startswith(f"relight: note: {ply}: taken as +Z up")
    assert ("read from its header" if marker else "detected") in notes[0]


def test_y_down_splat_with_far_outliers_renders_upright_and_framed(tmp_path, capsys):
    path = capture_splat(tmp_path / "capture.splat", "-Y")
    _, alpha, albedo = _render(tmp_path, "c", path, "--model", "unlit", "--env", "white", *SIZE)
    _upright_and_framed(alpha, albedo)
    assert "taken as -Y up (detected" in capsys.readouterr().err
    # --up always wins: +Y (the identity) shows the capture upside down
    _, alpha, albedo = _render(tmp_path, "d", path, "--model", "unlit", "--up", "+Y", *SIZE)
    with pytest.raises(AssertionError):
        _upright_and_framed(alpha, albedo)


def test_png_environment_renders_as_its_linear_exr(tmp_path, capsys):
    from viewer.geometry.mesh import srgb_to_linear
    from viewer.imageio import write_exr, write_png

    y, x = np.meshgrid(np.linspace(1.0, 0.0, 32), np.linspace(0.0, 1.0, 64), indexing="ij")
    u8 = np.round(255 * np.stack([y, 0.5 * y + 0.5 * x, x * (1 - y)], -1))
    write_png(tmp_path / "env.png", u8.astype(np.uint8))
    write_exr(tmp_path / "env.exr", srgb_to_linear(u8 / 255.0))
    glb = box_gltf(tmp_path / "m.glb")
    a, _, _ = _render(tmp_path, "a", glb, "--env", tmp_path / "env.png", *SIZE, aovs="alpha")
    err = capsys.readouterr().err
    b, _, _ = _render(tmp_path, "b", glb, "--env", tmp_path / "env.exr", *SIZE, aovs="alpha")
    # same linear radiance up to 8-bit quantisation (1/255 of the brightest texel)
    assert np.abs(a - b).max() < 1.0 / 255.0 and a.mean() > 0.05
    warned = [ln for ln in err.splitlines() if "decoded from sRGB" in ln]
    assert len(warned) == 1 and warned[0].startswith(f"relight: warning: {tmp_path / 'env.png'}")
    assert "UserWarning" not in err and "clipped" in warned[0]


def test_scene_command_round_trips(tmp_path, capsys):
    glb = box_gltf(tmp_path / "m.glb")
    ply = capture_ply(tmp_path / "c.ply", "+Z")
    args = [str(glb), str(ply), "--floor", "--env", "sky", "--model", "blinn_phong", *SIZE]
    assert main(["scene", *args]) == 0
    text = capsys.readouterr().out
    assert text.startswith("# made by relight scene") and 'type = "plane"' in text
    (tmp_path / "s.toml").write_text(text)
    a, _, _ = _render(tmp_path, "a", *args, aovs="alpha")
    b, _, _ = _render(tmp_path, "b", tmp_path / "s.toml", aovs="alpha")
    np.testing.assert_array_equal(a, b)


@pytest.mark.parametrize("make, problem", [
    (lambda d: d / "missing.glb", "missing.glb: file not found"),
    (lambda d: (d / "a.xyz").write_text("x") and d / "a.xyz", "unknown asset extension"),
    (lambda d: (d / "bad.glb").write_bytes(b"glTF\x02\x00garbage") and d / "bad.glb",
     "bad.glb: corrupt or unreadable glTF"),
    (lambda d: (d / "bad.ply").write_bytes(b"ply\nformat ascii 1.0\nelement vertex 3\n"
                                           b"property float x\nend_header\n1\n") and d / "bad.ply",
     "bad.ply: "),
])
def test_bad_assets_are_one_line(tmp_path, capsys, make, problem):
    path = make(tmp_path)
    assert main(["render", str(path), "--out", str(tmp_path / "o.png"), *SIZE]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("relight: error: ") and problem in err[0], err
    assert not (tmp_path / "o.png").exists()


def test_bad_options_are_one_line(tmp_path, capsys):
    glb = str(box_gltf(tmp_path / "m.glb"))
    scene = tmp_path / "s.toml"
    scene.write_text("[[objects]]\ntype = 'sphere'\n")
    for args, problem in ((["--up", "Q"], "--up: up must be one of"),
                          (["--env", "nowhere.exr"], "environment file not found"),
                          (["--model", "magic"], "--model")):
        assert main(["scene", glb, *args]) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and problem in err[0], err
    assert main(["scene", str(scene), glb]) == 2
    assert "opened alone" in capsys.readouterr().err
    assert main(["scene", str(scene), "--up", "-Z"]) == 2  # "-Z" taken as the value
    assert "--up and --floor are for asset files" in capsys.readouterr().err


@pytest.mark.parametrize("command", ["render", "view", "scene"])
def test_help_lists_the_choices(command, capsys):
    with pytest.raises(SystemExit):
        main([command, "--help"])
    text = " ".join(capsys.readouterr().out.split())
    for word in ("ggx_split_sum", "unlit", "sky", "studio", "white", "+Z", "-Y", "--floor"):
        assert word in text, word


def test_view_opens_an_asset(tmp_path):
    pytest.importorskip("imgui_bundle")
    shot = tmp_path / "v.png"
    code = main(["view", str(box_gltf(tmp_path / "m.glb")), "--offscreen", "--screenshot",
                 str(shot), "--size", "64x48", "--floor", "-q"])
    assert code == 0 and read_image(shot)[0].shape[:2] == (48, 64)


def test_image_stack_opens_as_an_asset(tmp_path, capsys):
    """A 12-channel G-buffer stack given directly renders from its own camera, as the scene it
    was captured from (camera at the origin looking down -Z: the stack's convention)."""
    from viewer.geometry.imagespace import ImageGBuffer, save_stack_exr

    scene = tmp_path / "ball.toml"
    scene.write_text("[camera]\nposition = [0, 0, 0]\ntarget = [0, 0, -1]\nfov_y = 30\n"
                     "size = [48, 40]\n[[objects]]\ntype = 'sphere'\ncenter = [0, 0, -3]\n")
    channels = ("albedo", "normal", "roughness", "specular", "metallic", "depth", "ao", "alpha")
    want, _, _ = _render(tmp_path, "want", scene, aovs=",".join(channels))
    stack = ImageGBuffer(channels={c: read_image(tmp_path / f"want.{c}.exr")[0]
                                   for c in channels}, fov_y=30.0)
    save_stack_exr(tmp_path / "stack.exr", stack)
    got, alpha, _ = _render(tmp_path, "got", tmp_path / "stack.exr", "--floor", aovs="alpha")
    assert got.shape == want.shape and alpha.max() == 1.0
    np.testing.assert_allclose(got, want, atol=5e-4, rtol=1e-3)  # as test_imagespace_render
    assert "--floor ignored" in capsys.readouterr().err


def test_floor_catches_the_suns_shadow(tmp_path, capsys):
    glb = box_gltf(tmp_path / "m.glb")
    rad, _, albedo = _render(tmp_path, "f", glb, "--floor", "slab", "--env", "sky", *SIZE)
    floor = (np.abs(albedo - 0.5) < 0.01).all(axis=-1)  # the floor's mid grey (the box is white)
    lum = rad[..., :3].mean(axis=-1)[floor]
    assert floor.sum() > 200
    # lit by the sun (~0.95) and in the box's shadow (~0.36; measured at 64x48)
    assert np.percentile(lum, 95) > 2.0 * np.percentile(lum, 5)
    # a bare --floor is the shadow catcher (tests/viewer/test_ground.py); a wrong kind is one line
    assert main(["scene", str(glb), "--floor"]) == 0
    assert "catcher = true" in capsys.readouterr().out
    with pytest.raises(SystemExit):
        main(["scene", str(glb), "--floor", "wood"])
    assert "invalid choice: 'wood'" in capsys.readouterr().err
