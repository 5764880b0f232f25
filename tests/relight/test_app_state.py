"""Viewer state <-> scene, camera control math and scene saving (no window needed)."""
import dataclasses
import math

import numpy as np
import pytest

from relight.app import camera_control as cc
from relight.app.state import (
    MaterialOverride,
    reset_camera,
    scene_from_state,
    state_from_scene,
    with_environment_file,
)
from viewer.errors import SceneError
from viewer.renderer import Renderer
from viewer.scene.camera import Camera
from viewer.scene.description import load_scene, scene_from_dict
from viewer.scene.files import save_scene, scene_to_dict
from viewer.scene.material import Material


def demo():
    from assets import ASSET_ROOT

    return load_scene(ASSET_ROOT / "scenes" / "demo.toml")


def sphere_scene(**render):
    return scene_from_dict({
        "camera": {"position": [0, 0, 3], "fov_y": 40, "size": [48, 48]},
        "environment": {"procedural": "studio", "width": 64},
        "objects": [{"type": "sphere", "material": {"albedo": [0.7, 0.3, 0.2], "roughness": 0.4}},
                    {"type": "plane", "center": [0, -1, 0]}],
        "render": {"tonemap": "none", **render}})


def test_state_round_trip_is_exact():
    scene = demo()
    assert scene_from_state(state_from_scene(scene)) == scene


def test_material_override_applies_chosen_fields_on_top_of_edits():
    scene = sphere_scene()
    state = state_from_scene(scene)
    state.object_materials = (Material(albedo=(0.1, 0.2, 0.3), roughness=0.9),
                              state.object_materials[1])
    state.material_override = MaterialOverride(roughness=0.0, metallic=1.0)
    out = scene_from_state(state)
    assert out.objects[0].material == Material(albedo=(0.1, 0.2, 0.3), roughness=0.0, metallic=1.0)
    assert out.objects[1].material.roughness == 0.0
    assert out.objects[1].material.albedo == scene.objects[1].material.albedo
    assert scene.objects[0].material.roughness == 0.4  # the loaded scene is untouched


def test_environment_file_keeps_intensity_and_rotation(tmp_path):
    state = state_from_scene(sphere_scene())
    state.environment = dataclasses.replace(state.environment, intensity=2.5, rotation_deg=30.0)
    env = with_environment_file(state, str(tmp_path / "a.exr")).environment
    assert env.path == str(tmp_path / "a.exr") and env.procedural is None
    assert (env.intensity, env.rotation_deg) == (2.5, 30.0)


def test_reset_camera_keeps_render_size():
    state = state_from_scene(sphere_scene())
    state.camera = cc.orbit(state.camera, 40, 10).with_size(32, 20)
    assert reset_camera(state).camera == state.scene.camera.with_size(32, 20)


# ---- camera control ------------------------------------------------------------------------------

CAM = Camera(position=(0.0, 0.0, 3.0), target=(0.0, 0.0, 0.0), fov_y=40.0, size=(100, 100))


def dist(cam):
    return float(np.linalg.norm(np.subtract(cam.position, cam.target)))


def test_orbit_yaw_turns_counter_clockwise_about_up_and_keeps_distance():
    cam = cc.orbit(CAM, 90.0, 0.0)
    np.testing.assert_allclose(cam.position, (3.0, 0.0, 0.0), atol=1e-12)  # +Z -> +X
    assert cam.target == CAM.target
    cam = cc.orbit(CAM, 37.0, 21.0)
    assert dist(cam) == pytest.approx(3.0, rel=1e-12)


def test_orbit_pitch_rises_and_stops_before_the_pole():
    cam = cc.orbit(CAM, 0.0, 30.0)
    assert cam.position[1] == pytest.approx(3.0 * math.sin(math.radians(30.0)))
    top = cc.orbit(CAM, 0.0, 500.0)
    elevation = math.degrees(math.asin(top.position[1] / dist(top)))
    assert elevation == pytest.approx(cc.MAX_PITCH_DEG)
    top.basis()  # still a valid camera (up not parallel to the view direction)


def test_pan_moves_the_target_point_with_the_mouse():
    """After panning by (dx, dy) pixels, the old target projects dx right and dy down of centre."""
    dx, dy = 10.0, -6.0
    cam = cc.pan(CAM, dx, dy)
    np.testing.assert_allclose(np.subtract(cam.position, cam.target),
                               np.subtract(CAM.position, CAM.target), atol=1e-12)
    p = cam.projection_matrix() @ cam.view_matrix() @ np.array([*CAM.target, 1.0])
    ndc = p[:2] / p[3]
    px = ((ndc[0] + 1) / 2 * cam.width, (1 - ndc[1]) / 2 * cam.height)  # row 0 at the top
    np.testing.assert_allclose(px, (50 + dx, 50 + dy), atol=1e-9)


def test_zoom_scales_distance():
    assert dist(cc.zoom(CAM, 0.5)) == pytest.approx(1.5)
    assert dist(cc.zoom(CAM, cc.wheel_factor(2))) == pytest.approx(3.0 * 0.81)
    assert dist(cc.zoom(CAM, 0.0)) == pytest.approx(cc.MIN_DISTANCE)


# ---- saving scenes -------------------------------------------------------------------------------

def test_save_scene_round_trips_every_field(tmp_path):
    mesh = tmp_path / "m.obj"
    mesh.write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
    env = tmp_path / "env.exr"
    scene = scene_from_dict({
        "camera": {"position": [0.1, 0.2, 3.3], "fov_y": 33.3, "size": [40, 30], "near": 0.1},
        "environment": {"path": str(env), "intensity": 0.7, "rotation_deg": -12.5},
        "objects": [{"type": "mesh", "path": "m.obj",
                     "transform": [[1, 0, 0, 0.5], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]]},
                    {"type": "mesh", "path": "m.obj", "material": {"roughness": 0.2}},
                    {"type": "material_grid", "rows": 2, "cols": 3, "radius": 0.4},
                    {"type": "plane", "size": [3, 2], "normal": [0, 1, 0.1]}],
        "render": {"model": "blinn_phong", "multiscatter": False, "exposure": 0.1 + 0.2,
                   "tonemap": "reinhard", "background": "transparent", "seed": 7}},
        file=str(tmp_path / "orig.toml"), base=tmp_path)
    path = save_scene(scene, tmp_path / "saved.toml")
    loaded = load_scene(path)
    assert dataclasses.replace(loaded, source=None) == dataclasses.replace(scene, source=None)
    assert loaded.render.display.exposure == 0.1 + 0.2  # floats keep every bit


def test_saved_edited_scene_renders_identically_headless(ctx, tmp_path):
    """What the viewer shows (state -> scene) saved to TOML renders to the same pixels."""
    state = state_from_scene(sphere_scene())
    state.render = state.render.with_flat(exposure=0.7, tonemap="aces")
    state.camera = cc.zoom(cc.orbit(state.camera, 25.0, 10.0), 0.9)
    state.material_override = MaterialOverride(roughness=0.15)
    state.environment = dataclasses.replace(state.environment, intensity=1.7, rotation_deg=45.0)
    shown = scene_from_state(state)
    loaded = load_scene(save_scene(shown, tmp_path / "edited.toml"))
    renderer = Renderer(ctx=ctx)
    try:
        a, b = renderer.render(shown), renderer.render(loaded)
    finally:
        renderer.release()
    assert np.array_equal(a.radiance, b.radiance) and np.array_equal(a.display, b.display)
    assert a.radiance[..., 3].any()  # the sphere is in view


def test_material_edits_reuse_cached_geometry(ctx):
    """Material sliders change uniforms only: no new geometry, and the pixels still follow."""
    scene = sphere_scene()
    renderer = Renderer(ctx=ctx)
    try:
        dull = renderer.render(scene).radiance
        n = len(renderer.geometry_cache)
        state = state_from_scene(scene)
        state.material_override = MaterialOverride(albedo=(1.0, 1.0, 1.0))
        bright = renderer.render(scene_from_state(state)).radiance
        assert len(renderer.geometry_cache) == n
        fresh = Renderer(ctx=ctx)
        try:
            expected = fresh.render(scene_from_state(state)).radiance
        finally:
            fresh.release()
    finally:
        renderer.release()
    assert np.array_equal(bright, expected) and not np.array_equal(bright, dull)


def test_scene_to_dict_leaves_out_keys_a_type_rejects():
    objs = scene_to_dict(demo())["objects"]
    assert "rows" not in objs[1] and objs[0]["rows"] == 2


def test_save_scene_into_a_missing_folder_is_one_line(tmp_path):
    with pytest.raises(SceneError, match="folder does not exist") as err:
        save_scene(sphere_scene(), tmp_path / "nope" / "s.toml")
    assert "\n" not in str(err.value)
