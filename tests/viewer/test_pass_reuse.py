"""Reusing the last frame's G-buffer and SSAO targets (Renderer.reuse_passes): a frame whose
geometry, camera and SSAO inputs are unchanged draws only the lighting passes, and is the frame a
renderer drawing every pass makes, bit for bit; any change that enters the G-buffer or the SSAO
pass draws them again (never a stale frame)."""
import dataclasses

import numpy as np
import pytest

from relight.bench.real_assets_cases import sx_student_file
from viewer.gl.timing import PassTimer
from viewer.renderer import Renderer
from viewer.scene.description import scene_from_dict

BASE = {
    "camera": {"position": [0, 1.2, 2.6], "target": [0, 0.3, 0], "fov_y": 45, "size": [40, 32]},
    "environment": {"procedural": "sky", "width": 64},
    "objects": [
        {"type": "plane", "center": [0, 0, 0], "size": [6, 6], "normal": [0, 1, 0],
         "material": {"albedo": [0.8, 0.8, 0.8], "roughness": 0.7}},
        {"type": "sphere", "center": [0, 0.45, 0], "radius": 0.45,
         "material": {"albedo": [0.9, 0.3, 0.2], "roughness": 0.4}}],
    # the rasterised passes (SSAO, its bounce, shadow maps); the rays' reuse is
    # tests/viewer/test_rt_light.py's
    "render": {"tonemap": "none", "ssao_rays": 6, "ssao_steps": 6, "raytrace": False},
}
CASES = {  # the student reads SSAO and the indirect light (with hits); the S(x) student also
    # the visibility S(x), whose directions turn with the environment
    "neural": {"model": "neural"},
    "neural S(x)": {"model": "neural", "weights": str(sx_student_file())},
    "split+ssao+indirect": {"ssao": True, "indirect": True},
    "split+ssao+indirect 1/2": {"ssao": True, "indirect": True, "ssao_scale": 2},
}


@pytest.fixture(scope="module")
def renderer(ctx):
    r = Renderer(ctx=ctx)
    r.profiler = PassTimer(ctx)
    yield r
    r.release()


def _frame(renderer, scene):
    """(radiance, the passes drawn) of one frame."""
    timer = renderer.profiler
    timer.enabled = True
    timer.reset()
    try:
        frame = renderer.render(scene)
        return frame.radiance, set(timer.milliseconds())
    finally:
        timer.enabled = False


def _full(renderer, scene):
    with renderer.every_pass():
        return _frame(renderer, scene)[0]


def _scene(render, **changes):
    d = {**BASE, "render": {**BASE["render"], **render}}
    return scene_from_dict({**d, **changes})


@pytest.mark.parametrize("case", list(CASES))
def test_a_light_slider_redraws_only_the_lighting(renderer, case):
    scene = _scene(CASES[case])
    _frame(renderer, scene)
    brighter = dataclasses.replace(scene, environment=dataclasses.replace(
        scene.environment, intensity=1.7))
    img, drawn = _frame(renderer, brighter)
    assert "gbuffer" not in drawn and "ssao" not in drawn, drawn
    assert "shade" in drawn
    assert {"indirect"} <= drawn  # gathers this frame's direct light
    np.testing.assert_array_equal(img, _full(renderer, brighter))
    assert not np.array_equal(img, _full(renderer, scene))  # the slider did something


def _moved_camera(scene):
    return scene.with_camera(position=(0.3, 1.2, 2.6))


def _rotated_environment(scene):
    return dataclasses.replace(scene, environment=dataclasses.replace(scene.environment,
                                                                      rotation_deg=40.0))


def _new_material(scene):
    plane, sphere = scene.objects
    sphere = dataclasses.replace(sphere, material=dataclasses.replace(sphere.material,
                                                                      albedo=(0.2, 0.6, 0.9)))
    return dataclasses.replace(scene, objects=(plane, sphere))


def _moved_sphere(scene):
    plane, sphere = scene.objects
    return dataclasses.replace(scene, objects=(plane, dataclasses.replace(
        sphere, center=(0.2, 0.45, 0.0))))


CHANGES = {  # change -> (the change, the passes it must draw again)
    "camera": (_moved_camera, {"gbuffer", "ssao"}),
    "geometry": (_moved_sphere, {"gbuffer", "ssao"}),
    "material": (_new_material, {"gbuffer", "ssao"}),
    "ssao radius": (lambda s: s.with_render(ssao_radius=0.9), {"ssao"}),
    "seed": (lambda s: s.with_render(seed=5), {"ssao"}),
    "environment rotation (the visibility's directions)": (_rotated_environment, {"ssao"}),
}


@pytest.mark.parametrize("change", list(CHANGES))
def test_what_enters_the_gbuffer_or_ssao_redraws_them(renderer, change):
    scene = _scene(CASES["neural S(x)"])
    make, must = CHANGES[change]
    _frame(renderer, scene)
    changed = make(scene)
    img, drawn = _frame(renderer, changed)
    assert must <= drawn, (change, drawn)
    np.testing.assert_array_equal(img, _full(renderer, changed))


def test_replaced_geometry_content_redraws(renderer):
    """In-memory geometry (add_geometry) replaced under the same object: not the old G-buffer."""
    from viewer.geometry.primitives import sphere
    from viewer.scene.description import ObjectSpec

    scene = _scene({"ssao": True})
    scene = dataclasses.replace(scene, objects=scene.objects + (
        ObjectSpec(type="mesh", path="in-memory-probe"),))
    renderer.add_geometry(scene.objects[-1], [sphere(center=(0.6, 0.2, 0.3), radius=0.2)])
    _frame(renderer, scene)
    renderer.add_geometry(scene.objects[-1], [sphere(center=(-0.6, 0.3, 0.3), radius=0.3)])
    img, drawn = _frame(renderer, scene)
    assert "gbuffer" in drawn
    np.testing.assert_array_equal(img, _full(renderer, scene))


def test_environment_visibility_between_frames_is_not_reused(renderer):
    """Renderer.environment_visibility draws into a target of its own: the frame's SSAO target
    (O only) is untouched, so the next frame may reuse it and is still the full frame."""
    scene = _scene({"ssao": True})
    targets = renderer.draw(scene)
    plain = np.frombuffer(targets.ssao.read(), np.float32).copy()
    vis = renderer.environment_visibility(scene, targets)
    assert vis.glo != targets.ssao.glo
    assert not np.array_equal(np.frombuffer(vis.read(), np.float32), plain)  # S(x) in g
    np.testing.assert_array_equal(np.frombuffer(targets.ssao.read(), np.float32), plain)
    img, drawn = _frame(renderer, scene)
    assert "ssao" not in drawn and "shade" not in drawn, drawn
    np.testing.assert_array_equal(img, _full(renderer, scene))


def test_every_pass_draws_everything(renderer):
    scene = _scene(CASES["split+ssao+indirect"])
    _frame(renderer, scene)
    with renderer.every_pass():
        _, drawn = _frame(renderer, scene)
    assert {"gbuffer", "ssao", "shade", "indirect"} <= drawn
    assert renderer.reuse_passes  # restored
