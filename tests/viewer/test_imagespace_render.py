"""Image-space G-buffer stacks shade exactly like the meshes they were captured from.

A mesh scene seen from the stack camera (origin, looking down -Z) is rendered, its G-buffer saved as
a 12-channel stack (depth normalised with near 1, far 800) and as an FFHQ256-PBR folder, loaded back
through a scene file and shaded: the radiance must match the mesh render.
"""
import numpy as np
import pytest

from relight.cli import main
from viewer.geometry.imagespace import ImageGBuffer, save_stack_exr
from viewer.imageio import read_image, write_exr, write_png
from viewer.renderer import Renderer
from viewer.scene.description import load_scene

MESH_SCENE = """
[camera]
position = [0, 0, 0]
target = [0, 0, -1]
fov_y = 30
size = [48, 40]
[environment]
procedural = "sky"
rotation_deg = 200
[[objects]]
type = "sphere"
center = [0, 0, -4]
radius = 1
[objects.material]
albedo = [0.8, 0.5, 0.2]
roughness = 0.35
metallic = 0.0
specular = 0.7
[render]
model = "{model}"
raytrace = false  # a stack holds no triangles to trace: both sides shade without rays
"""

STACK_SCENE = """
[environment]
procedural = "sky"
rotation_deg = 200
[[objects]]
type = "gbuffer"
path = "{path}"
fov_y = 30
[render]
model = "{model}"
"""


@pytest.fixture(scope="module")
def renderer(ctx):
    r = Renderer(ctx=ctx)
    yield r
    r.release()


def _capture(renderer, tmp_path, model):
    p = tmp_path / "mesh.toml"
    p.write_text(MESH_SCENE.format(model=model))
    aovs = ("albedo", "normal", "roughness", "specular", "metallic", "depth", "ao", "alpha")
    frame = renderer.render(load_scene(p), aovs=aovs)
    return frame, frame.aovs


@pytest.mark.parametrize("model", ["ggx_split_sum", "blinn_phong", "unlit"])
def test_stack_exr_matches_mesh_render(renderer, tmp_path, model):
    frame, ch = _capture(renderer, tmp_path, model)
    stack = ImageGBuffer(channels={k: v for k, v in ch.items()}, fov_y=30.0)
    save_stack_exr(tmp_path / "stack.exr", stack)
    scene_path = tmp_path / "stack.toml"
    scene_path.write_text(STACK_SCENE.format(path="stack.exr", model=model))
    got = renderer.render(load_scene(scene_path)).radiance
    # Normals and albedo survive the [0, 1] encoding to float32 rounding; the error is dominated
    # by normal re-normalisation (~1e-7) moving the specular lookup. Measured max abs 3e-5.
    np.testing.assert_allclose(got, frame.radiance, atol=5e-4, rtol=1e-3)


def test_ffhq_folder_matches_mesh_render(renderer, tmp_path):
    frame, ch = _capture(renderer, tmp_path, "ggx_split_sum")
    folder = tmp_path / "sample"
    folder.mkdir()
    write_exr(folder / "albedo.exr", ch["albedo"])
    write_exr(folder / "normal.exr", ch["normal"] * 0.5 + 0.5)
    write_exr(folder / "roughness.exr", ch["roughness"])
    write_exr(folder / "specular.exr", ch["specular"])
    write_exr(folder / "depth.exr", ch["depth"])
    write_png(folder / "mask.png", (ch["alpha"][..., 0] * 255).astype(np.uint8))
    (folder / "camera.json").write_text('{"fov_y": 30}')
    scene_path = tmp_path / "ffhq.toml"
    scene_path.write_text(STACK_SCENE.format(path="sample", model="ggx_split_sum"))
    got = renderer.render(load_scene(scene_path)).radiance
    np.testing.assert_allclose(got, frame.radiance, atol=5e-4, rtol=1e-3)


def test_nan_in_stack_is_an_error_naming_the_file(renderer, tmp_path, capsys):
    frame, ch = _capture(renderer, tmp_path, "ggx_split_sum")
    stack = ImageGBuffer(channels=dict(ch), fov_y=30.0)
    save_stack_exr(tmp_path / "stack.exr", stack)
    img, names = read_image(tmp_path / "stack.exr")
    img[3, 4, 0] = np.nan
    write_exr(tmp_path / "bad.exr", img, names)
    scene_path = tmp_path / "bad.toml"
    scene_path.write_text(STACK_SCENE.format(path="bad.exr", model="ggx_split_sum"))
    out = tmp_path / "out.png"
    assert main(["render", str(scene_path), "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert "bad.exr" in err and ("NaN" in err or "finite" in err) and not out.exists()


def test_stack_rejects_a_different_size(renderer, tmp_path, capsys):
    frame, ch = _capture(renderer, tmp_path, "unlit")
    save_stack_exr(tmp_path / "stack.exr", ImageGBuffer(channels=dict(ch), fov_y=30.0))
    scene_path = tmp_path / "s.toml"
    scene_path.write_text(STACK_SCENE.format(path="stack.exr", model="unlit"))
    assert main(["render", str(scene_path), "--out", str(tmp_path / "o.png"), "--size", "10x10"]) == 2
    assert "renders at its own size 48x40" in capsys.readouterr().err
