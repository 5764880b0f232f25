"""The viewer's "shadow caster only" switch, offscreen: a sphere's entry under Material has the
checkbox; ticking it leaves the sphere out of the image while its shadow stays on the floor
(the floor's darkest part keeps its darkness, where the sphere stood the floor shows), and the
saved scene says ``shadow_only``; unticking brings the sphere back. A shadow-catcher floor has no
such switch (a catcher is what the camera sees)."""
import numpy as np
import pytest
from viewer_helpers import click, release, scene_image

pytestmark = pytest.mark.gui
imgui_bundle = pytest.importorskip("imgui_bundle", reason="the viewer needs imgui-bundle ([gui])")


def _click(v, key):
    x0, y0, _, y1 = v.ui.rects[key]
    click(v, x0 + 5, (y0 + y1) / 2)
    release(v)


def test_the_switch_hides_the_sphere_and_keeps_its_shadow(tmp_path):
    from relight.app.window import Viewer
    from viewer.scene.description import load_scene, scene_from_dict
    from viewer.scene.files import save_scene

    scene = scene_from_dict({
        "camera": {"position": [0, 6, 0], "target": [0, 0, 0], "up": [0, 0, -1], "fov_y": 60,
                   "size": [64, 64]},
        "environment": {"procedural": "white", "width": 32, "intensity": 0.0},
        "lights": [{"type": "directional", "direction": [1.0, 1.0, 0.0], "intensity": 3.0}],
        "objects": [{"type": "plane", "center": [0, 0, 0], "size": [10, 10],
                     "material": {"albedo": [0.5, 0.5, 0.5], "roughness": 0.9}},
                    {"type": "sphere", "center": [0, 1, 0], "radius": 0.5,
                     "material": {"albedo": [0.9, 0.1, 0.1], "roughness": 0.5}},
                    {"type": "plane", "center": [0, -1, 0], "size": [1, 1], "catcher": True}],
        "render": {"raytrace": False, "tonemap": "none"}})
    with Viewer(scene, window_size=(480, 1000), offscreen=True) as v:  # the panel fits
        v.ui.open_all, v.state.show_overlay = True, False
        v.run(frames=2)
        assert "shadow caster only##so1" in v.ui.rects
        assert "shadow caster only##so2" not in v.ui.rects  # the catcher

        seen = scene_image(v)
        red = seen[..., 0] > 2.0 * seen[..., 1] + 0.02  # the sphere's pixels
        assert red.sum() > 0.01 * 480 * 900  # the bound it had in the 900 px window, in pixels
        _click(v, "shadow caster only##so1")
        assert v.state.scene.objects[1].shadow_only
        cast = scene_image(v)
        assert not (cast[..., 0] > 2.0 * cast[..., 1] + 0.02).any()  # no red left
        floor = ~red
        lit = np.percentile(seen[floor][:, 1], 90)
        # the shadow: floor pixels under a quarter of the lit floor, in both images alike
        assert (seen[floor][:, 1] < 0.25 * lit).sum() > 20
        np.testing.assert_array_equal(cast[floor][:, 1] < 0.25 * lit,
                                      seen[floor][:, 1] < 0.25 * lit)
        path = tmp_path / "s.toml"
        save_scene(v.state.scene, path)
        assert load_scene(path).objects[1].shadow_only
        _click(v, "shadow caster only##so1")
        assert not v.state.scene.objects[1].shadow_only
        np.testing.assert_allclose(scene_image(v), seen, atol=1e-6)
