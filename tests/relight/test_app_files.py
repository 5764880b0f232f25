"""The viewer window, offscreen: dropped, opened and saved files (bad input keeps the previous
state and image, a saved scene renders what the window shows, loader warnings reach the message
line) and ``relight view``'s screenshot."""
import numpy as np
import pytest
from viewer_helpers import headless, shown

from viewer.scene.description import load_scene
from viewer.scene.material import Material

pytestmark = pytest.mark.gui
imgui_bundle = pytest.importorskip("imgui_bundle", reason="the viewer needs imgui-bundle ([gui])")


def test_bad_input_keeps_the_previous_state_and_image(fresh, tmp_path):
    good, image, renders = fresh.state.copy(), shown(fresh), fresh.renders
    corrupt = tmp_path / "broken.exr"
    corrupt.write_bytes(b"not an exr at all")
    fresh.drop([str(corrupt)])
    after = shown(fresh, frames=2)
    assert "broken.exr" in fresh.state.message and "\n" not in fresh.state.message
    assert fresh.state.environment == good.environment
    assert np.array_equal(after, image) and fresh.renders == renders

    fresh.drop([str(tmp_path / "notes.txt")])
    assert "unsupported file type" in fresh.state.message

    bad_scene = tmp_path / "bad.toml"
    bad_scene.write_text("[render]\nexposure = 'bright'\n")
    fresh.drop([str(bad_scene)])
    assert "bad.toml" in fresh.state.message and fresh.state.scene == good.scene

    # a model the graph cannot run (as a neural model without weights): message, old model kept
    fresh.state.render = fresh.state.render.with_flat(model="no_such_model")
    assert np.array_equal(shown(fresh), image)
    assert fresh.state.render.model == good.render.model and "no_such_model" in fresh.state.message


def test_saved_scene_renders_what_the_window_shows(fresh, ctx, tmp_path):
    fresh.state.object_materials = (Material(albedo=(0.2, 0.5, 0.8), roughness=0.35),)
    fresh.state.render = fresh.state.render.with_flat(tonemap="aces", exposure=0.5)
    fb = shown(fresh)
    assert fresh.save_scene(str(tmp_path / "saved.toml"))
    frame = headless(ctx, load_scene(tmp_path / "saved.toml"))
    assert np.array_equal(fb[..., :3], frame.display[..., :3])
    fresh.screenshot(tmp_path / "shot.png")
    from viewer.imageio import read_image

    png, _ = read_image(tmp_path / "shot.png")
    assert np.array_equal(np.round(png * 255).astype(np.uint8), frame.display[..., :3])


def test_dropped_scene_and_environment_files_load(fresh, tmp_path):
    from viewer.imageio import write_exr

    env = np.full((32, 64, 3), 0.5, np.float32)
    write_exr(tmp_path / "grey.exr", env, ["R", "G", "B"])
    fresh.drop([str(tmp_path / "grey.exr")])
    fresh.run(frames=1)
    assert fresh.state.message is None
    assert fresh.current_scene().environment.path == str((tmp_path / "grey.exr").resolve())
    (tmp_path / "s.toml").write_text(
        '[camera]\nsize = [64, 48]\n[[objects]]\ntype = "plane"\n[render]\nmodel = "unlit"\n')
    fresh.drop([str(tmp_path / "s.toml")])
    fresh.run(frames=1)
    assert fresh.current_scene().render.model == "unlit"
    assert fresh.targets.display.size == (64, 48)


def test_cli_view_offscreen_screenshot(tmp_path, ctx):
    from relight.cli import main

    out = tmp_path / "view.png"
    # without rays: the viewer adds one frame of them per frame, a headless render eight
    assert main(["view", "--offscreen", "--frames", "2", "--size", "64x40",
                 "--set", "raytrace=false", "--screenshot", str(out), "-q"]) == 0
    from assets import ASSET_ROOT
    from viewer.imageio import read_image

    png, _ = read_image(out)
    truth = headless(ctx, load_scene(ASSET_ROOT / "scenes" / "demo.toml").with_render(
        raytrace=False), size=(64, 40))
    assert np.array_equal(np.round(png * 255).astype(np.uint8), truth.display[..., :3])
    assert main(["view", "--offscreen", "--screenshot", str(tmp_path / "x.jpg")]) == 2
    assert main(["view", "--offscreen", "--screenshot", str(tmp_path / "x.exr"),
                 "--screenshot-ui"]) == 2  # the window with its panel is a .png


def test_cli_view_help_lists_models_and_views(capsys):
    from relight.app.state import VIEWS
    from relight.cli import main
    from viewer.models import MODELS

    with pytest.raises(SystemExit):
        main(["view", "--help"])
    text = " ".join(capsys.readouterr().out.split())
    assert ", ".join(MODELS) in text and ", ".join(VIEWS) in text
    with pytest.raises(SystemExit) as exit_:
        main(["view", "--offscreen", "--model", "no_such_model"])
    assert exit_.value.code == 2 and "invalid choice" in capsys.readouterr().err


def _gltf_with_transmission(path):
    """A one-triangle glTF whose material uses KHR_materials_diffuse_transmission (not
    implemented: the loader names it in a warning)."""
    import base64
    import json

    data = np.float32([[-1, -1, 0], [1, -1, 0], [0, 1, 0]]).tobytes()
    path.write_text(json.dumps({
        "asset": {"version": "2.0"}, "extensionsUsed": ["KHR_materials_diffuse_transmission"],
        "buffers": [{"byteLength": len(data), "uri": "data:application/octet-stream;base64,"
                     + base64.b64encode(data).decode()}],
        "bufferViews": [{"buffer": 0, "byteLength": len(data)}],
        "accessors": [{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3",
                       "min": [-1, -1, 0], "max": [1, 1, 0]}],
        "materials": [{"doubleSided": True,
                       "extensions": {"KHR_materials_diffuse_transmission": {}}}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "material": 0}]}],
        "nodes": [{"mesh": 0}], "scenes": [{"nodes": [0]}], "scene": 0}))


def test_loader_warnings_reach_stderr_and_the_message_line(fresh, tmp_path, capsys):
    _gltf_with_transmission(tmp_path / "coat.gltf")
    (tmp_path / "coat.toml").write_text('[camera]\nsize = [96, 96]\n[[objects]]\ntype = "mesh"\n'
                                        'path = "coat.gltf"\n')
    renders = fresh.renders
    capsys.readouterr()
    assert fresh.open_scene(str(tmp_path / "coat.toml"))
    fresh.state.show_ui = True  # the message line is drawn in the panel
    fresh.run(frames=2)
    assert fresh.renders == renders + 1  # a warning does not stop the render
    message = fresh.state.message
    assert message.startswith("warning: ") and "\n" not in message
    named = "KHR_materials_diffuse_transmission (changes the BSDF"
    assert "coat.gltf" in message and named in message
    err = capsys.readouterr().err
    assert err.count(named) == 1 and "UserWarning" in err
    # the geometry is cached: later frames and edits neither warn again nor clear the message
    fresh.state.render = fresh.state.render.with_flat(exposure=0.5)
    fresh.run(frames=1)
    assert fresh.renders == renders + 2 and fresh.state.message == message
    assert "KHR_materials_diffuse_transmission" not in capsys.readouterr().err


def test_files_dropped_through_glfw_open_and_a_bad_one_keeps_the_scene(fresh, tmp_path):
    """The drop callback registered with glfw: a scene opens, an environment replaces the
    environment, a corrupt file or an asset this build cannot open says so in one line and the
    scene on screen stays."""
    from viewer_helpers import drop_files

    from viewer.imageio import write_exr

    (tmp_path / "s.toml").write_text(
        '[camera]\nsize = [64, 48]\n[[objects]]\ntype = "sphere"\n[render]\nmodel = "unlit"\n')
    drop_files(fresh, [tmp_path / "s.toml"])
    assert fresh.state.message is None and fresh.current_scene().render.model == "unlit"
    write_exr(tmp_path / "sky.exr", np.full((16, 32, 3), 0.25, np.float32), ["R", "G", "B"])
    drop_files(fresh, [tmp_path / "sky.exr"])
    assert fresh.current_scene().environment.path == str((tmp_path / "sky.exr").resolve())
    good, image, renders = fresh.current_scene(), shown(fresh), fresh.renders

    (tmp_path / "bad.hdr").write_bytes(b"#?RADIANCE\nthis is not a picture")
    fresh.state.show_overlay = True  # the panel is hidden: the overlay shows the message
    drop_files(fresh, [tmp_path / "bad.hdr"])
    message = fresh.state.message
    assert "bad.hdr" in message and "\n" not in message
    fresh.run(frames=1)
    assert fresh.ui.overlay_lines[-1] == message
    fresh.state.show_overlay = False
    assert fresh.current_scene() == good and fresh.renders == renders
    assert np.array_equal(shown(fresh), image)


def test_a_dropped_asset_opens_framed_in_the_current_environment(fresh, tmp_path):
    """Assets go to ``viewer.scene.assets.scene_from_assets`` at the current render size, lit by the
    current environment; a corrupt one gives one line and keeps the scene."""
    import sys
    from pathlib import Path

    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "viewer"))
    from asset_files import box_gltf
    from viewer_helpers import drop_files

    good = fresh.current_scene()
    bad = tmp_path / "chair.glb"
    bad.write_bytes(b"glTF not really")
    drop_files(fresh, [bad])
    message = fresh.state.message
    assert message and "chair.glb" in message and "\n" not in message
    assert fresh.current_scene() == good

    box = tmp_path / "box.gltf"
    box_gltf(box)
    drop_files(fresh, [box])
    scene = fresh.current_scene()
    assert fresh.state.message is None, fresh.state.message
    assert [o.type for o in scene.objects] == ["mesh"]
    assert scene.camera.size == good.camera.size
    assert scene.environment == good.environment  # lit as before the drop
