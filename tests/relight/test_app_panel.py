"""The viewer's panel at 640x480, offscreen (and on a real X server under Xvfb when there is one):
docked beside the image, every section opens without moving the image, no label is cut, the
user resizes it by its edge and hides it with a key, and a screenshot can include it."""
import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from viewer_helpers import click, drag_to, release, sphere_scene

from viewer.scene.description import scene_from_dict

pytestmark = pytest.mark.gui
imgui_bundle = pytest.importorskip("imgui_bundle", reason="the viewer needs imgui-bundle ([gui])")

WINDOW = (640, 480)
ROOT = Path(__file__).resolve().parents[2]


def lit_scene():
    """The test sphere with a key light and a point and a spot light: every Light widget shows."""
    scene = sphere_scene()
    lights = scene_from_dict({
        "objects": [{"type": "sphere"}],
        "lights": [{"type": "directional", "direction": [0.3, 1, 0.2], "intensity": 2.0},
                   {"type": "point", "position": [1, 1, 1], "intensity": 5.0},
                   {"type": "spot", "position": [0, 2, 0], "direction": [0, 1, 0],
                    "intensity": 5.0}]}).lights
    from dataclasses import replace

    return replace(scene, lights=lights)


@pytest.fixture(scope="module")
def window():
    from relight.app.window import Viewer
    from viewer.errors import GLContextError

    try:
        v = Viewer(lit_scene(), window_size=WINDOW, offscreen=True)
    except GLContextError as exc:  # pragma: no cover - only where glfw has no Null/EGL platform
        pytest.skip(f"no offscreen window: {exc}")
    yield v
    v.close()


@pytest.fixture
def panel(window):
    from relight.app.panels import PANEL_FRACTION
    from relight.app.state import state_from_scene

    window.state = state_from_scene(lit_scene())
    window.ui.fraction, window.ui.open_all = PANEL_FRACTION, False
    window.run(frames=2)
    return window


def cut_labels(ui) -> list:
    """Items that pass the panel's edge (a cut label) or are narrower than their own label."""
    bad = []
    for it in ui.items:
        edge = ui.edge if it.kind == "header" else ui.right
        if it.rect[2] > edge + 0.5 or it.rect[2] - it.rect[0] < it.text_width:
            bad.append((it.label, it.rect, it.text_width, edge))
    return bad


def test_every_section_opens_beside_the_image_and_no_label_is_cut(panel):
    from relight.app.panels import SECTIONS

    ui = panel.ui
    assert ui.width == pytest.approx(240.0)  # 30% of 640 is under the 240-pixel minimum
    area, shown_at = panel.view_area(), panel._view_rect()
    assert area == (240, 0, 400, 480) and shown_at[0] >= 240  # the image is beside the panel
    assert cut_labels(ui) == []
    ui.open_all = True
    panel.run(frames=3)
    labels = {it.label for it in ui.items}
    # one widget of each section, and of the other lights: every section is open
    assert {"field of view", "environment", "light intensity", "colour", "position",
            "direction", "albedo", "samples", "view", "screenshot"} <= labels
    assert all(title in ui.rects for title in SECTIONS)
    assert cut_labels(ui) == []
    # the sections open below each other and the panel scrolls within itself: the image stays
    assert ui.rects["Output"][1] > WINDOW[1] and ui.width == pytest.approx(240.0)
    assert panel.view_area() == area and panel._view_rect() == shown_at


def test_in_a_small_window_labels_wrap_instead_of_being_cut():
    """At 320x240 the panel is half the window (160 pixels): labels go on their own lines,
    checkbox and button text wraps, and still no item passes the panel's edge."""
    from relight.app.window import Viewer

    with Viewer(lit_scene(), window_size=(320, 240), offscreen=True) as v:
        v.ui.open_all = True
        v.run(frames=3)
        assert v.ui.width == pytest.approx(160.0) and v.view_area() == (160, 0, 160, 240)
        assert cut_labels(v.ui) == []
        kinds = {it.kind for it in v.ui.items if it.label}
        assert "label" in kinds  # some labels moved to their own line


def test_the_default_window_shows_the_render_one_to_one_beside_the_panel():
    from relight.app.panels import PANEL_FRACTION, panel_limits, window_width_for

    def area(width):
        lo, hi = panel_limits(width)
        return width - max(lo, min(hi, PANEL_FRACTION * width))

    assert window_width_for(400) == 640  # a 240-pixel panel
    for view in (1, 64, 240, 400, 640, 1280):
        width = window_width_for(view)
        assert area(width) >= view > area(width - 1)


def test_labels_would_be_cut_at_imgui_default_widths(panel, monkeypatch):
    """The check above can fail: with ImGui's default item width (65% of the panel) the longer
    labels pass the panel's edge."""
    from relight.app.panels import layout

    def default_width(self, label):
        self._fitted.pop(label, None)
        return label

    monkeypatch.setattr(layout.Layout, "fit", default_width)
    panel.ui.open_all = True
    panel.run(frames=2)
    assert "light intensity" in {bad[0] for bad in cut_labels(panel.ui)}


def press_key(viewer, key):
    from imgui_bundle import imgui

    imgui.backends.glfw_key_callback(viewer.window.address, key, 0, 1, 0)  # GLFW_PRESS
    viewer.run(frames=1)
    imgui.backends.glfw_key_callback(viewer.window.address, key, 0, 0, 0)  # GLFW_RELEASE
    viewer.run(frames=1)


def test_f1_hides_the_panel_and_the_image_takes_the_window(panel):
    import glfw

    press_key(panel, glfw.KEY_F1)
    assert not panel.state.show_ui and panel.view_area() == (0, 0, *WINDOW)
    press_key(panel, glfw.KEY_H)
    assert panel.state.show_ui and panel.view_area()[0] == 240


def test_dragging_the_panel_edge_resizes_it_and_the_image_follows(panel):
    click(panel, panel.ui.width - 1, 300)  # on the panel's right border, below the widgets
    drag_to(panel, 300, 300, frames=3)
    release(panel)
    assert panel.ui.width == pytest.approx(301.0, abs=2.0)
    assert panel.ui.fraction == pytest.approx(panel.ui.width / WINDOW[0])
    assert panel.view_area()[0] == round(panel.ui.width)
    click(panel, panel.ui.width - 1, 300)
    drag_to(panel, 600, 300, frames=3)  # past the limit: half the window
    release(panel)
    assert panel.ui.width == pytest.approx(WINDOW[0] / 2)
    assert cut_labels(panel.ui) == []


def test_screenshot_with_the_ui_is_the_render_beside_the_panel(panel, tmp_path):
    from viewer.imageio import read_image

    panel.state.fit_view = True  # the render size follows the area beside the panel
    panel.state.show_overlay = False  # the overlay would cover part of the image
    panel.run(frames=2)
    assert panel.current_scene().camera.size == (400, 480)
    panel.screenshot(tmp_path / "ui.png", ui=True)
    panel.screenshot(tmp_path / "view.png")
    ui = np.round(read_image(tmp_path / "ui.png")[0] * 255).astype(np.uint8)
    view = np.round(read_image(tmp_path / "view.png")[0] * 255).astype(np.uint8)
    assert ui.shape == (480, 640, 3) and view.shape == (480, 400, 3)
    assert np.array_equal(ui[:, 240:], view)  # the image area is the render, pixel for pixel
    differs = np.any(ui[:, :240] != view[:, :240], axis=-1)
    assert differs.mean() > 0.5  # the panel's pixels, not the render's


def test_panel_screenshot_on_a_real_x_server(tmp_path):
    """``relight view --screenshot-ui`` in an on-screen window on Xvfb (skipped without it)."""
    if shutil.which("xvfb-run") is None:
        pytest.skip("xvfb-run is not installed (apt-get install xvfb)")
    scene = tmp_path / "s.toml"
    scene.write_text('[camera]\nposition = [0, 0, 3]\n[[objects]]\ntype = "sphere"\n'
                     '[render]\nmodel = "unlit"\n')
    out = tmp_path / "ui.png"
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    cmd = ["xvfb-run", "-a", "-s", "-screen 0 1024x768x24", sys.executable, "-m", "relight",
           "view", str(scene), "--window", "640x480", "--frames", "2", "--screenshot", str(out),
           "--screenshot-ui", "-q"]
    run = subprocess.run(cmd, capture_output=True, text=True, timeout=120, env=env, cwd=ROOT)
    if run.returncode != 0 and "cannot initialise glfw" in run.stderr:
        pytest.skip(f"no display under xvfb-run: {run.stderr.strip()}")
    assert run.returncode == 0, run.stderr
    from viewer.imageio import read_image

    shot = np.round(read_image(out)[0] * 255).astype(np.uint8)
    assert shot.shape == (480, 640, 3)
    # the panel's background (ImGui's dark window colour) fills the left edge below the widgets
    column = shot[300:470, 120]  # (the last row is the window border)
    assert np.all(column == column[0]) and column[0].max() < 64
    assert not np.array_equal(shot[:, :240], shot[:, 240:480])
