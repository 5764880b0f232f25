"""``--sun-strength S`` on ``relight scene`` / ``render``: the environment's compact sun times S
for assets and scene files alike, written to the TOML (and read back), rendered darker without
the sun; a negative or non-numeric value is refused by argparse in one line (exit 2)."""
import numpy as np
import pytest

from relight.cli import main
from viewer.imageio import read_image

OBJ = "v -1 -1 0\nv 1 -1 0\nv 0 1 0\nvn 0 0 1\nf 1//1 2//1 3//1\n"  # one triangle facing +Z


@pytest.fixture
def asset(tmp_path):
    p = tmp_path / "tri.obj"
    p.write_text(OBJ)
    return p


def test_scene_writes_the_strength_and_it_loads_back(asset, tmp_path, capsys):
    from viewer.scene.description import load_scene

    assert main(["scene", str(asset), "--env", "sky", "--sun-strength", "0", "--floor", "slab",
                 "--size", "16x16"]) == 0
    text = capsys.readouterr().out
    assert "sun_strength = 0.0" in text and "--sun-strength 0.0" in text.splitlines()[0]
    path = tmp_path / "s.toml"
    path.write_text(text)
    assert load_scene(path).environment.sun_strength == 0.0
    # a scene file given the option takes it too
    assert main(["scene", str(path), "--sun-strength", "2"]) == 0
    assert "sun_strength = 2.0" in capsys.readouterr().out


def test_render_without_the_sun_is_darker(asset, tmp_path):
    outs = {}
    for s in ("1", "0"):
        out = tmp_path / f"r{s}.exr"
        assert main(["render", str(asset), "--env", "sky", "--sun-strength", s, "--floor",
                     "slab", "--size", "24x16", "--model", "ggx_split_sum", "--set",
                     "raytrace=false", "--out", str(out)]) == 0
        outs[s] = read_image(out)[0][..., :3].astype(np.float64)
    assert outs["0"].sum() < 0.8 * outs["1"].sum()


@pytest.mark.parametrize("bad", ["-1", "sun", "inf"])
def test_bad_values_are_one_line(asset, capsys, bad):
    with pytest.raises(SystemExit) as exc:
        main(["scene", str(asset), "--sun-strength", bad])
    assert exc.value.code == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert "--sun-strength" in err[-1] and "Traceback" not in "\n".join(err)
