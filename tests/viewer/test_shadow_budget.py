"""The shadow budget (``[render] shadow_budget``, viewer/graph/shadows.py ``budgeted``): a frame's
light maps share about ``budget`` maps' texels, so more lights get maps of a smaller side, by the
same factor; a lone light, or a budget of 0, keeps the set sizes. The budget changes map sizes
and nothing else: a budgeted frame is the frame drawn with those sizes set by hand."""
import dataclasses

import numpy as np
import pytest
from shadow_scenes import CAMERA, DARK, FLOOR, SPHERE

from viewer.errors import SceneError
from viewer.graph.shadows import budgeted
from viewer.renderer import Renderer
from viewer.scene.description import load_scene, scene_from_dict
from viewer.scene.settings import ShadowSettings

SUN_LIKE = {"type": "directional", "intensity": 2.0, "angular_diameter_deg": 2.0}


@pytest.fixture(scope="module")
def renderer(ctx):
    r = Renderer(ctx=ctx)
    yield r
    r.release()


@pytest.mark.parametrize("maps, budget, size, cube", [
    (1, 1.0, 2048, 1024),  # a lone light keeps its sizes
    (4, 1.0, 1024, 512),   # four lights: half the side, a quarter of the texels each
    (2, 1.0, 1440, 720),   # 2048 / sqrt(2) = 1448, down to a multiple of 16
    (4, 2.0, 1440, 720),
    (3, 4.0, 2048, 1024),  # within the budget
    (8, 0.0, 2048, 1024),  # no limit
])
def test_the_budget_shares_one_maps_texels(maps, budget, size, cube):
    out = budgeted(ShadowSettings(budget=budget), maps)
    assert (out.size, out.cube_size) == (size, cube)
    assert dataclasses.replace(out, size=2048, cube_size=1024) == ShadowSettings(budget=budget)
    # together, the maps never hold more than the budget's texels (up to the rounding down)
    if 0.0 < budget < maps:
        assert maps * out.size ** 2 <= budget * 2048 ** 2


def test_small_maps_keep_a_floor():
    out = budgeted(ShadowSettings(size=100, cube_size=40), 16)
    assert (out.size, out.cube_size) == (64, 32)
    out = budgeted(ShadowSettings(size=64, cube_size=32), 16)
    assert (out.size, out.cube_size) == (64, 32)


def _scene(lights, render):
    return scene_from_dict({"camera": {**CAMERA, "size": [48, 48]}, "environment": DARK,
                            "lights": lights, "objects": [FLOOR, SPHERE],
                            "render": {"tonemap": "none", "shadow_size": 256,
                                       "shadow_cube_size": 128,
                                       # the maps' budget: the rasterised frame (the rays'
                                       # bounce would light the shadows it measures)
                                       "raytrace": False, **render}})


LIGHTS = [{**SUN_LIKE, "direction": [0.3, 1.0, 0.2]},
          {**SUN_LIKE, "direction": [-0.4, 1.0, 0.1]},
          {"type": "point", "position": [0.5, 3.0, -0.3], "intensity": 20.0},
          {"type": "spot", "position": [-1.0, 3.0, 0.5], "direction": [-0.2, 1.0, 0.1],
           "outer_cone_deg": 50, "inner_cone_deg": 40, "intensity": 20.0}]


@pytest.mark.parametrize("other, shapes", [(2, [(160, 240), (256, 384)]),  # a cube atlas
                                           (3, [(176, 176), (256, 256)])])  # a spot light
def test_every_kind_of_light_map_shrinks_alike(renderer, other, shapes):
    """Two lights under the default budget (a directional one, and a point or a spot light): the
    2D maps' sides and the point light's cube faces shrink by sqrt(2) (down to a multiple of
    16); without the budget, the set sizes."""
    lights = [LIGHTS[0], LIGHTS[other]]
    for render, sun_size, shape in (({}, 176, shapes[0]), ({"shadow_budget": 0}, 256, shapes[1])):
        aovs = renderer.render(_scene(lights, render), aovs=("shadow0", "shadow1")).aovs
        assert aovs["shadow0"].shape[:2] == (sun_size, sun_size)
        assert aovs["shadow1"].shape[:2] == shape


def test_a_budgeted_frame_is_the_frame_with_those_sizes(renderer):
    """The budget only sets sizes: two lights under it render exactly what the same lights do
    with the budget's sizes set and no budget (the shadows are there: where the sphere hides
    one of the two equal lights, the floor keeps about half the light of the frame without
    shadows)."""
    budget = _scene(LIGHTS[:2], {})
    by_hand = _scene(LIGHTS[:2], {"shadow_size": 176, "shadow_budget": 0})
    a = renderer.render(budget).radiance
    b = renderer.render(by_hand).radiance
    assert np.array_equal(a, b)
    free = renderer.render(_scene(LIGHTS[:2], {"shadows": False})).radiance
    assert (a[..., 0] < 0.75 * free[..., 0]).sum() > 20


@pytest.mark.parametrize("value, ok", [(0, True), (1, True), (2.5, True), (64, True),
                                       (0.5, False), (-1, False), (65, False), ("two", False)])
def test_the_budget_is_checked(tmp_path, value, ok):
    path = tmp_path / "scene.toml"
    path.write_text(f"[render]\nshadow_budget = {value!r}\n".replace("'", '"'))
    if ok:
        assert load_scene(path).render.shadow.budget == float(value)
    else:
        with pytest.raises(SceneError, match="shadow_budget"):
            load_scene(path)
