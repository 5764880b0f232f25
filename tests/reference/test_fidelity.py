"""Fidelity: the rasteriser's models against committed path-traced references (Mitsuba 3, our BSDF,
4096 spp, pixel-centre rays; ``assets/references``, made by ``relight reference
assets/scenes/reference/*.toml --out-dir assets/references --spp 4096``). No Mitsuba is needed
here: the references are data, and tests/reference/test_reference_render.py checks that the tool
that made them agrees with itself and with physics.

Two kinds of bound:
* ``ggx_mc`` integrates the same BSDF over the same environment, so on convex objects (no
  visibility) it equals the reference in expectation: a per-pixel z-test whose false-alarm rate
  (1e-3 per scene, Bonferroni over pixels) follows from the two estimates' own variances, and an
  energy-bias test at 4 standard errors.
* approximations (split-sum, SH9, SSAO) differ by more than noise: their bounds are the issue's
  stated goals or a physical statement (missing visibility over-estimates energy), each plus 3
  standard errors of the reference's own noise.
"""
import math

import numpy as np
import pytest
from scipy import stats

from assets import ASSET_ROOT
from relight.reference import read_reference
from relight.reference.compare import coverage_mask, score, z_test
from viewer.scene.description import load_scene

SCENES = ASSET_ROOT / "scenes" / "reference"
REFS = ASSET_ROOT / "references"
ALL = sorted(p.stem for p in SCENES.glob("*.toml"))
CONVEX = [n for n in ALL if "on_plane" not in n]
ON_PLANE = [n for n in ALL if "on_plane" in n]
GROUPS, GROUP_SPP = 16, 256  # ggx_mc: 16 independent renders (seeds) of 256 spp each


@pytest.fixture(scope="module")
def renderer(ctx):
    from viewer.renderer import Renderer

    return Renderer(ctx=ctx)


def _load(name):
    return load_scene(SCENES / f"{name}.toml"), read_reference(REFS / f"{name}.exr")


_MC_CACHE: dict = {}


def _mc(renderer, scene):
    """Mean of GROUPS independent ggx_mc renders, its per-pixel standard error (from the spread
    of the groups) and the standard error of its total (the energy-bias test)."""
    if scene.source in _MC_CACHE:
        return _MC_CACHE[scene.source]
    runs = np.asarray([renderer.render(scene.with_render(
        model="ggx_mc", samples=GROUP_SPP, sampling="mis", seed=1000 + g)).radiance
        for g in range(GROUPS)])
    mean = runs.mean(axis=0)
    se = runs[..., :3].std(axis=0, ddof=1) / math.sqrt(GROUPS)
    _MC_CACHE[scene.source] = (mean, se, runs)
    return mean, se, runs


def test_every_reference_scene_has_a_reference():
    assert len(ALL) >= 10 and ON_PLANE
    for name in ALL:
        ref = read_reference(REFS / f"{name}.exr")
        assert ref.meta["spp"] >= 4096 and ref.meta["rays"] == "pixel centre"
        scene = load_scene(SCENES / f"{name}.toml")
        assert ref.radiance.shape[:2] == (scene.camera.height, scene.camera.width)


# The references trace the rasteriser's own triangles (a 192 x 96 sphere), so the path tracer
# also sees the facets: a shadow ray towards a light that the interpolated shading normal faces
# (n.l > 0) but the flat facet does not starts below the facet and hits the sphere itself. That
# self-shadowing of the tessellation exists only where n.l is within the facet's normal deviation
# (at most half a 1.875-degree facet diagonal, 1.33 degrees) plus the sun's angular radius (2
# degrees for the procedural sky, under one texel, 0.7 degrees, for the HDRIs) of zero: a 5-degree
# band around the sun's terminator. Measured: there 3 to 10 pixels of the rough conductors under
# the procedural sky differed by up to 50 %, and the same scene traced with --geometry analytic
# agreed with ggx_mc at those pixels (0.547 vs 0.556). The per-pixel test leaves that band out.
TERMINATOR_BAND_DEG = 5.0


def _sun_direction(scene) -> np.ndarray:
    """World direction of the environment's brightest texel (rotation 0 in these scenes)."""
    from viewer.environment.maps import load_environment, texel_directions

    env = load_environment(scene.environment)
    lum = env.sum(axis=-1)
    i, j = np.unravel_index(np.argmax(lum), lum.shape)
    assert scene.environment.rotation_deg == 0.0
    return texel_directions(env.shape[1])[i, j]


@pytest.mark.parametrize("name", CONVEX)
def test_ggx_mc_equals_path_traced_truth_per_pixel(renderer, name):
    """Same integrand, same triangles, no visibility: equal in expectation, pixel by pixel, away
    from the sun's terminator band (above). The image's variance is estimated from 16 renders,
    so the threshold is Student-t with 15 degrees of freedom (conservative for the combined
    variance's effective degrees of freedom)."""
    scene, ref = _load(name)
    mean, se, _ = _mc(renderer, scene)
    normal = renderer.render(scene, aovs=("normal",)).aovs["normal"][..., :3]
    n_dot_sun = normal @ _sun_direction(scene)
    band = np.abs(n_dot_sun) < math.sin(math.radians(TERMINATOR_BAND_DEG))
    mask = coverage_mask(mean, ref) & ~band
    result = z_test(mean, ref, image_stderr=se, alpha=1e-3, mask=mask,
                    quantile=lambda p: float(stats.t.isf(p, GROUPS - 1)))
    assert result.passed, result


@pytest.mark.parametrize("name", CONVEX)
def test_ggx_mc_has_the_path_traced_energy(renderer, name):
    """The total over the object within 4 standard errors (reference noise and the spread of
    the 16 renders' totals, combined)."""
    scene, ref = _load(name)
    mean, _, runs = _mc(renderer, scene)
    m = coverage_mask(mean, ref)
    totals = runs[..., :3][:, m].sum(axis=(1, 2))
    ref_total = ref.radiance[..., :3][m].sum()
    noise = math.hypot(totals.std(ddof=1) / math.sqrt(GROUPS),
                       math.sqrt((ref.stderr[m].astype(np.float64) ** 2).sum()))
    assert abs(totals.mean() - ref_total) < 4.0 * noise, (totals.mean() / ref_total - 1, noise)


@pytest.mark.parametrize("name", ON_PLANE)
def test_missing_visibility_overestimates_and_ssao_moves_towards_truth(renderer, name):
    """A sphere resting on a plane: ggx_mc has the exact BSDF integral but no visibility, so it
    sees the environment through the sphere (no contact shadow): more energy than truth, beyond
    the reference's noise. Screen-space AO occludes some of that light, so split-sum with SSAO
    is closer in total energy than split-sum without it; the default render's rays (the
    real-time tier) closer still."""
    scene, ref = _load(name)
    mean, _, _ = _mc(renderer, scene)
    s = score(mean, ref)
    assert s.bias > 3.0 * s.bias_noise + 0.02, s
    plain = score(renderer.render(scene.with_render(model="ggx_split_sum", raytrace=False)
                                  ).radiance, ref)
    ssao = score(renderer.render(scene.with_render(model="ggx_split_sum", ssao=True,
                                                   raytrace=False)).radiance, ref)
    assert plain.bias > ssao.bias > -0.05, (plain, ssao)
    # the default render's rays: closer per pixel (the total can be further off: on park the
    # tier takes 5.5 % too much, its bounce sees hit surfaces as Lambertian, so a metal sphere
    # lights the floor with nothing; measured PSNR rays / ssao: park 36.9 / 33.3, studio
    # 27.7 / 19.8 dB)
    traced = score(renderer.render(scene.with_render(model="ggx_split_sum")).radiance, ref)
    print(f"{name}: bias plain {plain.bias:+.4f} ssao {ssao.bias:+.4f} rays {traced.bias:+.4f}"
          f"; psnr ssao {ssao.psnr:.2f} rays {traced.psnr:.2f}")
    assert traced.psnr > ssao.psnr + 3.0, (traced, ssao)


# ---- split-sum against truth (issue 12's goals) ------------------------------------------
# Goals: |total bias| <= 3 % at roughness <= 0.3 and 8 % at 0.8; median
# per-pixel relative error <= 5 % at 0.05 and 8 % at 0.3. Each score is compared after adding 3
# standard errors of the reference's own noise (Score.bias_noise) to the bound.
SPLIT_SUM_BIAS_GOAL = {"005": 3.0, "03": 3.0, "08": 8.0}
SPLIT_SUM_MEDIAN_GOAL = {"005": 5.0, "03": 8.0}
# All are met since the split-sum shades the environment's sun analytically (viewer/environment/sun.py): with
# render.sun = false, park at 0.3 measures -7.3 % and procsky at 0.3 -4.8 %, the sun's reflection
# near the grazing rim, where one lookup of a round pre-blurred lobe cannot follow the stretched,
# horizon-clipped lobe (test_the_analytic_sun_is_what_meets_the_rim_goals).


@pytest.mark.parametrize("name", [n for n in CONVEX if "conductor" in n])
def test_split_sum_against_truth_meets_the_goals(renderer, name):
    scene, ref = _load(name)
    s = score(renderer.render(scene.with_render(model="ggx_split_sum")).radiance, ref)
    r = name.rsplit("_r", 1)[1]
    noise = 300.0 * s.bias_noise  # 3 standard errors, in %
    assert abs(100 * s.bias) <= SPLIT_SUM_BIAS_GOAL[r] + noise, s
    if r in SPLIT_SUM_MEDIAN_GOAL:
        assert 100 * s.median_rel <= SPLIT_SUM_MEDIAN_GOAL[r], s


@pytest.mark.parametrize("name", ["park_conductor_r03", "procsky_conductor_r03"])
def test_the_analytic_sun_is_what_meets_the_rim_goals(renderer, name):
    """The two scenes whose sun reflects near the grazing rim: without the analytic sun
    (render.sun = false) the split-sum loses more than the goal's 3 % (measured -7.3 % and
    -4.8 %), with it it is within 1 % (measured -0.9 %, -0.5 %)."""
    scene, ref = _load(name)
    off = score(renderer.render(scene.with_render(model="ggx_split_sum", sun=False)).radiance,
                ref)
    on = score(renderer.render(scene.with_render(model="ggx_split_sum")).radiance, ref)
    assert off.bias < -0.04, off
    assert abs(on.bias) <= 0.01 + 3.0 * on.bias_noise, on


def test_exact_irradiance_diffuse_against_truth(renderer):
    """A Lambert sphere under a real HDRI, diffuse from the exact irradiance map (the cosine
    convolution of every texel, viewer/environment/irradiance.py): the sun inside the map (render.sun = false)
    or taken out and shaded as a light (the default), bias within 1 % and median per-pixel error
    within 3 % either way (measured 0.0 % and 0.8 % both). Nine SH coefficients, the method the map
    replaced, rang and blurred at the sun's terminator: 10.2 % median with the sun inside."""
    scene, ref = _load("park_diffuse")
    s = score(renderer.render(scene.with_render(model="ggx_split_sum", sun=False)).radiance, ref)
    assert abs(s.bias) <= 0.01 + 3.0 * s.bias_noise, s
    assert s.median_rel <= 0.03, s
    s = score(renderer.render(scene.with_render(model="ggx_split_sum")).radiance, ref)
    assert abs(s.bias) <= 0.01 + 3.0 * s.bias_noise, s
    assert s.median_rel <= 0.03, s
