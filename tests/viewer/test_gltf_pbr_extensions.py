"""glTF PBR material extensions end to end, the dielectric lobe: KHR_materials_ior +
KHR_materials_specular (its F0 colour and F90; emission, unlit and clearcoat:
test_gltf_coat_emission.py). For each: the loader (values, maps, one-line errors, no "ignored" warning), the G-buffer channel only
a scene using it allocates, a white furnace (numpy quadrature of the reference's BSDF), and a grid
of spheres (gltf_spheres.py) rasterised against ``relight reference`` (Mitsuba, our BSDF plugin)
within a stated tolerance, beside a negative control that the tolerance rejects."""

import numpy as np
import pytest
from gltf_builder import GltfBuilder, image, load_warnings, quad
from gltf_spheres import albedo_quadrature, grid_scene, per_sphere, sphere_grid

from viewer.errors import InputError
from viewer.gbuffer import GBufferLayout
from viewer.scene.material import Material, dielectric_f0_ior

IOR_SPECULAR = ["KHR_materials_ior", "KHR_materials_specular"]


@pytest.fixture(scope="module")
def renderer(ctx):
    from viewer.renderer import Renderer

    return Renderer(ctx=ctx)


@pytest.fixture
def dielectric_gbuffer_of(ctx, programs):
    """As conftest's ``gbuffer_of`` (64x64 from (0, 0, 3)) with the dielectric channel."""
    from gltf_builder import SIZE

    from viewer.geometry.loaders import load_mesh
    from viewer.passes.gbuffer import GBufferPass, GBufferTargets
    from viewer.scene.camera import Camera

    layout = GBufferLayout(with_dielectric=True)
    targets = GBufferTargets.create(ctx, layout, (SIZE, SIZE))
    gpass = GBufferPass(programs, layout)
    camera = Camera(position=(0.0, 0.0, 3.0), target=(0.0, 0.0, 0.0), fov_y=40.0,
                    size=(SIZE, SIZE))

    def draw(path):
        targets.clear()
        gpass.draw_meshes(targets, camera, load_mesh(path))
        return targets.read()

    yield draw
    gpass.release()
    targets.release()


def _ior_materials(with_extensions: bool = True) -> list[dict]:
    """Four rough dielectrics: glTF's default lobe (ior 1.5: F0 = 0.04), a high IOR (2.5: F0 =
    0.18), a reddish specular colour at ior 1.8, a specular factor of 0.3 (F0 and F90 scaled),
    all on a dark base so the specular lobe carries the picture."""
    base = {"baseColorFactor": [0.05, 0.08, 0.12, 1.0], "metallicFactor": 0.0,
            "roughnessFactor": 0.3}
    exts = [{"KHR_materials_ior": {"ior": 1.5}},
            {"KHR_materials_ior": {"ior": 2.5}},
            {"KHR_materials_ior": {"ior": 1.8},
             "KHR_materials_specular": {"specularColorFactor": [1.0, 0.3, 0.2]}},
            {"KHR_materials_specular": {"specularFactor": 0.3}}]
    return [{"pbrMetallicRoughness": base, **({"extensions": e} if with_extensions else {})}
            for e in exts]


# ---- KHR_materials_ior + KHR_materials_specular: loader ------------------------------------------
def test_ior_and_specular_load_as_the_dielectric_lobe_without_a_warning(tmp_path):
    path = sphere_grid(tmp_path / "ior.gltf", _ior_materials(), IOR_SPECULAR)
    meshes, messages = load_warnings(path)
    assert messages == []
    mats = [m.material for m in meshes]
    assert [m.ior for m in mats] == [1.5, 2.5, 1.8, 1.5]
    assert mats[2].specular_color == (1.0, 0.3, 0.2) and mats[3].specular_factor == 0.3
    np.testing.assert_allclose(mats[0].dielectric(), (0.04, 0.04, 0.04, 1.0), rtol=1e-12)
    f0 = ((1.8 - 1) / 2.8) ** 2
    np.testing.assert_allclose(mats[2].dielectric(), (f0, 0.3 * f0, 0.2 * f0, 1.0), rtol=1e-12)
    np.testing.assert_allclose(mats[3].dielectric(), (0.012, 0.012, 0.012, 0.3), rtol=1e-12)
    plain, _ = load_warnings(sphere_grid(tmp_path / "plain.gltf", _ior_materials(False)))
    assert all(m.material.ior is None and m.material.dielectric()[3] == -1.0 for m in plain)


def test_the_spec_clamps_f0_and_reads_ior_0_as_infinite():
    assert dielectric_f0_ior(0.0, (1.0, 1.0, 1.0), 0.5) == (0.5, 0.5, 0.5)
    assert dielectric_f0_ior(1.0, (1.0, 1.0, 1.0), 1.0) == (0.0, 0.0, 0.0)
    assert dielectric_f0_ior(1.5, (100.0, 1.0, 0.0), 1.0) == (1.0, 0.04000000000000001, 0.0)


@pytest.mark.parametrize("ext, needle", [
    ({"KHR_materials_ior": {"ior": 0.5}}, "ior = 0.5"),
    ({"KHR_materials_ior": {"ior": "glass"}}, "ior = 'glass'"),
    ({"KHR_materials_specular": {"specularFactor": 1.5}}, "specularFactor = 1.5"),
    ({"KHR_materials_specular": {"specularColorFactor": [1, 1]}}, "specularColorFactor"),
    ({"KHR_materials_specular": {"specularColorFactor": [1, -1, 1]}}, "specularColorFactor"),
    ({"KHR_materials_specular": {"specularTexture": {"index": 7}}}, "specularTexture"),
    ({"KHR_materials_emissive_strength": {"emissiveStrength": -2}}, "emissiveStrength = -2"),
])
def test_bad_extension_values_are_one_line_errors_naming_the_file(tmp_path, ext, needle):
    b = GltfBuilder()
    quad(b, b.material(extensions=ext))
    path = b.save(tmp_path / "bad.gltf")
    with pytest.raises(InputError) as info:
        load_warnings(path)
    msg = str(info.value)
    assert "\n" not in msg and str(path) in msg and needle in msg, msg


def test_specular_maps_multiply_the_factors_in_the_gbuffer(tmp_path, dielectric_gbuffer_of):
    """specularTexture's A scales the factor (F0 and F90), specularColorTexture's RGB (sRGB) the
    colour: a quad whose left half has A = 0.5, colour (255, 128, 0)."""
    b = GltfBuilder()
    spec = b.image(image([[[0, 0, 0, 128], [0, 0, 0, 255]]]),
                   sampler={"magFilter": 9728, "minFilter": 9728})
    color = b.image(image([[[255, 128, 0, 255], [255, 255, 255, 255]]]),
                    sampler={"magFilter": 9728, "minFilter": 9728})
    quad(b, b.material(extensions={"KHR_materials_ior": {"ior": 2.0},
                                   "KHR_materials_specular": {
                                       "specularFactor": 0.8, "specularTexture": {"index": spec},
                                       "specularColorTexture": {"index": color}}}))
    g = dielectric_gbuffer_of(b.save(tmp_path / "maps.gltf"))
    assert "dielectric" in g
    f0 = (1.0 / 3.0) ** 2
    a = 128 / 255
    srgb_half = ((128 / 255 + 0.055) / 1.055) ** 2.4
    left, right = g["dielectric"][32, 16], g["dielectric"][32, 48]
    np.testing.assert_allclose(left, (f0 * 0.8 * a, f0 * srgb_half * 0.8 * a, 0.0, 0.8 * a),
                               rtol=2e-3, atol=1e-6)
    np.testing.assert_allclose(right, (f0 * 0.8, f0 * 0.8, f0 * 0.8, 0.8), rtol=1e-5)


# ---- the G-buffer channel: only where a scene uses it ------------------------------------------
def test_only_scenes_with_the_lobe_allocate_its_channel(tmp_path, renderer):
    from viewer.specialize import analyse, specialise

    ext = grid_scene(sphere_grid(tmp_path / "ior.gltf", _ior_materials(), IOR_SPECULAR), 4)
    plain = grid_scene(sphere_grid(tmp_path / "plain.gltf", _ior_materials(False)), 4)
    f_ext, f_plain = analyse(renderer, ext), analyse(renderer, plain)
    assert f_ext.dielectric and not f_plain.dielectric
    lay_ext = specialise(f_ext, ext.render).layout
    lay_plain = specialise(f_plain, plain.render).layout
    assert "dielectric" in {c.name for c in lay_ext.channels}
    assert "dielectric" not in {c.name for c in lay_plain.channels}
    assert lay_ext.bytes_per_pixel() == lay_plain.bytes_per_pixel() + 16  # one RGBA32F more
    assert GBufferLayout().bytes_per_pixel() == 48
    assert GBufferLayout(with_dielectric=True, dtype="f2").bytes_per_pixel() == 32


# ---- white furnace: the reference's BSDF never creates energy ----------------------------------
@pytest.mark.parametrize("ior, color, factor", [(1.5, (1, 1, 1), 1.0), (3.0, (1, 0.2, 4.0), 1.0),
                                                (0.0, (1, 1, 1), 0.6), (1.0, (1, 1, 1), 1.0)])
@pytest.mark.parametrize("multiscatter", [False, True])
def test_white_furnace_the_dielectric_lobe_keeps_energy(ior, color, factor, multiscatter):
    """A white base under the glTF lobe reflects what it receives and no more: the specular
    albedo E_spec (F0, F90 from the extensions; times the multiple-scattering compensation) plus
    the diffuse's 1 - E_spec is 1 at every n.v, to the quadrature's error (measured max
    |1 - sum| 2.1e-3, max sum 1.00027, at ior 3 with a colour factor of 4 clamped: F0 = 1 in
    blue; bound 3e-3; roughness >= 0.3, where the grid resolves the lobe). A split that took F90
    from Filament's f90_from_f0 while the lobe reflects with the spec's (at ior 1: F0 = 0, F90 =
    1, the lobe's grazing light counted twice) breaks the equality."""
    d = Material(ior=ior, specular_color=color, specular_factor=factor).dielectric()
    for roughness in (0.3, 0.6, 1.0):
        for nov in (0.2, 0.5, 1.0):
            total = albedo_quadrature(d, roughness, nov, multiscatter)
            np.testing.assert_allclose(total, 1.0, atol=3e-3, err_msg=f"{roughness} {nov}")


# ---- spheres against the path-traced reference ---------------------------------------------------
@pytest.fixture(scope="module")
def ior_truth(mitsuba_llvm, tmp_path_factory):
    """The ior/specular grid (with and without the extensions) and its reference (256 spp, direct
    light: max_depth 2; the grid's pitch keeps what neighbours hide small)."""
    from relight.reference import ReferenceOptions, render_reference

    d = tmp_path_factory.mktemp("ior")
    ext = grid_scene(sphere_grid(d / "ior.gltf", _ior_materials(), IOR_SPECULAR), 4)
    plain = grid_scene(sphere_grid(d / "plain.gltf", _ior_materials(False)), 4)
    with pytest.warns(UserWarning, match="single-sided culling"):
        ref = render_reference(ext, ReferenceOptions(spp=256, max_depth=2), progress=False)
    return ext, plain, ref


def test_ior_and_specular_spheres_match_the_reference(ior_truth, renderer):
    """The four dielectrics of :func:`_ior_materials` under the sky (its sun a light), 64 x 64:
    ggx_split_sum against ``relight reference``. Tolerance per sphere: |bias| <= 8 % and median
    per-pixel error <= 8 % (measured: bias -1.0, +5.8, +3.2, +5.0 %; median 3.6, 4.3, 5.2,
    5.7 %: the split-sum's own error plus the reference's noise), and the specular colour's red
    / green ratio within 5 % of the reference's (measured 1.31 vs 1.33). The same file without
    the extensions (Filament's f0 = 0.04 everywhere) fails them: bias -41 % (ior 2.5) and +103 %
    (factor 0.3), median 20 % and a red / green of 0.85 (the coloured one)."""
    ext, plain, ref = ior_truth
    ref = ref.radiance
    ours = per_sphere(renderer.render(ext.with_render(model="ggx_split_sum")).radiance, ref, 4)
    base = per_sphere(renderer.render(plain.with_render(model="ggx_split_sum")).radiance, ref, 4)
    truth = per_sphere(ref, ref, 4)

    def red_green(stats):
        return stats[2][0] / stats[2][1]

    def within(stats, t):
        return abs(stats[0]) <= 0.08 and stats[1] <= 0.08 and \
            abs(red_green(stats) / red_green(t) - 1.0) <= 0.05

    for k, (s, t) in enumerate(zip(ours, truth)):
        assert within(s, t), (k, s, t)
    assert sum(not within(s, t) for s, t in zip(base[1:], truth[1:])) == 3, base


def test_the_path_tracer_converges_to_the_reference_with_the_lobe(ior_truth, renderer):
    """``path`` (direct light: max_depth 2, as the reference's, segments counted alike) on the
    same grid: the per-block
    z-test of tests/reference/test_path_convergence.py (8 seeds x 16 spp) passes with the
    extensions and rejects the file without them (the path tracer's own surface_init then has
    Filament's lobe). Secondary hits read the lobe's factors from the material rows
    (ROW["dielectric"], ``Material.dielectric``): checked here, and by the raytrace parity check."""
    from relight.bench.path import block_test
    from viewer.raytrace.scene import MATERIAL_VEC4S, ROW, material_rows

    ext, plain, ref = ior_truth

    def runs(scene):
        return np.asarray([renderer.render(scene.with_render(
            model="path", samples=16, seed=s, max_depth=2)).radiance for s in range(8)],
            np.float64)

    result = block_test(runs(ext), ref)
    assert result.count > 20 and result.passed, result
    assert not block_test(runs(plain), ref).passed
    meshes = renderer.geometry(ext.objects[0])
    rows = material_rows(meshes, [{} for _ in meshes])
    for k, mesh in enumerate(meshes):
        np.testing.assert_allclose(rows[k * MATERIAL_VEC4S + ROW["dielectric"]],
                                   mesh.material.dielectric(), rtol=1e-6)


def test_neural_models_warn_once_that_they_ignore_the_dielectric_lobe(renderer, tmp_path):
    """A student reads Filament's specular reflectance only: rendering a scene with the glTF
    lobe warns once, on one line naming the extensions; a scene without it does not."""
    import warnings

    import torch

    from learned.export import export
    from learned.neural.student import Student

    torch.manual_seed(0)
    weights = tmp_path / "s.safetensors"
    export(Student(hidden=(8, 8), num_freqs=1), weights)
    ext = grid_scene(sphere_grid(tmp_path / "ior.gltf", _ior_materials()[1:2], IOR_SPECULAR), 1)
    plain = grid_scene(sphere_grid(tmp_path / "plain.gltf", _ior_materials(False)[1:2]), 1)
    for scene, expected in ((plain, 0), (ext, 1), (ext, 0)):  # once per model and process
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            renderer.render(scene.with_render(model="neural", weights=str(weights)))
        lobe = [str(w.message) for w in caught if "dielectric lobe" in str(w.message)]
        assert len(lobe) == expected, lobe
        assert all("\n" not in m and "KHR_materials_specular" in m for m in lobe)
