"""The viewer's material-variant picker (KHR_materials_variants), offscreen: a glTF with
variants gets one radio button per name in its object's Material entry; clicking one re-renders
the object with that variant's materials, "as authored" brings the defaults back, and the saved
scene names the variant. A file without variants has no names, so no picker."""
import sys
from pathlib import Path

import numpy as np
import pytest
from viewer_helpers import click, release, shown, to_linear

pytestmark = pytest.mark.gui
imgui_bundle = pytest.importorskip("imgui_bundle", reason="the viewer needs imgui-bundle ([gui])")
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "viewer"))  # the glTF builders


def _click(v, key):
    x0, y0, _, y1 = v.ui.rects[key]
    click(v, x0 + 5, (y0 + y1) / 2)
    release(v)


def test_picking_a_variant_renders_its_materials(tmp_path):
    from test_gltf_variants import variants_file

    from relight.app.window import Viewer
    from viewer.geometry.loaders import material_variants
    from viewer.scene.description import scene_from_dict

    path = variants_file(tmp_path / "v.gltf")
    assert material_variants(path) == ("red", "blue", "shared")
    assert material_variants(tmp_path / "missing.gltf") == ()
    obj = tmp_path / "t.obj"  # other formats have no variants: no picker (_variant_picker)
    obj.write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
    assert material_variants(obj) == ()
    scene = scene_from_dict({"objects": [{"type": "mesh", "path": str(path)}],
                             "camera": {"size": [64, 64]},
                             "render": {"raytrace": False, "shadows": False}})
    with Viewer(scene, window_size=(480, 900), offscreen=True) as v:
        v.ui.open_all, v.state.show_overlay = True, False
        v.run(frames=2)
        assert "red##variant0" in v.ui.rects and "as authored##variant0" in v.ui.rects

        def colour():
            v.state.show_ui = False
            rgb = to_linear(shown(v))[..., :3]
            v.state.show_ui = True
            v.run(frames=2)
            sphere = np.abs(rgb - rgb[-1, 0]).sum(-1) > 0.01  # off the background's colour
            assert sphere.mean() > 0.05
            return rgb[sphere].mean(0)

        grey = colour()
        _click(v, "red##variant0")
        assert v.state.scene.objects[0].variant == "red"
        red = colour()
        # the sphere turned from grey (0.5) to red (0.8, 0.1, 0.1)
        assert abs(grey[0] - grey[2]) < 0.1 * grey[0] and red[0] > 3 * red[2]
        _click(v, "as authored##variant0")
        assert v.state.scene.objects[0].variant is None
        assert np.allclose(colour(), grey, atol=0.02)
        _click(v, "blue##variant0")
        assert v.current_scene().objects[0].variant == "blue"  # what "save scene" writes
        blue = colour()
        assert blue[2] > 3 * blue[0]

