"""The `relight` command: outputs, AOVs, and bad input -> one line on stderr, exit 2, no files."""
import json

import numpy as np
import pytest

from relight.cli import main
from viewer.imageio import read_image

SPHERE = """
[camera]
position = [0, 0, 3]
fov_y = 40
size = [48, 40]
[environment]
procedural = "studio"
[[objects]]
type = "sphere"
[objects.material]
albedo = [0.7, 0.3, 0.2]
roughness = 0.4
"""


@pytest.fixture
def scene_file(tmp_path):
    p = tmp_path / "s.toml"
    p.write_text(SPHERE)
    return p


def test_render_png_exr_and_aovs(tmp_path, scene_file, capsys):
    png, exr = tmp_path / "a.png", tmp_path / "a.exr"
    assert main(["render", str(scene_file), "--out", str(png), "-q"]) == 0
    assert main(["render", str(scene_file), "--out", str(exr), "--aov", "normal,depth,alpha",
                 "--size", "32x24", "-q"]) == 0
    img, _ = read_image(png)
    assert img.shape == (40, 48, 3)
    rad, names = read_image(exr)
    assert rad.shape == (24, 32, 3) and names == ["R", "G", "B"]
    assert np.isfinite(rad).all() and rad.min() >= 0
    normal, _ = read_image(tmp_path / "a.normal.exr")
    depth, _ = read_image(tmp_path / "a.depth.exr")
    alpha, _ = read_image(tmp_path / "a.alpha.exr")
    assert normal.shape == (24, 32, 3) and depth.shape == (24, 32, 1)
    # centre pixel looks at the sphere's pole facing the camera: depth 2, normal +Z
    c = (12, 16)
    assert alpha[c][0] == 1.0 and abs(depth[c][0] - 2.0) < 0.02
    assert normal[c][2] > 0.99


def test_render_supersampled(tmp_path, scene_file):
    """--ssaa 2: the PNG, the EXR and the AOVs at the output size (the frame drawn at 2x)."""
    png, exr = tmp_path / "s.png", tmp_path / "s.exr"
    assert main(["render", str(scene_file), "--out", str(png), "--ssaa", "2", "-q"]) == 0
    assert main(["render", str(scene_file), "--out", str(exr), "--ssaa", "2", "--aov", "depth",
                 "--size", "32x24", "-q"]) == 0
    assert read_image(png)[0].shape == (40, 48, 3)
    assert read_image(exr)[0].shape == (24, 32, 3)
    assert read_image(tmp_path / "s.depth.exr")[0].shape == (24, 32, 1)


def test_every_model_renders(tmp_path, scene_file):
    from viewer.models import MODELS

    for model in MODELS:
        out = tmp_path / f"{model}.exr"
        assert main(["render", str(scene_file), "--out", str(out), "--model", model, "-q"]) == 0
        img, _ = read_image(out)
        assert np.isfinite(img).all()


@pytest.mark.parametrize("args, needle", [
    (["--model", "phong"], "--model: render.model = 'phong' is not one of"),
    (["--aov", "normals"], "unknown AOV 'normals'"),
    (["--size", "12by3"], "--size must look like"),
    (["--samples", "0"], "--samples: render.samples must be an integer in [1"),
    (["--ssaa", "9"], "--ssaa: render.ssaa must be an integer in [1, 8]"),
    (["--aa", "msaa"], "--aa: render.aa = 'msaa' is not one of fxaa, none"),
])
def test_bad_options_exit_2_and_write_nothing(tmp_path, scene_file, capsys, args, needle):
    out = tmp_path / "x.png"
    assert main(["render", str(scene_file), "--out", str(out), *args]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("relight: error:") and needle in err and "\n" not in err
    assert not out.exists() and list(tmp_path.iterdir()) == [scene_file]


def test_bad_scene_and_output_paths(tmp_path, scene_file, capsys):
    assert main(["render", str(tmp_path / "none.toml"), "--out", str(tmp_path / "x.png")]) == 2
    assert "none.toml: scene file not found" in capsys.readouterr().err
    assert main(["render", str(scene_file), "--out", str(tmp_path / "x.jpg")]) == 2
    assert "--out must end in .exr" in capsys.readouterr().err
    assert main(["render", str(scene_file), "--out", str(tmp_path / "no" / "x.png")]) == 2
    assert "output folder does not exist" in capsys.readouterr().err


def test_missing_environment_file(tmp_path, capsys):
    p = tmp_path / "s.toml"
    p.write_text(SPHERE.replace('procedural = "studio"', 'path = "missing.exr"'))
    assert main(["render", str(p), "--out", str(tmp_path / "x.png")]) == 2
    err = capsys.readouterr().err
    assert "missing.exr" in err and not (tmp_path / "x.png").exists()


def test_info_json(capsys):
    assert main(["info", "--json"]) == 0
    info = json.loads(capsys.readouterr().out)
    assert info["version_code"] >= 430
    assert info["float_target_mantissa_bits"]["f4"] == 23
    # measured filter precision: GPUs keep 8 fraction bits (4 allowed), llvmpipe filters in
    # float and shows the probe's resolution
    bits = info["texture_filter_bits"]
    assert 4 <= bits["subtexel"] <= 16 and 4 <= bits["mipmap"] <= 16, bits
    if "llvmpipe" in str(info["renderer"]).lower():
        assert bits == {"subtexel": 16, "mipmap": 16}, bits


def test_demo_renders_by_default(tmp_path):
    out = tmp_path / "demo.png"
    assert main(["render", "--out", str(out), "--size", "80x50", "-q"]) == 0
    img, _ = read_image(out)
    assert img.shape == (50, 80, 3) and img.std() > 0.02  # not a flat or black image
