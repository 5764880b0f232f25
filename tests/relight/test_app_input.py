"""The viewer window, offscreen: simulated mouse input on the real ImGui widgets (the exposure
slider, the Light panel) and on the image (orbiting), through the glfw backend's callbacks."""
import numpy as np
import pytest

from viewer_helpers import click, drag_to, release, shown, sphere_scene, to_linear

pytestmark = pytest.mark.gui
imgui_bundle = pytest.importorskip("imgui_bundle", reason="the viewer needs imgui-bundle ([gui])")


def test_mouse_on_the_exposure_slider_changes_the_image():
    from relight.app.window import Viewer

    with Viewer(sphere_scene(), window_size=(480, 240), offscreen=True) as v:
        v.run(frames=2)  # lay out the panel
        x0, y0, x1, y1 = v.ui.rects["exposure"]
        y = (y0 + y1) / 2
        click(v, x0 + 2, y)
        low = v.state.render.display.exposure
        assert low < -9.0  # the slider's left end is its minimum, -10 EV
        drag_to(v, x1 - 3, y)
        high = v.state.render.display.exposure
        release(v)
        assert high > low + 2.0 and v.state.render.display.exposure == high
        v.state.show_ui = False
        bright = to_linear(shown(v)).mean()
        v.state.render = v.state.render.with_flat(exposure=low)
        dark = to_linear(shown(v)).mean()
        assert bright > 4 * dark


def test_dragging_on_the_image_orbits_the_camera(fresh):
    before_cam, before = fresh.state.camera, shown(fresh)
    click(fresh, 48, 48)
    drag_to(fresh, 78, 40)
    release(fresh)
    cam = fresh.state.camera
    assert cam.target == before_cam.target and cam.position != before_cam.position
    d0 = np.linalg.norm(np.subtract(before_cam.position, before_cam.target))
    assert np.linalg.norm(np.subtract(cam.position, cam.target)) == pytest.approx(d0)
    assert cam.position[0] < before_cam.position[0]  # dragged right: the camera went left
    assert not np.array_equal(shown(fresh), before)


def test_light_panel_switches_moves_and_keeps_the_light():
    """The Light panel's widgets, clicked through the glfw backend: the checkbox switches the
    light on (and off, and back to what it was), the elevation slider moves it, and frames with
    the panel open never rewrite it (float32 widget values are written only on an edit)."""
    from relight.app.window import Viewer

    tall = Viewer(sphere_scene(), window_size=(480, 400), offscreen=True)
    try:
        tall.run(frames=2)
        x0, y0, x1, y1 = tall.ui.rects["Light"]
        click(tall, x0 + 10, (y0 + y1) / 2)
        release(tall)
        x0, y0, x1, y1 = tall.ui.rects["directional light"]
        click(tall, x0 + 5, (y0 + y1) / 2)
        release(tall)
        light = tall.state.light
        assert light is not None and tall.current_scene().lights == (light,)
        renders = tall.renders
        tall.run(frames=3)
        assert tall.state.light is light and tall.renders == renders
        x0, y0, x1, y1 = tall.ui.rects["elevation"]
        click(tall, x0 + 2, (y0 + y1) / 2)  # the slider's left end: -90 degrees
        release(tall)
        assert tall.state.light.direction[1] < -0.99
        assert tall.state.light.intensity == light.intensity
        moved = tall.state.light
        x0, y0, x1, y1 = tall.ui.rects["directional light"]
        click(tall, x0 + 5, (y0 + y1) / 2)
        release(tall)
        assert tall.state.light is None and tall.current_scene().light is None  # no lights
        click(tall, x0 + 5, (y0 + y1) / 2)
        release(tall)
        assert tall.state.light == moved
    finally:
        tall.close()
