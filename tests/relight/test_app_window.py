"""The viewer window, offscreen (glfw Null platform + EGL): what it shows is what ``relight
render`` renders, and state changes (exposure, intensity, roughness, views, the light, progressive
accumulation) change the picture as they should. Mouse input: test_app_input.py; files:
test_app_files.py."""
import dataclasses

import numpy as np
import pytest
from viewer_helpers import SIZE, headless, shown, to_linear

from viewer.scene.description import load_scene
from viewer.scene.material import Material

pytestmark = pytest.mark.gui
imgui_bundle = pytest.importorskip("imgui_bundle", reason="the viewer needs imgui-bundle ([gui])")


def test_window_shows_exactly_the_headless_render(fresh, ctx):
    fb = shown(fresh)
    assert fb.shape == (SIZE[1], SIZE[0], 4)
    assert np.array_equal(fb[..., :3], headless(ctx, fresh.current_scene()).display[..., :3])


def test_doubling_exposure_doubles_linear_radiance_on_screen(fresh):
    # without FXAA, whose edge tests on perceptual luma see each exposure differently
    fresh.state.render = fresh.state.render.with_flat(aa="none")
    before = to_linear(shown(fresh))
    fresh.state.render = fresh.state.render.with_flat(exposure=0.0)  # +1 EV
    after = to_linear(shown(fresh))
    ok = (before > 0.05) & (before < 0.45)  # lit, and not clipped after doubling
    assert ok.sum() > 500
    ratio = after[ok] / before[ok]
    # 8-bit sRGB quantisation: at linear 0.05 one code is ~3.5% of the value
    assert np.median(ratio) == pytest.approx(2.0, abs=0.02)
    assert np.all(np.abs(ratio - 2.0) < 0.15)


def test_intensity_doubles_the_linear_screenshot(fresh, tmp_path):
    from viewer.imageio import read_image

    fresh.screenshot(tmp_path / "a.exr")
    env = fresh.state.environment
    fresh.state.environment = dataclasses.replace(env, intensity=2.0 * env.intensity)
    fresh.run(frames=1)
    fresh.screenshot(tmp_path / "b.exr")
    a, _ = read_image(tmp_path / "a.exr")
    b, _ = read_image(tmp_path / "b.exr")
    assert a.max() > 0.1
    np.testing.assert_allclose(b, 2.0 * a, rtol=1e-5, atol=1e-7)


def highlight_stats(viewer, roughness):
    viewer.state.object_materials = (Material(albedo=(0.6, 0.6, 0.6), roughness=roughness,
                                              specular=1.0),)
    viewer.state.view = "display"
    lum = to_linear(shown(viewer)) @ np.array([0.2126, 0.7152, 0.0722])
    viewer.state.view = "alpha"  # the G-buffer coverage channel, through the debug view
    on = shown(viewer)[..., 0] == 255
    inner = on & np.roll(on, 2, 0) & np.roll(on, -2, 0) & np.roll(on, 2, 1) & np.roll(on, -2, 1)
    grad = np.abs(np.diff(lum, axis=0))[:, :-1] + np.abs(np.diff(lum, axis=1))[:-1, :]
    return lum[on].max(), grad[inner[:-1, :-1]].mean()


def test_roughness_blurs_the_highlight(fresh):
    peak_smooth, edges_smooth = highlight_stats(fresh, 0.0)
    peak_rough, edges_rough = highlight_stats(fresh, 1.0)
    assert peak_smooth > 1.5 * peak_rough
    assert edges_smooth > 2.0 * edges_rough


def test_gbuffer_views_match_the_headless_aovs(fresh, ctx):
    truth = headless(ctx, fresh.current_scene(), aovs=("normal", "roughness")).aovs
    fresh.state.view = "normal"
    normal = shown(fresh)[..., :3] / 255.0
    np.testing.assert_allclose(normal, truth["normal"] * 0.5 + 0.5, atol=1.0 / 255 + 1e-6)
    fresh.state.view = "roughness"
    rough = shown(fresh)[..., :1] / 255.0
    np.testing.assert_allclose(rough, truth["roughness"], atol=1.0 / 255 + 1e-6)


def test_error_views_against_a_reference(fresh, tmp_path):
    fresh.screenshot(tmp_path / "ref.exr")
    assert fresh.load_reference(str(tmp_path / "ref.exr"))
    fresh.state.view = "difference"
    assert shown(fresh)[..., :3].max() == 0  # identical to the reference
    fresh.state.view = "error"
    same = shown(fresh)
    assert np.all(same == same[0, 0])  # one colour: zero error everywhere
    env = fresh.state.environment
    fresh.state.environment = dataclasses.replace(env, intensity=1.1 * env.intensity)
    fresh.state.error_scale = 0.2  # +10% error: half-way up the colour map
    assert not np.array_equal(shown(fresh), same)
    fresh.state.view = "difference"
    assert shown(fresh)[..., :3].max() > 0


def test_progressive_accumulation_restarts_on_change_and_idles_when_done(fresh):
    fresh.samples_per_frame = 4
    fresh.state.render = fresh.state.render.with_flat(model="ggx_mc", samples=8)
    counts = []
    for _ in range(3):
        fresh.run(frames=1)
        counts.append(fresh.targets.samples)
    assert counts == [4, 8, 8]
    renders = fresh.renders
    fresh.run(frames=2)
    assert fresh.renders == renders  # converged and unchanged: the graph does not run
    env = fresh.state.environment
    fresh.state.environment = dataclasses.replace(env, rotation_deg=env.rotation_deg + 10.0)
    fresh.run(frames=1)
    assert fresh.targets.samples == 4  # any change restarts the running mean


def test_directional_light_through_the_state_adds_lambert_and_saves(fresh, ctx, tmp_path):
    """Turning the light on through the ViewerState adds exactly albedo E cos(theta) / pi to a
    white Lambertian sphere's linear radiance; the saved scene renders the same pixels."""
    from relight.app.state import light_direction
    from viewer.imageio import read_image
    from viewer.scene.description import DirectionalLight

    fresh.state.object_materials = (Material(albedo=(1.0, 1.0, 1.0), roughness=0.5,
                                             specular=0.0),)
    fresh.run(frames=1)
    fresh.screenshot(tmp_path / "off.exr")
    e, l_ws = 2.5, light_direction(140.0, 30.0)  # upper right, in front of the sphere
    fresh.state.light = DirectionalLight(direction=l_ws, intensity=e)
    fresh.run(frames=1)
    fresh.screenshot(tmp_path / "on.exr")
    off, _ = read_image(tmp_path / "off.exr")
    on, _ = read_image(tmp_path / "on.exr")
    truth = headless(ctx, fresh.current_scene(), aovs=("normal",))
    np.testing.assert_array_equal(truth.radiance[..., :3], on)  # the screenshot is the render
    normal = truth.aovs["normal"]
    normal = normal / np.maximum(np.linalg.norm(normal, axis=-1, keepdims=True), 1e-12)
    cos = normal @ np.asarray(l_ws)
    inside = truth.radiance[..., 3] == 1.0
    expected = e / np.pi * np.clip(cos, 0.0, None)
    assert (inside & (cos > 0.5)).sum() > 200 and (inside & (cos < -0.2)).sum() > 50
    # measured: max abs 1.8e-7 (float32 radiance of two renders)
    np.testing.assert_allclose((on - off)[..., :3][inside], np.repeat(
        expected[inside][:, None], 3, axis=1), atol=2e-5, rtol=1e-4)
    assert fresh.save_scene(str(tmp_path / "lit.toml"))
    saved = load_scene(tmp_path / "lit.toml")
    assert saved.lights == (fresh.state.light,)
    np.testing.assert_array_equal(headless(ctx, saved).radiance[..., :3], on)
    fresh.state.light = None
    fresh.run(frames=1)
    fresh.screenshot(tmp_path / "off2.exr")
    np.testing.assert_array_equal(read_image(tmp_path / "off2.exr")[0], off)
