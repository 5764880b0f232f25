"""Shadow casters only (``shadow_only = true``): an object in the shadow maps and the rays but not
in the G-buffer, the proxy geometry of what an image-space stack shows. Judged against the same
scene with the object seen: the floor around it is the same floor, shadow included, to float
rounding; without the caster that shadow is gone; the camera sees the floor, not the sphere,
where the sphere would stand; its material never specialises the lighting pass; the key is
refused where it means nothing, and the path tracer refuses it in one line. A splat cloud can be
a caster only too."""
import numpy as np
import pytest
from scipy import ndimage
from shadow_scenes import CAMERA, DARK, FLOOR, SPHERE, floor_points, sphere_pixels

from viewer.errors import SceneError
from viewer.renderer import Renderer
from viewer.scene.description import scene_from_dict
from viewer.scene.files import scene_toml
from viewer.specialize import analyse

DIRECTION = [1.0, 1.0, 0.0]
CASTER = {**SPHERE, "shadow_only": True,
          "material": {"albedo": [0.9, 0.1, 0.1], "metallic": 1.0, "roughness": 0.2}}


@pytest.fixture(scope="module")
def renderer(ctx):
    r = Renderer(ctx=ctx)
    yield r
    r.release()


def scene(objects, **render):
    return scene_from_dict({
        "camera": CAMERA, "environment": DARK,
        "lights": [{"type": "directional", "direction": DIRECTION, "intensity": 3.0}],
        "objects": objects, "render": {"tonemap": "none", "raytrace": False, **render}})


def _floor_only_pixels():
    x, z = floor_points()
    return ~sphere_pixels(x, z)


@pytest.mark.parametrize("raytrace", [False, True], ids=["shadow maps", "rays"])
def test_a_caster_only_shadows_the_floor_as_the_seen_object_does(renderer, raytrace):
    """Outside the sphere's own pixels the floor with the caster equals the floor with the seen
    sphere (the same maps or rays; 1e-5 relative: float rounding of one shading pass), and it
    holds a shadow the floor alone does not (at least 200 pixels darker by half); inside them
    the caster scene shows the floor, the seen scene the red metal. With rays the comparison
    leaves out a band of 16 px around the sphere's pixels: the denoiser's a-trous footprint
    (viewer.passes.rt_light.FILTER_STEPS 1, 2, 4 of a 5 x 5 kernel: 14 px) stops at the seen
    sphere's edge and not at the floor's (measured: 0.49 relative at the edge, 5e-3 at 12 px,
    4e-5 beyond 16 px)."""
    seen = renderer.render(scene([FLOOR, {**CASTER, "shadow_only": False}],
                                 raytrace=raytrace)).radiance[..., :3]
    caster = renderer.render(scene([FLOOR, CASTER], raytrace=raytrace)).radiance[..., :3]
    bare = renderer.render(scene([FLOOR], raytrace=raytrace)).radiance[..., :3]
    keep = _floor_only_pixels()
    if raytrace:
        keep = ~ndimage.binary_dilation(~keep, iterations=16)
    np.testing.assert_allclose(caster[keep], seen[keep], rtol=1e-4 if raytrace else 1e-5,
                               atol=1e-6)
    shadow = _floor_only_pixels() & (caster[..., 0] < 0.5 * bare[..., 0])
    assert shadow.sum() > 200
    x, z = floor_points()
    inside = sphere_pixels(x, z)
    # the grey floor under the sphere (with rays, tinted a little by the red metal's bounce:
    # measured r / g 1.04), where the seen sphere is red (measured r / g 4.8)
    r_over_g = [im[inside][:, 0].mean() / im[inside][:, 1].mean() for im in (caster, seen)]
    assert r_over_g[0] < 1.1 and r_over_g[1] > 3.0, r_over_g


def test_a_splat_cloud_casts_only(renderer):
    """A splat sphere as a caster only: the G-buffer's albedo is the bare floor's everywhere
    (exactly: the splat pass draws nothing), where the seen cloud's is not, and the floor holds
    the cloud's shadow (its analytic core under a tenth of the bare floor, as
    tests/viewer/test_shadows.py asks of a seen cloud)."""
    import dataclasses

    from shadow_scenes import CENTER, RADIUS
    from test_shadows import analytic_shadow

    from viewer.scene.description import ObjectSpec
    from viewer.splats.generate import sphere_splats

    cloud = sphere_splats(3000, radius=RADIUS)
    cloud = dataclasses.replace(cloud, means=cloud.means + CENTER.astype(np.float32))
    seen_obj = ObjectSpec(type="splats", path="in-memory-splat-caster")
    renderer.add_geometry(seen_obj, cloud)
    # added once: the geometry cache's key leaves shadow_only out (the switch loads nothing)
    caster_obj = dataclasses.replace(seen_obj, shadow_only=True)
    base = scene([FLOOR])

    def render(*extra):
        sc = dataclasses.replace(base, objects=base.objects + extra)
        return renderer.render(sc, aovs=("albedo",))

    bare, seen, caster = render(), render(seen_obj), render(caster_obj)
    # the splat pass's colour channel only where a cloud is seen
    layout = lambda *extra: renderer.specialization(
        dataclasses.replace(base, objects=base.objects + extra)).layout.with_color
    assert layout(seen_obj) and not layout(caster_obj)
    np.testing.assert_array_equal(caster.aovs["albedo"], bare.aovs["albedo"])
    assert np.abs(seen.aovs["albedo"] - bare.aovs["albedo"]).max() > 0.05
    x, z = floor_points()
    core = ndimage.binary_erosion(analytic_shadow(DIRECTION, x, z), iterations=3)
    assert core.sum() > 100
    lit, free = caster.radiance[..., 0], bare.radiance[..., 0]
    assert np.median(lit[core] / np.maximum(free[core], 1e-6)) < 0.1


def test_a_casters_material_does_not_specialise_the_lighting_pass(renderer):
    """The floor has no specular lobe (specular 0, dielectric); a metal sphere seen turns the
    lobe on, the same sphere as a caster only does not (its material is never shaded)."""
    matte = {**FLOOR, "material": {"albedo": [0.5, 0.5, 0.5], "roughness": 0.9,
                                   "specular": 0.0}}
    seen = analyse(renderer, scene([matte, {**CASTER, "shadow_only": False}]))
    caster = analyse(renderer, scene([matte, CASTER]))
    assert seen.specular and not caster.specular
    assert caster.meshes  # the shadow maps still have something to draw


def test_the_key_is_checked_and_saved(tmp_path):
    """A bool on spheres, planes, grids and meshes; one line naming the key otherwise; not with
    a shadow catcher; a saved scene loads back with it."""
    s = scene([FLOOR, CASTER])
    assert s.objects[1].shadow_only and not s.objects[0].shadow_only
    text = scene_toml(s)
    assert "shadow_only = true" in text
    path = tmp_path / "s.toml"
    path.write_text(text)
    from viewer.scene.description import load_scene

    assert load_scene(path).objects == s.objects
    with pytest.raises(SceneError, match="shadow_only must be true or false"):
        scene([{**SPHERE, "shadow_only": 1}])
    with pytest.raises(SceneError, match="both a shadow catcher and shadow_only"):
        scene([{**FLOOR, "catcher": True, "shadow_only": True}])
    with pytest.raises(SceneError, match="shadow_only"):
        scene([{"type": "gbuffer", "path": str(tmp_path), "shadow_only": True}])


def test_the_reference_refuses_a_caster_only():
    from relight.reference.scene import ReferenceError, check_traceable

    with pytest.raises(ReferenceError, match="shadow caster only") as err:
        check_traceable(scene([FLOOR, CASTER]))
    assert "objects[1]" in str(err.value) and "\n" not in str(err.value)
    check_traceable(scene([FLOOR, SPHERE]))
