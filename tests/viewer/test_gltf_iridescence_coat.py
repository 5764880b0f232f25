"""KHR_materials_iridescence under KHR_materials_clearcoat: the spec's "Clearcoat" section
evaluates the coat before the film, whose outside IOR becomes the coat's (1.5), mix(1, 1.5,
clearcoat factor) for partial coats (OpenPBR's thin-film outside IOR, Babylon):
lib/iridescence.glsl iridescence_outside_ior, relight.reference.iridescence.outside_ior. The
film from 1.5 against the exact Airy summation (test_gltf_iridescence.airy_film), and a grid of
coated and uncoated film spheres (gltf_spheres.py) through the split sum and the path tracer
against ``relight reference``. A film of IOR 1.3 under the coat flips the phase of its first
interface (1.5 > 1.3; from air 1 < 1.3): its colour is another than the same film's in air."""
import numpy as np
import pytest
from gltf_spheres import grid_truth, mc_runs, per_sphere, sphere_grid
from test_gltf_iridescence import _chromaticity_error, _rgb, airy_film

from relight.reference.iridescence import NUMPY, film_fresnel, outside_ior

# the spec's film from the coat's IOR 1.5 against the exact film (Airy, exact Fresnel equations)
# between media 1.5 | film n2 | base n3, films 100..800 nm of IOR 1.3 and 1.8 over bases of IOR
# 1.5 and 2.0 at cos theta >= 0.8 (light refracted into a coat from air reaches cos >= 0.745):
# measured max |spec - exact| 0.0165 per channel. The same film seen from air (outside IOR 1,
# what every caller did before) misses the exact film under the coat by 0.049 .. 0.12 at normal
# incidence. (Near the critical angle, cos 0.5 for a film of 1.3 under 1.5, the spec's Schlick
# interface from the dense side is off by 0.64: not asserted, unreachable through a coat.)
COATED_FILM_ATOL = 0.025


def test_under_a_coat_the_film_follows_the_airy_summation_from_the_coats_ior():
    """film_fresnel from outside_ior(1) = 1.5 against airy_film(1.5, n2, n3) per channel within
    COATED_FILM_ATOL; from air (1.0) the same films are further than 0.04 from it at normal
    incidence, each of them (so the bound can fail); outside_ior is 1, 1.25 and 1.5 at coat
    factors 0, 0.5 and 1."""
    assert (outside_ior(0.0), outside_ior(0.5), outside_ior(1.0)) == (1.0, 1.25, 1.5)
    for n3 in (1.5, 2.0):
        f0 = ((n3 - 1.0) / (n3 + 1.0)) ** 2
        for n2 in (1.3, 1.8):
            from_air = 0.0
            for cos1 in (1.0, 0.9, 0.8):
                for d in (100.0, 250.0, 400.0, 800.0):
                    exact = _rgb(airy_film(1.5, n2, n3, d, cos1)[0])
                    spec = np.ravel(film_fresnel(NUMPY, np.float64(cos1), np.float64(d), n2,
                                                 (f0, f0, f0), outside_ior(1.0)))
                    assert np.abs(spec - exact).max() <= COATED_FILM_ATOL, (n3, n2, cos1, d)
                    if cos1 == 1.0:
                        air = np.ravel(film_fresnel(NUMPY, np.float64(cos1), np.float64(d), n2,
                                                    (f0, f0, f0), 1.0))
                        from_air = max(from_air, float(np.abs(air - exact).max()))
            assert from_air > 0.04, (n3, n2, from_air)


def _coat_film_grid(path, with_extension: bool = True):
    """Four spheres over a near-black glossy base (so the film's colour shows): 0 the coat
    alone (clearcoat 1, roughness 0.1: the control), 1 the coat over a film of IOR 1.3, 400 nm
    (outside IOR 1.5), 2 the same film uncoated (outside 1), 3 the film under half a coat
    (outside 1.25). ``with_extension`` False: the films left out (the coats kept)."""
    base = {"baseColorFactor": [0.02, 0.02, 0.02, 1.0], "metallicFactor": 0.0,
            "roughnessFactor": 0.25}
    film = {"iridescenceFactor": 1.0, "iridescenceIor": 1.3, "iridescenceThicknessMaximum": 400.0}
    materials = []
    for coat, has_film in ((1.0, False), (1.0, True), (0.0, True), (0.5, True)):
        ext = {}
        if coat > 0.0:
            ext["KHR_materials_clearcoat"] = {"clearcoatFactor": coat,
                                              "clearcoatRoughnessFactor": 0.1}
        if has_film and with_extension:
            ext["KHR_materials_iridescence"] = film
        materials.append({"pbrMetallicRoughness": base, **({"extensions": ext} if ext else {})})
    used = ["KHR_materials_clearcoat"] + (["KHR_materials_iridescence"] if with_extension else [])
    return sphere_grid(path, materials, used)


@pytest.fixture(scope="module")
def renderer(ctx):
    from viewer.renderer import Renderer

    return Renderer(ctx=ctx)


@pytest.fixture(scope="module")
def coat_truth(mitsuba_llvm, tmp_path_factory):
    """The coated-film grid and its reference (64 spp, direct light)."""
    return grid_truth(tmp_path_factory, "coat_film", _coat_film_grid, spp=64)


def _chromaticity(image, ref, count=4):
    """Per sphere: the mean colour over the pixels both cover, as rgb / (r + g + b)."""
    from gltf_spheres import sphere_masks

    out = []
    for m in sphere_masks(count):
        c = image[m & (image[..., 3] > 0.999) & (ref[..., 3] > 0.999)][:, :3].sum(0)
        out.append(c.astype(np.float64) / float(c.sum()))
    return out


# per sphere (|bias|, median per-pixel error, chromaticity error) of ggx_split_sum against the
# reference. Measured: bias -2.0, +7.0, +5.7, +9.2 %; median 4.9, 8.6, 8.1, 8.4 %; chromaticity
# 0.0031, 0.0024, 0.0149, 0.0014 (the uncoated film's 0.015 is three.js's F0 of the film's
# Fresnel at n.v: test_gltf_iridescence's bubble). With the film seen from air under the coat
# (outside IOR 1, as before) the coated films read bias -73.7 % and -10.7 %, chromaticity 0.046
# and 0.061: the coat of factor 1 over a film of IOR 1.3 reflects totally where v.h < 0.5 (the
# spec's total internal reflection from 1.5 into 1.3), a bright rim the film seen from air lacks
COAT_SPLIT_SUM_BOUNDS = ((0.05, 0.08, 0.01), (0.12, 0.12, 0.01), (0.10, 0.12, 0.03),
                         (0.12, 0.12, 0.01))
# the film's colour under the full coat minus the same film's uncoated (chromaticity, per
# channel), split sum against reference: measured 0.014 apart (outside IOR 1: 0.060)
COAT_SHIFT_ATOL = 0.025


def test_the_split_sum_sees_the_film_under_a_coat_from_the_coats_ior(coat_truth, renderer):
    """ggx_split_sum on :func:`_coat_film_grid` (32 px per sphere) against ``relight reference``
    (64 spp): per sphere within COAT_SPLIT_SUM_BOUNDS, and the coated film's colour differs from
    the uncoated film's as the reference's does, within COAT_SHIFT_ATOL. Both fail with the film
    seen from air (measured beside the bounds)."""
    ext, _, ref = coat_truth
    ref = ref.radiance
    image = renderer.render(ext.with_render(model="ggx_split_sum")).radiance
    scores = [(*s[:2], c) for s, c in zip(per_sphere(image, ref, 4),
                                          _chromaticity_error(image, ref, 4))]
    assert all(abs(s[0]) <= b and s[1] <= med and s[2] <= chroma
               for s, (b, med, chroma) in zip(scores, COAT_SPLIT_SUM_BOUNDS)), scores
    ci, cr = _chromaticity(image, ref), _chromaticity(ref, ref)
    shift_image, shift_ref = ci[1] - ci[2], cr[1] - cr[2]
    assert np.abs(shift_image - shift_ref).max() <= COAT_SHIFT_ATOL, (shift_image, shift_ref)
    assert np.abs(shift_ref).max() > 0.05  # the coat changes the film's colour


def test_the_path_tracer_sees_the_film_under_a_coat_from_the_coats_ior(coat_truth, renderer):
    """``path`` (direct light, the reference's max_depth 2) on the same grid: the per-block
    z-test (8 seeds x 16 spp) passes (measured max |z| 2.4, threshold 11.8); with the film seen
    from air under the coat it fails (measured: 19 of 144 blocks, max |z| 38)."""
    from relight.bench.path import block_test

    ext, _, ref = coat_truth
    result = block_test(mc_runs(renderer, ext, "path", max_depth=2), ref)
    assert result.count > 20 and result.passed, result
