"""The optional directional light ([light]): parsing, saving, and what it adds to every model, with
physics as the oracle (Lambert: L = albedo E cos(theta) / pi; no light below the horizon)."""
import dataclasses
import math
import warnings

import numpy as np
import pytest

from viewer.errors import SceneError
from viewer.renderer import Renderer
from viewer.scene.description import (
    DirectionalLight,
    ObjectSpec,
    Scene,
    load_scene,
    scene_from_dict,
)
from viewer.scene.files import save_scene
from viewer.scene.material import Material

LIT_MODELS = ("ggx_split_sum", "blinn_phong", "ggx_mc")


@pytest.fixture(scope="module")
def renderer(ctx):
    r = Renderer(ctx=ctx)
    yield r
    r.release()


def dark_scene(objects, light: dict | None, model="ggx_split_sum", size=(64, 64), **camera):
    """A black environment (intensity 0): every photon comes from the light."""
    doc = {
        "camera": {"position": [0, 0, 3.5], "fov_y": 40, "size": list(size), **camera},
        "environment": {"procedural": "sky", "intensity": 0.0, "width": 64},
        # the rasterised models' shared light term (ggx_mc traces no rays)
        "render": {"tonemap": "none", "model": model, "samples": 4, "raytrace": False},
    }
    if light is not None:
        doc["light"] = light
    scene = scene_from_dict(doc)
    return dataclasses.replace(scene, objects=tuple(objects))


def lambertian(rho=(1.0, 1.0, 1.0)) -> Material:
    return Material(albedo=rho, roughness=0.5, metallic=0.0, specular=0.0)


# ---- scene files ---------------------------------------------------------------------------------

def test_light_table_parses_and_normalises(tmp_path):
    p = tmp_path / "s.toml"
    p.write_text("[light]\ndirection = [0, 3, 4]\ncolor = [1, 0.5, 0]\nintensity = 2.5\n")
    (light,) = load_scene(p).lights
    assert light == DirectionalLight(direction=(0.0, 0.6, 0.8), color=(1.0, 0.5, 0.0),
                                     intensity=2.5)
    assert light.irradiance == (2.5, 1.25, 0.0)
    assert scene_from_dict({}).light is None  # no table, no light
    assert scene_from_dict({"light": {"direction": [0, 0, 1]}}).lights[0] == DirectionalLight(
        direction=(0.0, 0.0, 1.0), color=(1.0, 1.0, 1.0), intensity=1.0)


@pytest.mark.parametrize("text, needle", [
    ("[light]\ndirection = [0, 0, 0]\n", "light.direction must not be zero"),
    ("[light]\ncolor = [1, 1, 1]\n", "light.direction is required"),
    ("[light]\ndirection = [0, 1]\n", "light.direction must be a list of 3 numbers"),
    ("[light]\ndirection = [0, nan, 1]\n", "light.direction must be a finite number"),
    ("[light]\ndirection = [0, 1, 0]\ncolor = [1, -0.1, 1]\n", "light.color"),
    ("[light]\ndirection = [0, 1, 0]\nintensity = -1\n", "light.intensity = -1"),
    ("[light]\ndirection = [0, 1, 0]\nintensity = inf\n", "light.intensity must be a finite"),
    ("[light]\ndirection = [0, 1, 0]\nintensity = true\n", "light.intensity must be a finite"),
    ("[light]\ndirection = [0, 1, 0]\ntype = 'spot'\n", "unknown key 'type' in [light]"),
    ("light = 3\n", "[light] must be a table"),
    ("[[light]]\ndirection = [0, 1, 0]\n", "[light] must be a table"),
])
def test_bad_light_is_one_line_error_naming_file_and_key(tmp_path, text, needle):
    p = tmp_path / "bad.toml"
    p.write_text(text)
    with pytest.raises(SceneError) as err:
        load_scene(p)
    msg = str(err.value)
    assert needle in msg and str(p) in msg and "\n" not in msg


@pytest.mark.parametrize("direction", [(0.3, 1.0, 0.5), (1e-3, 0.0, 0.0), (0.1, 0.2, -0.7)])
def test_save_scene_round_trips_the_light(tmp_path, direction):
    scene = scene_from_dict({"light": {"direction": list(direction), "color": [0.9, 0.8, 0.1],
                                       "intensity": 7.25}})
    again = load_scene(save_scene(scene, tmp_path / "s.toml"))
    assert again.light == scene.light  # bit-exact: a unit direction is not renormalised
    assert dataclasses.replace(again, source=None) == dataclasses.replace(scene, source=None)
    plain = load_scene(save_scene(scene_from_dict({}), tmp_path / "none.toml"))
    assert plain.light is None and "[light]" not in (tmp_path / "none.toml").read_text()


# ---- physics -------------------------------------------------------------------------------------

@pytest.mark.parametrize("model", LIT_MODELS)
def test_lambertian_sphere_under_a_light_in_the_dark(renderer, model):
    """albedo E / pi where the normal faces the light, albedo E cos(theta) / pi on the lit side,
    exactly 0 on the unlit side (no environment, no shadows needed for a convex object)."""
    rho, e = (0.7, 0.5, 0.25), 3.0
    l_ws = np.array([0.7, 0.4, 0.6]) / np.linalg.norm([0.7, 0.4, 0.6])
    scene = dark_scene([ObjectSpec("sphere", radius=1.0, material=lambertian(rho))],
                       {"direction": l_ws.tolist(), "intensity": e}, model)
    frame = renderer.render(scene, aovs=("normal",))
    n = frame.aovs["normal"]
    n = n / np.maximum(np.linalg.norm(n, axis=-1, keepdims=True), 1e-12)
    on = frame.radiance[..., 3] == 1.0
    cos = n @ l_ws
    rad = frame.radiance[..., :3].astype(np.float64)
    facing = np.unravel_index(np.argmax(np.where(on, cos, -2.0)), cos.shape)
    assert cos[facing] > 0.999
    np.testing.assert_allclose(rad[facing], np.multiply(rho, e / math.pi), rtol=5e-3)
    lit = on & (cos > 0.05)
    expected = np.multiply.outer(cos[lit], np.multiply(rho, e / math.pi))
    # measured: 9.5e-7 relative (float32 vs float64); 2.9e-4 at the facing pixel (cos 0.9997)
    np.testing.assert_allclose(rad[lit], expected, rtol=1e-4, atol=1e-6)
    dark = on & (cos < -0.05)
    assert dark.sum() > 100 and lit.sum() > 300
    assert np.all(rad[dark] == 0.0)


@pytest.mark.parametrize("model", LIT_MODELS)
@pytest.mark.parametrize("theta_deg", [0.0, 30.0, 60.0, 85.0])
def test_white_plane_reflects_e_cos_theta_over_pi(renderer, model, theta_deg):
    """The light's furnace: a white Lambertian plane (no specular lobe) under irradiance E at
    normal incidence from theta renders E cos(theta) / pi everywhere (nothing is lost, nothing
    gained)."""
    e = 2.0
    t = math.radians(theta_deg)
    plane = ObjectSpec("plane", center=(0.0, 0.0, 0.0), size=(8.0, 8.0), normal=(0.0, 0.0, 1.0),
                       material=lambertian())
    scene = dark_scene([plane], {"direction": [math.sin(t), 0.0, math.cos(t)], "intensity": e},
                       model, size=(32, 24))
    rad = renderer.render(scene).radiance
    assert np.all(rad[..., 3] == 1.0)
    # measured: 1.2e-7 relative
    np.testing.assert_allclose(rad[..., :3], e * math.cos(t) / math.pi, rtol=1e-5, atol=1e-7)


def test_ggx_mc_and_split_sum_share_the_light_term(renderer):
    """In the dark the environment adds nothing, so ggx_mc (any samples) equals ggx_split_sum:
    both evaluate the same GGX + Lambert BRDF with the same energy split for the light."""
    objects = [ObjectSpec("sphere", center=(-0.6, 0.0, 0.0), radius=0.55,
                          material=Material(albedo=(0.9, 0.6, 0.3), roughness=0.3, metallic=1.0)),
               ObjectSpec("sphere", center=(0.6, 0.0, 0.0), radius=0.55,
                          material=Material(albedo=(0.2, 0.5, 0.8), roughness=0.1, specular=1.0))]
    light = {"direction": [0.2, 0.5, 1.0], "color": [1.0, 0.9, 0.8], "intensity": 5.0}
    for multiscatter in (True, False):
        split = dark_scene(objects, light, "ggx_split_sum").with_render(multiscatter=multiscatter)
        a = renderer.render(split).radiance
        b = renderer.render(split.with_render(model="ggx_mc", samples=3)).radiance
        assert a[..., :3].max() > 1.0  # highlights are in the picture
        np.testing.assert_allclose(b, a, rtol=1e-6, atol=1e-7)  # measured: identical


def test_environment_rotation_does_not_turn_the_light(renderer):
    sphere = ObjectSpec("sphere", material=Material(albedo=(0.5, 0.5, 0.5), roughness=0.3))
    scene = dark_scene([sphere], {"direction": [1.0, 0.2, 0.3], "intensity": 4.0})
    a = renderer.render(scene).radiance
    b = renderer.render(scene.with_environment(rotation_deg=90.0)).radiance
    assert a[..., :3].max() > 0.1
    np.testing.assert_array_equal(a, b)


@pytest.mark.parametrize("model", LIT_MODELS)
def test_light_adds_to_the_environment_and_scales_linearly(renderer, model):
    sphere = ObjectSpec("sphere", material=Material(albedo=(0.6, 0.4, 0.2), roughness=0.4))
    # the sky's sun keeps one map size with or without the light (shadow_budget 0: under the
    # budget, a light joining it would share its texels, tests/viewer/test_shadow_budget.py)
    base = dark_scene([sphere], None, model).with_environment(intensity=1.0).with_render(
        shadow_budget=0)
    light = {"direction": [0.3, 0.8, 0.6], "color": [1.0, 0.5, 0.25]}
    none = renderer.render(base).radiance[..., :3]
    one = renderer.render(dataclasses.replace(
        base, lights=scene_from_dict({"light": {**light, "intensity": 1.0}}).lights)).radiance
    three = renderer.render(dataclasses.replace(
        base, lights=scene_from_dict({"light": {**light, "intensity": 3.0}}).lights)).radiance
    term = one[..., :3] - none
    assert term.max() > 0.05 and term.min() >= -1e-6
    np.testing.assert_allclose(three[..., :3] - none, 3.0 * term, rtol=1e-4, atol=2e-6)


def test_scenes_without_a_light_compile_it_out(renderer):
    from viewer.passes.shade import shade_defines

    settings = scene_from_dict({}).render
    light = DirectionalLight(direction=(0.0, 1.0, 0.0))
    for model in LIT_MODELS:
        assert shade_defines(model, settings)["LIGHT_COUNT"] == 0
        assert shade_defines(model, settings, light)["LIGHT_COUNT"] == 1
        assert shade_defines(model, settings, light)["LIGHT_POSITIONAL"] == 0
    assert shade_defines("neural", settings, light)["LIGHT_COUNT"] == 1  # through its base
    for model in ("unlit", "neural_teacher"):
        assert "LIGHT_COUNT" not in shade_defines(model, settings, light)


def test_unlit_ignores_the_light(renderer):
    sphere = ObjectSpec("sphere", material=Material(albedo=(0.6, 0.4, 0.2)))
    scene = dark_scene([sphere], {"direction": [0.0, 0.0, 1.0], "intensity": 9.0}, "unlit")
    np.testing.assert_array_equal(renderer.render(scene).radiance,
                                  renderer.render(dataclasses.replace(scene, lights=())).radiance)


def test_neural_teacher_warns_that_it_ignores_the_light(renderer):
    from viewer import renderer as renderer_module

    sphere = ObjectSpec("sphere", material=Material(albedo=(0.6, 0.4, 0.2)))
    scene = dark_scene([sphere], {"direction": [0.0, 0.0, 1.0], "intensity": 9.0},
                       "neural_teacher", size=(16, 16)).with_environment(intensity=1.0) \
        .with_render(samples=1)
    renderer_module._LIGHT_WARNED.discard("neural_teacher")
    with pytest.warns(UserWarning, match="ignores the scene's lights"):
        lit = renderer.render(scene).radiance
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # once per model: no second warning
        renderer.render(scene)
    np.testing.assert_array_equal(lit, renderer.render(
        dataclasses.replace(scene, lights=())).radiance)


@pytest.mark.parametrize("model", ["ggx_split_sum", "blinn_phong"])
def test_specialised_diffuse_scene_with_a_light_equals_the_general_path(renderer, model):
    """SPECULAR_LOBE 0 also drops the light's specular lobe, which is exactly 0 when f0 = 0."""
    objects = [ObjectSpec("sphere", material=lambertian((0.7, 0.5, 0.3))),
               ObjectSpec("plane", center=(0.0, -1.0, 0.0), material=lambertian())]
    scene = dark_scene(objects, {"direction": [0.4, 0.8, 0.5], "intensity": 3.0}, model) \
        .with_environment(intensity=1.0)
    assert renderer.specialization(scene).defines["SPECULAR_LOBE"] == 0
    a = renderer.render(scene.with_render(specialize=False)).radiance
    b = renderer.render(scene).radiance
    np.testing.assert_allclose(b, a, atol=1e-6, rtol=1e-6)  # measured: identical


def test_scene_type_keeps_the_light_optional():
    assert Scene().light is None


# ---- viewer state --------------------------------------------------------------------------------

def test_viewer_state_carries_the_light():
    from relight.app.state import (
        DEFAULT_LIGHT,
        light_angles,
        light_direction,
        load_into,
        scene_from_state,
        state_from_scene,
        with_light_angles,
    )

    scene = scene_from_dict({"light": {"direction": [0.0, 1.0, 1.0], "intensity": 2.0}})
    state = state_from_scene(scene)
    assert (state.light,) == scene.lights and scene_from_state(state) == scene
    state.light = None
    assert scene_from_state(state).light is None
    assert load_into(state, scene).light == scene.lights[0]  # a loaded scene brings its light
    moved = with_light_angles(state, 90.0, 0.0).light  # off: starts from the default light
    assert moved.intensity == DEFAULT_LIGHT.intensity
    np.testing.assert_allclose(moved.direction, (1.0, 0.0, 0.0), atol=1e-15)  # azimuth 90 = +X
    np.testing.assert_allclose(light_direction(0.0, 0.0), (0.0, 0.0, -1.0), atol=1e-15)
    for az, el in [(0.0, 10.0), (135.0, 45.0), (-170.0, -30.0), (90.0, 89.0)]:
        d = light_direction(az, el)
        assert math.isclose(math.hypot(*d), 1.0, rel_tol=1e-15)
        np.testing.assert_allclose(light_angles(d), (az, el), atol=1e-9)
