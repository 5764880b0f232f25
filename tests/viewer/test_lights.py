"""Point and spot lights ([[lights]], glTF KHR_lights_punctual) against analytic truth: a
Lambertian floor under a light of intensity I at distance d has radiance
albedo / pi * I cos(theta) / d^2 (times glTF's range window and spot cone factor)."""
import math
import warnings

import numpy as np
import pytest
from gltf_builder import GltfBuilder, quad

from viewer.errors import SceneError
from viewer.renderer import Renderer
from viewer.scene.description import load_scene, scene_from_dict

ALBEDO = 0.5
SIZE = 48
HEIGHT = 3.0  # the camera looks straight down at the floor y = 0 from here
TAN = math.tan(math.radians(30.0))


@pytest.fixture(scope="module")
def renderer(ctx):
    r = Renderer(ctx=ctx)
    yield r
    r.release()


def floor_scene(lights, model="ggx_split_sum", objects=None):
    doc = {"camera": {"position": [0, HEIGHT, 0], "target": [0, 0, 0], "up": [0, 0, -1],
                      "fov_y": 60, "size": [SIZE, SIZE]},
           "environment": {"procedural": "white", "intensity": 0.0},
           "objects": objects or [{"type": "plane", "center": [0, 0, 0], "size": [8, 8],
                                   "material": {"albedo": [ALBEDO] * 3, "roughness": 1.0,
                                                "specular": 0.0}}],
           "lights": lights,
           "render": {"model": model, "tonemap": "none", "samples": 1}}
    return scene_from_dict(doc)


def floor_point(row, col):
    """The floor point (y = 0) the pixel (row, col) shows (image row 0 at the top = -Z)."""
    x = ((col + 0.5) / SIZE * 2 - 1) * HEIGHT * TAN
    z = -(1 - (row + 0.5) / SIZE * 2) * HEIGHT * TAN
    return np.array([x, 0.0, z])


def lambert(point, light_pos, intensity, factor=1.0):
    to = np.asarray(light_pos) - point
    d2 = float(to @ to)
    cos = to[1] / math.sqrt(d2)
    return ALBEDO / math.pi * intensity * cos / d2 * factor


PIXELS = [(24, 24), (24, 40), (10, 30), (40, 8)]  # under the light ... far to the side


@pytest.mark.parametrize("model", ["blinn_phong", "ggx_split_sum", "ggx_mc", "neural"])
def test_point_light_on_a_lambertian_floor(renderer, model):
    pos = [0.1, 1.0, -0.05]
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no model ignores the light any more
        img = renderer.render(floor_scene([{"type": "point", "position": pos, "intensity": 2.0,
                                             "color": [1, 1, 1]}], model)).radiance
    for r, c in PIXELS:
        want = lambert(floor_point(r, c), pos, 2.0)
        assert img[r, c, :3] == pytest.approx([want] * 3, rel=0.05), (model, r, c)


def test_spot_light_cone(renderer):
    pos = np.array([0.0, 1.0, 0.0])
    inner, outer = 20.0, 40.0
    img = renderer.render(floor_scene([{"type": "spot", "position": list(pos), "intensity": 3.0,
                                        "direction": [0, 1, 0], "inner_cone_deg": inner,
                                        "outer_cone_deg": outer}])).radiance
    seen = {"inside": 0, "between": 0, "outside": 0}
    for r in range(0, SIZE, 3):
        for c in range(0, SIZE, 3):
            p = floor_point(r, c)
            angle = math.degrees(math.atan2(math.hypot(p[0], p[2]), 1.0))
            if abs(angle - inner) < 1.0 or abs(angle - outer) < 1.0:
                continue  # a pixel's footprint straddles the edge
            if angle < inner:
                factor, kind = 1.0, "inside"
            elif angle > outer:
                factor, kind = 0.0, "outside"
            else:  # glTF: the square of a ramp in the cosine
                t = (math.cos(math.radians(angle)) - math.cos(math.radians(outer))) / \
                    (math.cos(math.radians(inner)) - math.cos(math.radians(outer)))
                factor, kind = t * t, "between"
            seen[kind] += 1
            want = lambert(p, pos, 3.0, factor)
            assert img[r, c, 0] == pytest.approx(want, rel=0.05, abs=1e-4), (kind, angle)
    assert min(seen.values()) >= 5


def test_point_light_range_window(renderer):
    pos = np.array([0.0, 0.5, 0.0])
    rng = 1.2
    img = renderer.render(floor_scene([{"type": "point", "position": list(pos),
                                        "intensity": 1.0, "range": rng}])).radiance
    inside = outside = 0
    for r in range(0, SIZE, 4):
        for c in range(0, SIZE, 4):
            p = floor_point(r, c)
            d = float(np.linalg.norm(pos - p))
            window = min(max(1 - (d / rng) ** 4, 0.0), 1.0) ** 2
            assert img[r, c, 0] == pytest.approx(lambert(p, pos, 1.0, window), rel=0.05,
                                                 abs=2e-4)
            inside += window > 0.2
            outside += d > rng
    assert inside >= 5 and outside >= 5


def test_light_table_is_still_one_directional_light(renderer):
    old = floor_scene([])
    old = scene_from_dict({**{"camera": {"position": [0, HEIGHT, 0], "target": [0, 0, 0],
                                         "up": [0, 0, -1], "fov_y": 60, "size": [SIZE, SIZE]}},
                           "environment": {"procedural": "white", "intensity": 0.0},
                           "objects": [{"type": "plane", "size": [8, 8],
                                        "material": {"albedo": [ALBEDO] * 3, "specular": 0.0}}],
                           "light": {"direction": [0, 1, 0], "intensity": 2.0}})
    new = floor_scene([{"type": "directional", "direction": [0, 1, 0], "intensity": 2.0}])
    assert old.lights == new.lights
    img = renderer.render(old).radiance
    assert img[24, 24, 0] == pytest.approx(ALBEDO / math.pi * 2.0, rel=1e-3)


@pytest.mark.parametrize("lights, needle", [
    ([{"position": [0, 1, 0]}], "lights[0] has no type"),
    ([{"type": "area"}], "lights[0].type = 'area' is not one of"),
    ([{"type": "point"}], "lights[0].position is required"),
    ([{"type": "point", "position": [0, 1]}], "lights[0].position must be a list of 3"),
    ([{"type": "point", "position": [0, 1, 0], "direction": [0, 1, 0]}],
     "unknown key 'direction' in lights[0]"),
    ([{"type": "spot", "position": [0, 1, 0]}], "lights[0].direction is required"),
    ([{"type": "spot", "position": [0, 1, 0], "direction": [0, 1, 0], "inner_cone_deg": 30,
       "outer_cone_deg": 20}], "lights[0].inner_cone_deg (30.0) must be less than"),
    ([{"type": "point", "position": [0, 1, 0], "range": 0}], "lights[0].range must be > 0"),
    ([{"type": "point", "position": [0, 1, 0], "intensity": -1}], "lights[0].intensity = -1"),
    ([{"type": "directional", "direction": [0, 0, 0]}], "lights[0].direction must not be zero"),
    ([{"type": "point", "position": [0, 1, 0]}] * 9, "9 lights; a scene shades at most 8"),
])
def test_bad_lights_are_one_line_errors(tmp_path, lights, needle):
    import tomli_w

    p = tmp_path / "s.toml"
    p.write_text(tomli_w.dumps({"lights": lights}))
    with pytest.raises(SceneError) as exc:
        load_scene(p)
    msg = str(exc.value)
    assert needle in msg and "\n" not in msg and str(p) in msg


def test_gltf_point_light_with_node_transforms(renderer, tmp_path):
    """A glTF file with a floor and a point light under a translated parent node, placed by the
    scene's object transform: the floor is lit where the transformed light is, with no warning."""
    b = GltfBuilder()
    # the floor: the builder's z = 0 quad turned to y = 0 (facing +Y), 4 x 4
    quad(b, positions=np.float32([[-2, 0, -2], [-2, 0, 2], [2, 0, 2], [2, 0, -2]]),
         extra_attrs={"NORMAL": b.accessor(np.tile(np.float32([0, 1, 0]), (4, 1)))})
    b.doc["extensionsUsed"] = ["KHR_lights_punctual"]
    b.doc["extensions"] = {"KHR_lights_punctual": {"lights": [
        {"type": "point", "intensity": 2.0, "color": [1.0, 1.0, 1.0]}]}}
    b.doc["nodes"].append({"extensions": {"KHR_lights_punctual": {"light": 0}},
                           "translation": [0.0, 1.0, 0.0]})
    b.doc["nodes"].append({"children": [len(b.doc["nodes"]) - 1], "translation": [0.4, 0.0, 0.0]})
    b.doc["scenes"][0]["nodes"].append(len(b.doc["nodes"]) - 1)
    path = b.save(tmp_path / "lit.gltf")
    shift = [[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, -0.3], [0, 0, 0, 1]]  # object: 0.3 along -Z
    objects = [{"type": "mesh", "path": str(path), "transform": shift,
                "material": {"albedo": [ALBEDO] * 3, "roughness": 1.0, "specular": 0.0}}]
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        img = renderer.render(floor_scene([], objects=objects)).radiance
    pos = np.array([0.4, 1.0, -0.3])
    for r, c in PIXELS:
        assert img[r, c, 0] == pytest.approx(lambert(floor_point(r, c), pos, 2.0), rel=0.05)
    row, col = np.unravel_index(np.argmax(img[..., 0]), img.shape[:2])
    assert np.linalg.norm(floor_point(row, col)[[0, 2]] - pos[[0, 2]]) < 2 * HEIGHT * TAN / SIZE
