"""A setting that tunes a part of the frame it does not run is said, not dropped silently
(viewer.scene.settings.dormant_settings): each such knob, set away from its default, gives one
warning naming it and what it tunes; and the claim "no effect" is checked against the renderer:
the image with the knob equals the image without it, bit for bit."""
import warnings
from types import SimpleNamespace

import numpy as np
import pytest

from viewer.scene.settings import (
    RENDER_KEYS,
    TUNING_KEYS,
    FrameFacts,
    RenderSettings,
    dormant_settings,
)

# a value away from the default for every key of TUNING_KEYS (completeness is checked below)
OTHER = {"raytrace_rays": 2, "ray_denoise": False, "ray_frames": 4, "ray_still_frames": 2,
         "ray_scale": 2, "ssao_rays": 16, "ssao_steps": 4, "ssao_radius": 1.0,
         "ssao_thickness": 0.1, "ssao_scale": 2, "ssao_blur": False, "indirect_blur": False,
         "shadow_net_use": "visibility", "shadow_size": 512, "shadow_cube_size": 256,
         "shadow_budget": 0.5, "shadow_softness": 2.0, "shadow_bias": 2.0,
         "shadow_lod_error": 1.0, "shadow_cascades": 2,
         "contact_length": 0.2, "samples": 64, "sampling": "uniform", "mis_heuristic": "balance",
         "max_depth": 3, "weights": "w.safetensors", "teacher_weights": "t.safetensors",
         "neural_storage": "ubo", "specular_occlusion": False}
NOTHING = FrameFacts(RenderSettings(), SimpleNamespace(name="unlit", accumulates=False,
                                                       network=None, specular_occlusion=False),
                     {}, frozenset())


def _running(key: str) -> FrameFacts:
    """A frame that runs what ``key`` tunes."""
    model = SimpleNamespace(name="path" if key == "max_depth" else "x", accumulates=True,
                            network="teacher" if key == "teacher_weights" else "student",
                            specular_occlusion=True)
    return FrameFacts(RenderSettings(), model, {"CONTACT_SHADOWS": 1, "SAMPLING": 4, "USE_AO": 1},
                      frozenset({"raytrace", "ssao", "indirect_gather", "indirect",
                                 "shadow_net", "shadowsun"}))


def test_every_tuning_key_is_a_render_key_with_another_value_here():
    keys = [k for group, _, _ in TUNING_KEYS for k in group]
    assert len(keys) == len(set(keys)) and set(keys) == set(OTHER)
    assert set(keys) <= set(RENDER_KEYS)
    default = RenderSettings().flat()
    assert all(OTHER[k] != default[k] for k in keys)


@pytest.mark.parametrize("key", sorted(OTHER))
def test_a_knob_of_what_the_frame_does_not_run_is_named_and_one_it_runs_is_not(key):
    asked = RenderSettings().with_flat(**{key: OTHER[key]})
    (said,) = dormant_settings(asked, NOTHING)
    assert f"render.{key} = " in said[1] and "no effect" in said[1]
    assert dormant_settings(asked, _running(key)) == []
    assert dormant_settings(RenderSettings(), NOTHING) == []  # the defaults say nothing


def test_a_default_read_back_as_float32_is_no_change():
    """The viewer's sliders hold float32: 0.2 comes back as 0.20000000298..., still the
    default, and says nothing."""
    knobs = {k: float(np.float32(v)) for k, v in RenderSettings().flat().items()
             if isinstance(v, float)}
    assert knobs and any(v != RenderSettings().flat()[k] for k, v in knobs.items())
    assert dormant_settings(RenderSettings().with_flat(**knobs), NOTHING) == []


def test_one_sample_is_what_a_one_sample_model_draws():
    from dataclasses import replace

    one = RenderSettings().with_flat(samples=1)
    assert dormant_settings(one, replace(NOTHING, settings=one)) == []


def test_several_knobs_of_one_part_are_one_warning_keyed_by_their_names():
    asked = RenderSettings().with_flat(ray_scale=3, ray_still_frames=2)
    ((key, said),) = dormant_settings(asked, NOTHING)
    assert said.startswith("render.ray_still_frames = 2 and render.ray_scale = 3 have no "
                           "effect: they tune the ray-traced tier")
    # the key names the knobs, not their values: a slider moving them warns once
    ((again, _),) = dormant_settings(asked.with_flat(ray_scale=4), NOTHING)
    assert key == again == "dormant:ray_still_frames,ray_scale"


@pytest.mark.parametrize("knob,switches", [
    ({"ray_scale": 2, "ray_still_frames": 2, "raytrace_rays": 2}, {"raytrace": False}),
    ({"ssao_rays": 16, "ssao_scale": 2, "ssao_blur": False}, {"raytrace": False}),
    ({"ssao_rays": 16, "indirect_blur": False}, {"raytrace": True, "ssao": True,
                                                 "indirect": True}),
    ({"shadow_net_use": "visibility"}, {"raytrace": False, "ssao": True}),
    ({"shadow_size": 512, "shadow_softness": 2.0}, {"raytrace": False, "shadows": False}),
    ({"samples": 64, "sampling": "uniform", "max_depth": 3, "neural_storage": "ubo"}, {}),
    ({"contact_length": 0.2}, {"contact_shadows": "off"}),
])
def test_the_renderer_warns_once_and_the_knob_changes_nothing(ctx, knob, switches):
    from assets import ASSET_ROOT
    from relight.commands.common import DEMO_SCENE
    from viewer import renderer as renderer_module
    from viewer.renderer import Renderer
    from viewer.scene.description import load_scene

    scene = load_scene(ASSET_ROOT / "scenes" / DEMO_SCENE).with_render(**switches)
    r = Renderer(ctx=ctx)
    try:
        plain = r.render(scene, size=(48, 32)).radiance
        renderer_module._LIGHT_WARNED.clear()
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            tuned = r.render(scene.with_render(**knob), size=(48, 32)).radiance
            r.render(scene.with_render(**knob), size=(48, 32))  # once per process
    finally:
        r.release()
    said = [str(w.message) for w in caught if "no effect" in str(w.message)]
    groups = {i for i, (keys, _, _) in enumerate(TUNING_KEYS) for k in knob if k in keys}
    assert len(said) == len(groups), said  # one warning per part, every knob in one of them
    assert all(sum(f"render.{k} = " in m for m in said) == 1 for k in knob), said
    assert np.array_equal(plain, tuned)


def test_a_knob_of_what_the_frame_runs_says_nothing(ctx):
    """The defaults (rays on) with the rays' and the shadow maps' knobs moved, and split-sum
    without rays with SSAO's: every knob is used, no warning (and the image moves)."""
    from assets import ASSET_ROOT
    from relight.commands.common import DEMO_SCENE
    from viewer import renderer as renderer_module
    from viewer.renderer import Renderer
    from viewer.scene.description import load_scene

    scene = load_scene(ASSET_ROOT / "scenes" / DEMO_SCENE)
    r = Renderer(ctx=ctx)
    renderer_module._LIGHT_WARNED.clear()
    try:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            for knob in ({"ray_scale": 2, "raytrace_rays": 2},
                         {"raytrace": False, "shadow_size": 512, "shadow_softness": 0.0},
                         {"raytrace": False, "ssao": True, "ssao_rays": 16}):
                plain = r.render(scene.with_render(**{k: v for k, v in knob.items()
                                                      if k == "raytrace"}), size=(48, 32))
                tuned = r.render(scene.with_render(**knob), size=(48, 32))
                assert not np.array_equal(plain.radiance, tuned.radiance), knob
    finally:
        r.release()
    assert not [w for w in caught if "no effect" in str(w.message)]
