"""Whole-pipeline physics: white furnace, diffuse albedo, exposure, rotation, background, caching."""
import numpy as np
import pytest

from viewer.renderer import Renderer
from viewer.scene.description import ObjectSpec, Scene, scene_from_dict
from viewer.scene.material import Material

SIZE = (64, 64)


@pytest.fixture(scope="module")
def renderer(ctx):
    r = Renderer(ctx=ctx)
    yield r
    r.release()


def sphere_scene(material: Material, env="white", **render) -> Scene:
    scene = scene_from_dict({
        "camera": {"position": [0, 0, 3.5], "fov_y": 40, "size": list(SIZE)},
        "environment": {"procedural": env},
        "render": {"tonemap": "none", **render},
    })
    return Scene(camera=scene.camera, environment=scene.environment, render=scene.render,
                 objects=(ObjectSpec("sphere", material=material),))


@pytest.mark.parametrize("roughness", [0.0, 0.045, 0.2, 0.5, 0.8, 1.0])
def test_white_furnace_metal(renderer, roughness):
    """Plumbing: a metallic f0 = 1 sphere in a constant white environment equals the background
    (within 1%) at every roughness with multiple scattering on. Measured: max deviation 2e-7.
    An identity, not a check of the BRDF: energy compensation divides the DFG term out, so it
    holds for any DFG table (a wrong roughness-to-table mapping passes it exactly); it checks the
    pass wiring, the environment's unit radiance and the background. The DFG table itself is held
    to an independent quadrature in tests/shaders/test_furnace_quadrature.py."""
    scene = sphere_scene(Material(albedo=(1, 1, 1), metallic=1.0, roughness=roughness))
    frame = renderer.render(scene)
    rgb, alpha = frame.radiance[..., :3], frame.radiance[..., 3]
    on = alpha > 0
    assert on.sum() > 0.25 * on.size
    np.testing.assert_allclose(rgb[on], 1.0, atol=0.01)
    np.testing.assert_allclose(rgb[~on], 1.0, atol=1e-6)  # background is the environment


def test_single_scattering_loses_energy_at_high_roughness(renderer):
    """Without compensation a rough metal is darker than the furnace: at r = 1 and normal
    incidence the single-scattering albedo is 0.307 (brute-force quadrature of the same BRDF; the
    centre pixel renders 0.3071 from the 64x64 LUT); at r = 0.045 almost no energy is lost (the
    centre renders 1.0). The whole sphere at three roughness values, each channel of a coloured
    conductor, is held to the quadrature in tests/shaders/test_furnace_quadrature.py."""
    rough = renderer.render(sphere_scene(Material(albedo=(1, 1, 1), metallic=1.0, roughness=1.0),
                                         multiscatter=False)).radiance
    smooth = renderer.render(sphere_scene(Material(albedo=(1, 1, 1), metallic=1.0, roughness=0.045),
                                          multiscatter=False)).radiance
    centre = (SIZE[1] // 2, SIZE[0] // 2)
    assert 0.29 < rough[centre][0] < 0.33
    assert smooth[centre][0] > 0.97


@pytest.mark.parametrize("rho", [0.18, 0.5, 1.0])
def test_diffuse_sphere_renders_its_albedo(renderer, rho):
    """A Lambertian albedo-rho sphere (no specular lobe) in a unit white environment renders rho
    everywhere: E = pi from 9-coefficient SH is exact for a constant. Measured: 3e-7. (No DFG
    term is involved: f0 = 0 compiles the specular lobe out.)"""
    scene = sphere_scene(Material(albedo=(rho, rho, rho), specular=0.0, roughness=0.5))
    frame = renderer.render(scene)
    on = frame.radiance[..., 3] > 0
    np.testing.assert_allclose(frame.radiance[..., :3][on], rho, rtol=0.01)


def test_blinn_phong_furnace_is_bounded(renderer):
    """Plumbing: the normalised lobe reflects f0 of a unit furnace whatever its shape (the
    prefiltered radiance of a constant is that constant), so this checks the energy split
    diffuse (1 - f0) + f0, not the lobe."""
    scene = sphere_scene(Material(albedo=(0.5, 0.5, 0.5), roughness=0.3), model="blinn_phong")
    rad = renderer.render(scene).radiance
    on = rad[..., 3] > 0
    # Lambert 0.5 (1 - 0.04) + f0 0.04: energy conserving under a unit furnace
    np.testing.assert_allclose(rad[..., :3][on], 0.5 * 0.96 + 0.04, atol=1e-5)


def test_intensity_scales_radiance_linearly(renderer):
    base = sphere_scene(Material(albedo=(0.6, 0.4, 0.2), roughness=0.4), env="sky")
    a = renderer.render(base).radiance
    b = renderer.render(base.with_environment(intensity=2.5)).radiance
    np.testing.assert_allclose(b[..., :3], 2.5 * a[..., :3], rtol=1e-5, atol=1e-6)


def test_exposure_changes_display_not_radiance(renderer):
    # without FXAA, whose edge tests on perceptual luma see each exposure differently
    base = sphere_scene(Material(roughness=0.4), env="sky", tonemap="none", aa="none")
    a = renderer.render(base.with_render(exposure=-3.0))
    b = renderer.render(base.with_render(exposure=-2.0))
    np.testing.assert_array_equal(a.radiance, b.radiance)
    # doubling the exposure doubles linear display values (check in the unclipped range)
    lin = lambda d: np.where(d / 255.0 <= 0.04045, d / 255.0 / 12.92,
                             ((d / 255.0 + 0.055) / 1.055) ** 2.4)
    da, db = lin(a.display[..., :3].astype(float)), lin(b.display[..., :3].astype(float))
    mask = (da > 0.05) & (db < 0.9)
    assert mask.sum() > 100
    np.testing.assert_allclose(db[mask], 2.0 * da[mask], rtol=0.03)


def test_rotation_moves_the_environment(renderer):
    """Rotating the environment by +90 deg brings what was at -Z (the view centre) to -X."""
    scene = scene_from_dict({"camera": {"position": [0, 0, 0], "target": [0, 0, -1], "fov_y": 10,
                                        "size": [16, 16]},
                             "environment": {"procedural": "sky"},
                             "render": {"tonemap": "none"}})
    left = scene_from_dict({"camera": {"position": [0, 0, 0], "target": [-1, 0, 0], "fov_y": 10,
                                       "size": [16, 16]},
                            "environment": {"procedural": "sky", "rotation_deg": 90},
                            "render": {"tonemap": "none"}})
    a = renderer.render(scene).radiance
    b = renderer.render(left).radiance
    np.testing.assert_allclose(b, a, rtol=1e-4, atol=1e-5)


def test_transparent_background(renderer):
    scene = sphere_scene(Material(), env="sky", background="transparent")
    rad = renderer.render(scene).radiance
    off = rad[..., 3] == 0
    assert off.any() and np.all(rad[..., :3][off] == 0)


def test_caches_geometry_and_ibl(renderer):
    scene = sphere_scene(Material(), env="studio")
    renderer.render(scene)
    n_programs, n_ibl = len(renderer.programs), renderer.resources.environments
    renderer.render(scene.with_render(exposure=1.0).with_environment(intensity=3.0,
                                                                     rotation_deg=20))
    assert len(renderer.programs) == n_programs and renderer.resources.environments == n_ibl


@pytest.mark.parametrize("roughness", [0.0, 0.3, 1.0])
@pytest.mark.parametrize("specular", [0.5, 1.0])
def test_white_furnace_dielectric(renderer, roughness, specular):
    """Plumbing: a white dielectric (albedo 1) reflects exactly what it receives with multiscatter
    on: the diffuse lobe keeps 1 - E_spec of the compensated specular albedo. Measured: 2.4e-7.
    An identity for any DFG table (diffuse + specular = 1 by construction); the table is checked
    against quadrature in tests/shaders/test_furnace_quadrature.py."""
    scene = sphere_scene(Material(albedo=(1, 1, 1), roughness=roughness, specular=specular))
    rad = renderer.render(scene).radiance
    on = rad[..., 3] > 0
    np.testing.assert_allclose(rad[..., :3][on], 1.0, atol=1e-3)
