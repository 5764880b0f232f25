"""Scene TOML parsing: defaults, every key, and one-line errors naming the file and key."""
from pathlib import Path

import pytest

from viewer.errors import SceneError
from viewer.scene.description import load_scene, scene_from_dict

FULL = """
[camera]
position = [1, 2, 3]
target = [0, 0.5, 0]
up = [0, 1, 0]
fov_y = 30
size = [64, 48]

[environment]
procedural = "white"
intensity = 2.0
rotation_deg = 45

[[objects]]
type = "sphere"
center = [0, 0, 0]
radius = 0.5
[objects.material]
albedo = [0.1, 0.2, 0.3]
roughness = 0.25
metallic = 1.0
specular = 0.0

[[objects]]
type = "mesh"
path = "models/thing.glb"

[render]
model = "blinn_phong"
multiscatter = false
ao = false
tonemap = "reinhard"
exposure = -1.5
"""


def write(tmp_path: Path, text: str) -> Path:
    p = tmp_path / "scene.toml"
    p.write_text(text)
    return p


def test_full_scene_parses(tmp_path):
    scene = load_scene(write(tmp_path, FULL))
    assert scene.camera.size == (64, 48) and scene.camera.fov_y == 30
    assert scene.environment.procedural == "white" and scene.environment.intensity == 2.0
    assert scene.environment.rotation_deg == 45
    sphere, mesh = scene.objects
    assert sphere.material.albedo == (0.1, 0.2, 0.3) and sphere.material.metallic == 1.0
    assert Path(mesh.path) == (tmp_path / "models" / "thing.glb").resolve()  # relative to the file
    assert mesh.material is None  # meshes keep their own materials unless overridden
    r = scene.render
    assert (r.model, r.multiscatter, r.ao, r.display.tonemap, r.display.exposure) == (
        "blinn_phong", False, False, "reinhard", -1.5)


def test_defaults():
    scene = scene_from_dict({})
    assert scene.render.model == "ggx_split_sum" and scene.objects == ()
    assert scene.environment.procedural == "studio"


def test_with_render_is_immutable_update():
    scene = scene_from_dict({})
    brighter = scene.with_render(exposure=2.0)
    assert brighter.render.display.exposure == 2.0 and scene.render.display.exposure == 0.0


@pytest.mark.parametrize("text, needle", [
    ("[camera]\nfov = 30\n", "unknown key 'fov'"),
    ("[render]\nmodel = 'phong'\n", "render.model = 'phong'"),
    ("[render]\ntonemap = 'filmic'\n", "render.tonemap"),
    ("[[objects]]\ntype = 'teapot'\n", "objects[0].type"),
    ("[[objects]]\nradius = 1\n", "has no type"),
    ("[[objects]]\ntype = 'mesh'\n", "needs a path"),
    ("[[objects]]\ntype = 'sphere'\n[objects.material]\nroughness = 2\n", "outside [0.0, 1.0]"),
    ("[[objects]]\ntype = 'sphere'\n[objects.material]\nalbedo = [1, 2]\n", "list of 3 numbers"),
    ("[camera]\nsize = [0, 10]\n", "camera.size[0]"),
    ("[camera]\nposition = [0, 0, 0]\ntarget = [0, 0, 0]\n", "position equals target"),
    ("[environment]\npath = 'a.exr'\nprocedural = 'sky'\n", "both path and procedural"),
    ("[render]\nexposure = nan\n", "finite number"),
    ("[render]\nmultiscatter = 1\n", "true or false"),
    ("[lightz]\nx = 1\n", "unknown key 'lightz'"),
    ("this is not toml = = \n", "not valid TOML"),
])
def test_bad_scene_is_one_line_error_naming_file(tmp_path, text, needle):
    path = write(tmp_path, text)
    with pytest.raises(SceneError) as err:
        load_scene(path)
    msg = str(err.value)
    assert needle in msg
    assert str(path) in msg and "\n" not in msg


def test_missing_scene_file(tmp_path):
    with pytest.raises(SceneError, match="scene file not found"):
        load_scene(tmp_path / "nope.toml")


def test_demo_scene_parses():
    from assets import ASSET_ROOT

    scene = load_scene(ASSET_ROOT / "scenes" / "demo.toml")
    assert scene.objects and scene.render.model == "ggx_split_sum"
