"""A setting that tunes a pass the frame does not run is said, not dropped silently
(viewer.scene.settings.dormant_settings): each such knob, set away from its default, gives one
warning naming it and the pass; and the claim "no effect" is checked against the renderer: the
image with the knob equals the image without it, bit for bit."""
import warnings

import numpy as np
import pytest

from viewer.scene.settings import RENDER_KEYS, TUNING_KEYS, RenderSettings, dormant_settings

# a value away from the default for every key of TUNING_KEYS (completeness is checked below)
OTHER = {"raytrace_rays": 2, "ray_denoise": False, "ray_frames": 4, "ray_still_frames": 2,
         "ray_scale": 2, "ssao_rays": 16, "ssao_steps": 4, "ssao_radius": 1.0,
         "ssao_thickness": 0.1, "ssao_scale": 2, "ssao_blur": False, "indirect_blur": False,
         "shadow_net_use": "visibility"}


def test_every_tuning_key_is_a_render_key_with_another_value_here():
    keys = [k for group, _, _ in TUNING_KEYS for k in group]
    assert len(keys) == len(set(keys)) and set(keys) == set(OTHER)
    assert set(keys) <= set(RENDER_KEYS)
    default = RenderSettings().flat()
    assert all(OTHER[k] != default[k] for k in keys)


@pytest.mark.parametrize("key", sorted(OTHER))
def test_a_knob_of_a_pass_that_does_not_run_is_named_and_one_that_runs_is_not(key):
    asked = RenderSettings().with_flat(**{key: OTHER[key]})
    off = asked.with_flat(raytrace=False, ssao=False, indirect=False)
    (said,) = dormant_settings(off, off, rays=False)
    assert f"render.{key} = " in said[1] and "no effect" in said[1]
    # the same knob where its pass runs: nothing to say
    on = {"raytrace_rays": {}, "ray_denoise": {}, "ray_frames": {}, "ray_still_frames": {},
          "ray_scale": {}}.get(key)
    if on is not None:
        assert dormant_settings(asked, asked, rays=True) == []
    elif key == "shadow_net_use":
        runs = asked.with_flat(shadow_net="w.safetensors")
        assert dormant_settings(asked, runs, rays=False) == []  # the file given: it runs
    else:
        runs = asked.with_flat(ssao=True, indirect=True)
        assert dormant_settings(runs, runs, rays=False) == []
        # the rays stand in for SSAO and its bounce: they do not run under the tier
        assert len(dormant_settings(runs, runs, rays=True)) == 1
    # the defaults say nothing, whatever runs
    assert dormant_settings(RenderSettings(), RenderSettings(), rays=False) == []


def test_several_knobs_of_one_pass_are_one_warning():
    asked = RenderSettings().with_flat(raytrace=False, ray_scale=3, ray_still_frames=2)
    (said,) = dormant_settings(asked, asked, rays=False)
    assert said[1].startswith("render.ray_still_frames = 2 and render.ray_scale = 3 have no "
                              "effect: they tune the ray-traced tier")


@pytest.mark.parametrize("knob,switches", [
    ({"ray_scale": 2, "ray_still_frames": 2, "raytrace_rays": 2}, {"raytrace": False}),
    ({"ssao_rays": 16, "ssao_scale": 2, "ssao_blur": False}, {"raytrace": False}),
    ({"ssao_rays": 16, "indirect_blur": False}, {"raytrace": True, "ssao": True,
                                                 "indirect": True}),
    ({"shadow_net_use": "visibility"}, {"raytrace": False, "ssao": True}),
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
    assert len(said) == len(groups), said  # one warning per pass, every knob in one of them
    assert all(sum(f"render.{k} = " in m for m in said) == 1 for k in knob), said
    assert np.array_equal(plain, tuned)
