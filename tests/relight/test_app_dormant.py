"""The viewer's Shading section greys the knobs of what the frame does not run (the same
``viewer.scene.settings.dormant_keys`` the renderer's warnings read), keeps them editable, and
ungreys them when their part runs: the rays' knobs with ``raytrace = false``, SSAO's while no
SSAO pass runs."""
import pytest

pytestmark = pytest.mark.gui
imgui_bundle = pytest.importorskip("imgui_bundle", reason="the viewer needs imgui-bundle ([gui])")


def test_the_panel_greys_the_knobs_of_what_the_frame_does_not_run():
    from relight.app.window import Viewer
    from viewer.scene.description import scene_from_dict

    scene = scene_from_dict({
        "camera": {"position": [0, 2, 4], "target": [0, 0.5, 0], "size": [48, 32]},
        "environment": {"procedural": "sky", "width": 32},
        "objects": [{"type": "plane", "center": [0, 0, 0], "size": [6, 6]},
                    {"type": "sphere", "center": [0, 0.5, 0], "radius": 0.5}],
        "render": {"raytrace": False}})
    with Viewer(scene, window_size=(480, 1000), offscreen=True) as v:
        v.ui.open_all, v.state.show_overlay = True, False
        v.run(frames=2)
        greyed = v.ui.dormant
        assert {"ray_scale", "raytrace_rays", "ssao_rays", "samples", "max_depth"} <= set(greyed)
        assert "ray-traced tier" in greyed["ray_scale"]
        assert "ray_scale" in v.ui.rects  # still a widget: it can be set before its switch
        assert not {"model", "raytrace", "ssao", "exposure"} & set(greyed)  # switches never
        v.state.render = v.state.render.with_flat(raytrace=True)
        v.run(frames=2)
        assert "ray_scale" not in v.ui.dormant and "ssao_rays" in v.ui.dormant
        v.state.render = v.state.render.with_flat(raytrace=False, ssao=True)
        v.run(frames=2)
        assert "ssao_rays" not in v.ui.dormant and "ray_scale" in v.ui.dormant
