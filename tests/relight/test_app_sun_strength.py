"""The viewer's "sun strength" slider, offscreen: pressing it at its left end and dragging does
not rebuild the environment (the scene keeps its sun while the button is down); letting go sets
``sun_strength`` near 0, the image loses the sun's light, and the saved scene (what "save scene" writes) says so."""
import pytest
from viewer_helpers import click, release, scene_image

pytestmark = pytest.mark.gui
imgui_bundle = pytest.importorskip("imgui_bundle", reason="the viewer needs imgui-bundle ([gui])")


def test_the_slider_applies_when_let_go(tmp_path):
    from relight.app.window import Viewer
    from viewer.scene.description import load_scene, scene_from_dict

    scene = scene_from_dict({
        "camera": {"position": [0, 2.0, 4.0], "target": [0, 0.3, 0], "fov_y": 40,
                   "size": [64, 48]},
        "environment": {"procedural": "sky", "width": 128, "sun_radiance": 2e4},
        "objects": [{"type": "sphere", "center": [0, 0.5, 0], "radius": 0.5,
                     "material": {"albedo": [0.8, 0.8, 0.8], "roughness": 0.5}},
                    {"type": "plane", "center": [0, 0, 0], "size": [8, 8],
                     "material": {"albedo": [0.5, 0.5, 0.5], "roughness": 0.9}}],
        "render": {"raytrace": False, "tonemap": "none"}})
    with Viewer(scene, window_size=(480, 900), offscreen=True) as v:
        v.ui.open_all, v.state.show_overlay = True, False
        v.run(frames=2)

        lit = scene_image(v)
        x0, y0, x1, y1 = v.ui.rects["sun strength"]
        click(v, x0 + 2, (y0 + y1) / 2)  # pressed, not yet released
        assert v.state.environment.sun_strength == 1.0
        release(v)
        assert v.state.environment.sun_strength < 0.1
        dark = scene_image(v)
        assert dark.sum() < 0.8 * lit.sum()
        assert v.save_scene(str(tmp_path / "s.toml"))
        path = tmp_path / "s.toml"
        assert load_scene(path).environment.sun_strength < 0.1
