"""`relight graph`: the frame graph of the demo, a glTF scene, an image stack and a splat scene,
what a change redraws, its DOT (rendered by Graphviz when it is installed), and bad input."""
import json
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest

from relight.cli import main

ROOT = Path(__file__).resolve().parents[2]


def _stack_scene(tmp_path):
    """A 12-channel image stack (a flat disc of normals facing the camera) and its scene."""
    from viewer.geometry.imagespace import ImageGBuffer, save_stack_exr

    h, w = 32, 48
    yy, xx = np.mgrid[0:h, 0:w]
    alpha = (((xx - w / 2) ** 2 + (yy - h / 2) ** 2) < 12 ** 2).astype(np.float32)[..., None]
    ch = {"albedo": np.full((h, w, 3), 0.6, np.float32), "alpha": alpha,
          "normal": np.broadcast_to(np.float32([0, 0, 1]), (h, w, 3)).copy(),
          "roughness": np.full((h, w, 1), 0.5, np.float32),
          "metallic": np.zeros((h, w, 1), np.float32),
          "specular": np.full((h, w, 1), 0.5, np.float32),
          "depth": np.full((h, w, 1), 4.0, np.float32)}
    save_stack_exr(tmp_path / "stack.exr", ImageGBuffer(channels=ch, fov_y=30.0))
    path = tmp_path / "stack.toml"
    path.write_text(f'[environment]\nprocedural = "sky"\n[[objects]]\ntype = "gbuffer"\n'
                    f'path = "{tmp_path / "stack.exr"}"\nfov_y = 30\n')
    return path


def _splat_scene(tmp_path):
    from viewer.splats import write_ply
    from viewer.splats.generate import sphere_splats

    write_ply(tmp_path / "s.ply", sphere_splats(400, radius=0.5))
    path = tmp_path / "splats.toml"
    path.write_text(f'[camera]\nposition = [0, 0, 3]\nfov_y = 40\n[environment]\n'
                    f'procedural = "studio"\n[[objects]]\ntype = "splats"\n'
                    f'path = "{tmp_path / "s.ply"}"\n')
    return path


SCENES = {  # scene -> (its file, made in tmp_path or not; the passes its first frame draws)
    "demo": (lambda tmp: ROOT / "assets/scenes/demo.toml", {"gbuffer", "shade", "tonemap"}),
    "glTF": (lambda tmp: ROOT / "assets/scenes/gallery.toml", {"gbuffer", "shade", "tonemap"}),
    "image stack": (_stack_scene, {"shade", "tonemap"}),
    "splats": (_splat_scene, {"gbuffer", "splats", "shade", "tonemap"}),
}


@pytest.mark.parametrize("name", list(SCENES))
def test_graph_of_every_kind_of_scene(name, tmp_path, capsys):
    make, must = SCENES[name]
    path = make(tmp_path)
    dot = tmp_path / "g.dot"
    size = [] if name == "image stack" else ["--size", "48x32"]  # a stack has its own size
    assert main(["graph", str(path), *size, "--json", "--dot", str(dot)]) == 0
    info = json.loads(capsys.readouterr().out)
    status = {p["name"]: p["status"] for p in info["passes"]}
    assert must <= {n for n, s in status.items() if s == "drawn"}, status
    assert {"targets", "programs", "geometry"} <= set(info["memory"])
    declared = sum(r["bytes"] for r in info["resources"])
    assert declared > 0
    text = dot.read_text()
    assert text.startswith("digraph") and all(f'"pass:{n}"' in text for n in status)
    if shutil.which("dot"):  # the DOT renders
        subprocess.run(["dot", "-Tsvg", str(dot), "-o", str(tmp_path / "g.svg")], check=True)
        assert (tmp_path / "g.svg").stat().st_size > 0


def test_then_shows_what_a_slider_redraws(capsys):
    assert main(["graph", "--size", "48x32", "--then", "exposure=1.5"]) == 0
    out = capsys.readouterr().out
    assert "after exposure=1.5" in out
    passes = out.split("\n\n")[1]  # the pass table (resources and caches follow)
    lines = {ln.split()[0]: ln for ln in passes.splitlines()[1:]}
    assert " reused " in lines["gbuffer"] and " reused " in lines["shade"]
    assert " drawn " in lines["tonemap"] and "exposure" in lines["tonemap"]


@pytest.mark.parametrize("args, message", [
    (["--then", "exposure"], "expected KEY=VALUE"),
    (["--then", "no_such_setting=1"], "no_such_setting"),
    (["--dot", "/no/such/folder/g.dot"], "output folder does not exist"),
])
def test_bad_input_is_one_line(args, message, capsys):
    assert main(["graph", "--size", "16x16"] + args) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and message in err[0], err
