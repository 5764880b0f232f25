"""Shadow maps of spot lights (perspective) and point lights (cube maps), judged against analytic
geometry: a sphere's shadow on a floor lands where the segments from the floor to the light pass
through the sphere (within two pixels, also where the shadow crosses the edges of a cube map's
faces), the penumbra widens with the light's radius, a lit floor never shadows itself, and a
light's map is redrawn when it moves, not when its intensity does."""
import dataclasses

import numpy as np
import pytest
from scipy import ndimage
from shadow_scenes import (
    CAMERA,
    CENTER,
    DARK,
    FLOOR,
    RADIUS,
    SPHERE,
    floor_points,
    sphere_pixels,
)

from viewer.renderer import Renderer
from viewer.scene.description import scene_from_dict


@pytest.fixture(scope="module")
def renderer(ctx):
    r = Renderer(ctx=ctx)
    yield r
    r.release()


def scene(objects, light, render=None):
    return scene_from_dict({
        "camera": CAMERA, "environment": DARK,
        "lights": [{"intensity": 20.0, **light}],
        "objects": objects, "render": {"tonemap": "none", **(render or {})}})


def analytic_shadow(light_pos, x, z):
    """Whether the segment from the floor point (x, 0, z) to the light meets the sphere."""
    p = np.stack([x, np.zeros_like(x), z], axis=-1)
    d = np.asarray(light_pos, float) - p
    length = np.linalg.norm(d, axis=-1)
    d = d / length[..., None]
    o = p - CENTER
    b = (o * d).sum(-1)
    c = (o * o).sum(-1) - RADIUS ** 2
    disc = b * b - c
    t = -b - np.sqrt(np.maximum(disc, 0))
    return (disc > 0) & (t > 0) & (t < length)


def visibility(renderer, objects, light, **kw):
    lit = renderer.render(scene(objects, light, **kw)).radiance[..., 0]
    render = {**(kw.pop("render", None) or {}), "shadows": False}
    free = renderer.render(scene(objects, light, render=render, **kw)).radiance[..., 0]
    return lit / np.maximum(free, 1e-9), free


LIGHTS = {
    "spot overhead": {"type": "spot", "position": [0.8, 3.0, 0.4], "direction": [0.3, 1, 0.1],
                      "outer_cone_deg": 60, "inner_cone_deg": 50},
    "spot slanted": {"type": "spot", "position": [-2.0, 3.5, 1.0], "direction": [-1, 0.9, 0.5],
                     "outer_cone_deg": 55, "inner_cone_deg": 45},
    "point overhead": {"type": "point", "position": [0.5, 3.0, -0.3]},
    # the sphere seen from the light straddles the +X, -Y and -Z faces of its cube map
    "point across faces": {"type": "point", "position": [-1.4, 2.1, 1.2]},
}


@pytest.mark.parametrize("name", list(LIGHTS))
def test_shadow_lands_on_its_analytic_projection(renderer, name):
    light = {**LIGHTS[name], "radius": 0.0}
    vis, free = visibility(renderer, [FLOOR, SPHERE], light)
    x, z = floor_points()
    truth = analytic_shadow(light["position"], x, z)
    keep = ~sphere_pixels(x, z) & (free > 1e-4)  # inside a spot's cone
    band = ndimage.binary_dilation(truth, iterations=2) & ~ndimage.binary_erosion(truth,
                                                                                  iterations=2)
    ours = vis < 0.5
    wrong = (ours != truth) & keep & ~band
    assert (truth & keep).sum() > 200  # a real shadow, seen beside the sphere
    assert wrong.sum() == 0, np.argwhere(wrong)[:10]
    assert (vis[keep & ~truth & ~band] > 0.999).all()  # lit floor stays lit


def _penumbra_pixels(vis, keep):
    return int(((vis > 0.05) & (vis < 0.95) & keep).sum())


@pytest.mark.parametrize("kind", ["spot", "point"])
def test_penumbra_widens_with_the_lights_radius(renderer, kind):
    light = LIGHTS[f"{kind} overhead"]
    x, z = floor_points()
    keep = ~sphere_pixels(x, z)
    widths = {}
    for radius in (0.0, 0.1, 0.2, 0.4):
        vis, _ = visibility(renderer, [FLOOR, SPHERE], {**light, "radius": radius})
        widths[radius] = _penumbra_pixels(vis, keep)
    assert widths[0.0] < widths[0.1] < widths[0.2] < widths[0.4], widths
    # similar triangles: the penumbra's width is proportional to the radius (R (1/zb - 1/zr)),
    # its band's pixel count with it once several pixels wide. Here spot 2.000 / 2.146, point
    # 2.075 / 2.194; over 19 light positions (each light moved up to 0.6 across, -0.5..0.8 up)
    # the 38 ratios are 2.11 +- 0.045 (2.00-2.20; a point light straight above the sphere, whose
    # shadow hides under it, measured 1.89 / 1.73 and is not a case here): the band is about
    # +-5 standard deviations. It fails a radius clamped at 0.3 (0.2 -> 0.4: 1.58 / 1.60) and
    # penumbrae growing as radius^0.8 (1.78 / 1.80) or radius^1.2 (2.36-2.58), which 1.4-2.8 passed.
    for lo, hi in ((0.1, 0.2), (0.2, 0.4)):
        assert 1.85 < widths[hi] / widths[lo] < 2.35, widths


@pytest.mark.parametrize("height", [0.3, 1.0, 4.0])
def test_no_acne_on_a_lit_floor(renderer, height):
    """No occluder: the floor sees a point light fully from near grazing (a light 0.3 above a
    floor seen out to 5 m away: 3.4 degrees) to overhead."""
    vis, free = visibility(renderer, [FLOOR], {"type": "point", "position": [0.3, height, 0.2]},
                           render={"shadow_cube_size": 256})
    assert vis[free > 1e-6].min() > 0.999, vis.min()


def test_moving_the_light_redraws_its_map(renderer):
    from viewer.gl.timing import PassTimer

    sc = scene([FLOOR, SPHERE], LIGHTS["point overhead"])
    renderer.profiler = timer = PassTimer(renderer.ctx)
    try:
        renderer.draw(sc)
        timer.enabled = True
        timer.reset()
        renderer.draw(dataclasses.replace(sc, lights=(dataclasses.replace(
            sc.lights[0], intensity=7.0),)))
        assert "shadow0" not in set(timer.milliseconds())
        timer.reset()
        renderer.draw(dataclasses.replace(sc, lights=(dataclasses.replace(
            sc.lights[0], position=(0.0, 3.0, 0.0)),)))
        assert "shadow0" in set(timer.milliseconds())
    finally:
        timer.enabled = False
        renderer.profiler = None


@pytest.mark.parametrize("doc, needle", [
    ({"lights": [{"type": "point", "position": [0, 1, 0], "radius": -0.1}]},
     "lights[0].radius = -0.1 is outside [0.0, inf]"),
    ({"lights": [{"type": "spot", "position": [0, 1, 0], "direction": [0, 1, 0],
                  "shadow": "yes"}]}, "lights[0].shadow must be true or false"),
    ({"lights": [{"type": "directional", "direction": [0, 1, 0], "radius": 0.1}]},
     "unknown key 'radius' in lights[0]"),
    ({"render": {"contact_shadows": "always"}},
     "render.contact_shadows = 'always' is not one of auto, on, off"),
    ({"render": {"contact_length": 0}}, "render.contact_length = 0 is outside"),
    ({"render": {"shadow_cube_size": 8}}, "render.shadow_cube_size"),
])
def test_bad_shadow_keys_are_one_line_errors(tmp_path, doc, needle):
    import tomli_w

    from viewer.errors import SceneError
    from viewer.scene.description import load_scene

    p = tmp_path / "s.toml"
    p.write_text(tomli_w.dumps(doc))
    with pytest.raises(SceneError) as exc:
        load_scene(p)
    assert needle in str(exc.value) and "\n" not in str(exc.value), str(exc.value)


def test_a_lights_radius_and_shadow_round_trip():
    from viewer.lighting.lights import DEFAULT_RADIUS, Light
    from viewer.lighting.tables import light_table, parse_lights_entry

    spot = Light(type="spot", position=(0.0, 2.0, 0.0), radius=0.2, shadow=False,
                 inner_cone_deg=10.0, outer_cone_deg=30.0)
    table = light_table(spot)
    assert table["radius"] == 0.2 and table["shadow"] is False
    assert parse_lights_entry(table, 0, "s.toml") == spot
    point = Light(type="point", position=(1.0, 2.0, 3.0))
    assert point.radius == DEFAULT_RADIUS and "radius" not in light_table(point)
