"""``path`` (the GL path tracer, shaders/passes/shade_path.frag) converges to ``relight
reference`` (Mitsuba 3, our BSDF, the same triangles): statistical tests per block of pixels, in
the manner of Mitsuba's own tests, never a PSNR threshold.

The image's variance comes from GROUPS independent renders (seeds); a block's z is the
difference of its mean from the reference's over the combined standard error, against the
Student-t threshold of GROUPS - 1 degrees of freedom at a family-wise false-alarm rate ALPHA
(Bonferroni over blocks and channels). Blocks of BLOCK x BLOCK pixels are near normal where
single pixels are not (a conductor's sun highlight is a few very bright samples). Each check
also shows it can fail: the same test rejects a tracer that stops after direct light, and
the rasteriser's Monte-Carlo model, which has no visibility.

Stored references (assets/references, 1024-4096 spp) need no Mitsuba here; the point and spot
lights are traced by Mitsuba on the spot (``mitsuba_llvm``), small."""
import math

import numpy as np
import pytest

from relight.bench.path import block_test
from relight.reference import read_reference
from relight.reference.compare import coverage_mask
from viewer.scene.description import load_scene, scene_from_dict

GROUPS = 8
# (scene folder, name, spp per group): a sphere on a floor under an HDRI (visibility and the
# floor's bounce on the sphere), spheres under a studio with a 5-degree disc light, a rough
# conductor under a sun-lit sky (the environment's sun reached by importance sampling)
SCENES = (("reference", "park_sphere_on_plane", 16), ("shadows", "studio_key_spheres", 8),
          ("reference", "sky_conductor_r03", 16))


def _runs(renderer, scene, spp: int, groups: int = GROUPS, **render) -> np.ndarray:
    return np.asarray([renderer.render(scene.with_render(model="path", samples=spp, seed=s,
                                                         **render)).radiance
                       for s in range(groups)], np.float64)


@pytest.mark.parametrize("folder,name,spp", SCENES)
def test_path_converges_to_the_reference(renderer, folder, name, spp):
    scene = load_scene(f"assets/scenes/{folder}/{name}.toml")
    ref = read_reference(f"assets/references/{name}.exr")
    runs = _runs(renderer, scene, spp)
    result = block_test(runs, ref)
    assert result.count > 100 and result.passed, result
    # the whole image's energy, within 4 standard errors of the reference's (both noises)
    m = coverage_mask(runs.mean(0), ref)
    totals = runs[..., :3][:, m].sum(axis=(1, 2))
    ref_total = float(ref.radiance[..., :3][m].sum())
    noise = math.hypot(totals.std(ddof=1) / math.sqrt(GROUPS),
                       math.sqrt(float((ref.stderr[m].astype(np.float64) ** 2).sum())))
    assert abs(totals.mean() - ref_total) < 4.0 * noise, (totals.mean() / ref_total - 1, noise)


def test_the_test_rejects_missing_bounces_and_missing_visibility(renderer):
    """Direct light only (max_depth 2: no light from the floor on the sphere's underside) and
    the rasteriser's ggx_mc (the same BSDF, no visibility: no contact shadow) both fail."""
    scene = load_scene("assets/scenes/reference/park_sphere_on_plane.toml")
    ref = read_reference("assets/references/park_sphere_on_plane.exr")
    assert not block_test(_runs(renderer, scene, 16, max_depth=2), ref).passed
    mc = np.asarray([renderer.render(scene.with_render(model="ggx_mc", samples=16, seed=s))
                     .radiance for s in range(GROUPS)], np.float64)
    assert not block_test(mc, ref).passed


def test_noise_falls_as_one_over_root_spp(renderer):
    """Four times the samples halve the per-pixel standard deviation across seeds (measured:
    ratio 1.9-2.1 over the covered pixels' median)."""
    scene = load_scene("assets/scenes/reference/park_sphere_on_plane.toml")
    low = _runs(renderer, scene, 4)
    high = _runs(renderer, scene, 16)
    m = low[0, ..., 3] > 0.5
    sd_low = low[..., :3].std(0, ddof=1)[m]
    sd_high = high[..., :3].std(0, ddof=1)[m]
    ratio = np.median(sd_low) / np.median(sd_high)
    assert 1.7 < ratio < 2.3, ratio


def _lit_floor_scene(light: dict):
    return scene_from_dict({
        "camera": {"position": [0.0, 1.6, 2.6], "target": [0.0, 0.0, 0.0], "fov_y": 45.0,
                   "size": [40, 32]},
        "environment": {"procedural": "studio", "width": 128, "intensity": 0.3},
        "render": {"multiscatter": True, "ao": False, "tonemap": "none",
                   "background": "transparent"},
        "objects": [
            {"type": "sphere", "center": [0.0, 0.0, 0.0], "radius": 0.5,
             "material": {"albedo": [0.8, 0.4, 0.2], "roughness": 0.4}},
            {"type": "plane", "center": [0.0, -0.5, 0.0], "size": [6.0, 6.0],
             "material": {"albedo": [0.7, 0.7, 0.7], "roughness": 0.8}}],
        "lights": [light]})


@pytest.mark.parametrize("light", [
    {"type": "point", "position": [0.8, 1.5, 0.6], "intensity": 3.0},
    {"type": "spot", "position": [-0.6, 1.8, 0.8], "direction": [-0.3, 0.9, 0.4],
     "intensity": 6.0, "inner_cone_deg": 15.0, "outer_cone_deg": 35.0}], ids=["point", "spot"])
def test_path_converges_with_point_and_spot_lights(mitsuba_llvm, renderer, light):
    from relight.reference import ReferenceOptions, render_reference

    scene = _lit_floor_scene(light)
    ref = render_reference(scene, ReferenceOptions(spp=512, max_depth=6), progress=False)
    runs = _runs(renderer, scene, 16)
    result = block_test(runs, ref)
    assert result.count > 40 and result.passed, result
