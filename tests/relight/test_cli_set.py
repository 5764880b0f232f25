"""``--set KEY=VALUE`` on ``relight render``, ``relight view`` and ``relight scene``: any ``[render]``
setting by its scene-file key, the value read as TOML, checked by the scene files' validator; a bad
key or value is one line naming ``--set``, exit 2, nothing written."""
import numpy as np
import pytest

from relight.cli import main
from viewer.imageio import read_image

SPHERE = """
[camera]
position = [0, 0, 3]
fov_y = 40
size = [24, 20]
[environment]
procedural = "studio"
[render]
{render}
[[objects]]
type = "sphere"
[objects.material]
albedo = [0.7, 0.3, 0.2]
roughness = 0.4
"""

# one triangle facing +Z
OBJ = "v -1 -1 0\nv 1 -1 0\nv 0 1 0\nvn 0 0 1\nf 1//1 2//1 3//1\n"


@pytest.fixture
def scene_file(tmp_path):
    p = tmp_path / "s.toml"
    p.write_text(SPHERE.format(render=""))
    return p


@pytest.fixture
def asset(tmp_path):
    p = tmp_path / "tri.obj"
    p.write_text(OBJ)
    return p


def test_parse_settings_reads_toml_values_and_bare_words():
    from relight.commands.common import parse_settings

    got = parse_settings(["raytrace=true", "ssao_rays=16", "exposure=-1", "tonemap=aces",
                          'model="unlit"', "shadow_cascades=auto", "ssao_rays = 8"])
    assert got == {"raytrace": True, "ssao_rays": 8, "exposure": -1.0, "tonemap": "aces",
                   "model": "unlit", "shadow_cascades": "auto"}
    assert parse_settings(None) == {} and parse_settings([]) == {}


def test_scene_command_writes_set_keys(asset, capsys):
    assert main(["scene", str(asset), "--set", "exposure=-1", "--set", "raytrace=true",
                 "--set", "tonemap=aces", "--size", "16x16"]) == 0
    text = capsys.readouterr().out
    assert "exposure = -1.0" in text and "raytrace = true" in text
    assert 'tonemap = "aces"' in text and "--set exposure=-1" in text.splitlines()[0]


def test_scene_command_sets_a_scene_file(scene_file, capsys):
    assert main(["scene", str(scene_file), "--set", "ssao_rays=16"]) == 0
    assert "ssao_rays = 16" in capsys.readouterr().out


def test_render_set_equals_the_scene_file_saying_it(tmp_path, scene_file):
    unlit = tmp_path / "unlit.toml"
    unlit.write_text(SPHERE.format(render='model = "unlit"'))
    a, b, c = tmp_path / "a.exr", tmp_path / "b.exr", tmp_path / "c.exr"
    assert main(["render", str(scene_file), "--out", str(a), "--set", "model=unlit", "-q"]) == 0
    assert main(["render", str(unlit), "--out", str(b), "-q"]) == 0
    assert main(["render", str(scene_file), "--out", str(c), "-q"]) == 0
    img_a, img_b, img_c = (read_image(p)[0] for p in (a, b, c))
    np.testing.assert_array_equal(img_a, img_b)
    assert not np.array_equal(img_a, img_c)  # the setting changed something


def test_render_set_reaches_an_asset_scene(tmp_path, asset):
    a, b = tmp_path / "a.png", tmp_path / "b.png"
    base = ["render", str(asset), "--size", "16x16", "-q"]
    assert main([*base, "--out", str(a)]) == 0
    assert main([*base, "--out", str(b), "--set", "exposure=-3"]) == 0
    assert read_image(b)[0].mean() < read_image(a)[0].mean()


@pytest.mark.parametrize("command", ["render", "scene", "view"])
@pytest.mark.parametrize("setting, needle", [
    ("colour=red", "--set: unknown key 'colour' in [render]"),
    ("ssao_rays=0", "--set: render.ssao_rays must be an integer in [1, 1024], got 0"),
    ("raytrace=yes", "--set: render.raytrace must be true or false, got 'yes'"),
    ("model=phong", "--set: render.model = 'phong' is not one of"),
    ("exposure", "--set: must look like KEY=VALUE"),
    ("=1", "--set: must look like KEY=VALUE"),
])
def test_bad_set_is_one_line_exit_2_nothing_written(tmp_path, scene_file, capsys, command,
                                                     setting, needle):
    if command == "view":
        pytest.importorskip("imgui_bundle")
    out = tmp_path / "x.png"
    extra = {"render": ["--out", str(out)], "view": ["--offscreen", "--screenshot", str(out)],
             "scene": []}[command]
    assert main([command, str(scene_file), *extra, "--set", setting]) == 2
    captured = capsys.readouterr()
    err = captured.err.strip()
    assert err.startswith("relight: error: --set:") and needle in err and "\n" not in err
    assert captured.out == "" and list(tmp_path.iterdir()) == [scene_file]


def test_view_set_reaches_the_viewer(tmp_path, scene_file):
    pytest.importorskip("imgui_bundle")
    unlit = tmp_path / "unlit.toml"
    unlit.write_text(SPHERE.format(render='model = "unlit"'))
    a, b = tmp_path / "a.exr", tmp_path / "b.exr"
    assert main(["view", str(scene_file), "--offscreen", "--screenshot", str(a), "--set",
                 "model=unlit", "-q"]) == 0
    assert main(["view", str(unlit), "--offscreen", "--screenshot", str(b), "-q"]) == 0
    np.testing.assert_array_equal(read_image(a)[0], read_image(b)[0])
