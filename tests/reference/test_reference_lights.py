"""``relight reference`` with the scene's punctual lights (relight/reference/lights.py) against
physics: a Lambertian floor under each light kind against the closed-form radiance
albedo / pi x irradiance, per pixel, with a Bonferroni z-test on the reference's own standard
errors (false-alarm rate <= 1 % per test); and the rasteriser against the reference on the same
scene. Each test also shows it can fail: the same check against a slightly wrong answer fails."""
import math
import warnings

import numpy as np
import pytest

from relight.reference import ReferenceOptions, render_reference
from relight.reference.compare import Reference, score, z_test
from relight.reference.lights import mitsuba_light, spot_texture
from viewer.lighting.lights import Light
from viewer.scene.description import scene_from_dict

ALBEDO = 0.5
ENV = 0.1       # a dim white environment: its share is ALBEDO x ENV on an upward floor
HEIGHT = 3.0    # the camera, straight above the floor's centre
FOV = 60.0
FLOAT = 2e-4    # relative floor of the z-tests: float32 rounding of Mitsuba's sums (< 1e-5 rel)


def _floor_scene(light: dict, size: int = 32, env: float = ENV):
    return scene_from_dict({
        "camera": {"position": [0.0, HEIGHT, 1e-3], "target": [0.0, 0.0, 0.0], "fov_y": FOV,
                   "size": [size, size]},
        "environment": {"procedural": "white", "width": 64, "intensity": env},
        "render": {"multiscatter": False, "ao": False, "tonemap": "none",
                   "background": "transparent", "shadows": False},
        "objects": [{"type": "plane", "center": [0.0, 0.0, 0.0], "size": [20.0, 20.0],
                     "material": {"albedo": [ALBEDO] * 3, "specular": 0.0}}],
        "lights": [light]})


def _floor_points(scene) -> np.ndarray:
    """``[H, W, 3]`` where each pixel-centre ray meets the floor y = 0."""
    cam = scene.camera
    d = cam.view_rays_ws().astype(np.float64)
    o = np.asarray(cam.position, np.float64)
    return o + (-o[1] / d[..., 1:2]) * d


def _expected(irradiance: np.ndarray, env: float = ENV) -> np.ndarray:
    """``[H, W, 4]``: a Lambertian floor's radiance (albedo / pi x irradiance + albedo x env)."""
    img = np.ones(irradiance.shape + (4,))
    img[..., :3] = (ALBEDO / math.pi * irradiance + ALBEDO * env)[..., None]
    return img


def _check(ref: Reference, irradiance: np.ndarray, wrong: float = 1.03):
    """The reference equals the closed form per pixel (z-test) and in total (its energy bias
    within 4 of its noise), and the closed form off by ``wrong`` is rejected in total."""
    expected = _expected(irradiance)
    floor = FLOAT * float(expected[..., :3].max())
    right = z_test(expected, ref, floor=floor)
    assert right.passed, right
    s = score(expected, ref)
    assert abs(s.bias) < 4.0 * s.bias_noise + FLOAT, s
    off = score(_expected(irradiance * wrong), ref)
    assert abs(off.bias) > 4.0 * off.bias_noise + FLOAT, off


def _point_irradiance(p: np.ndarray, position, intensity: float) -> np.ndarray:
    to = np.asarray(position, np.float64) - p
    d2 = (to * to).sum(-1)
    return intensity * to[..., 1] / np.sqrt(d2) / d2  # I cos(theta) / d^2


def test_point_light_floor_is_inverse_square(mitsuba_llvm):
    """A point light 1 m above a Lambertian floor: albedo / pi x I cos(theta) / d^2 under it and
    to the side (the 32^2 view spans +-1.7 m: cos^3 falls to 0.19), with Mitsuba's ``point``
    intensity (W/sr) = our candela-like intensity one to one."""
    light = {"type": "point", "position": [0.2, 1.0, -0.1], "intensity": 2.0,
             "color": [1.0, 1.0, 1.0]}
    scene = _floor_scene(light)
    ref = render_reference(scene, ReferenceOptions(spp=64, max_depth=2), progress=False)
    irr = _point_irradiance(_floor_points(scene), light["position"], light["intensity"])
    assert irr.max() / irr.min() > 5.0  # the view reaches well to the side
    _check(ref, irr)


def gltf_spot_attenuation(cos_angle, inner_deg: float, outer_deg: float):
    """KHR_lights_punctual's angular attenuation, as the extension's README gives its reference
    implementation (written here, not taken from the code under test):

        lightAngleScale = 1.0f / max(0.001f, cos(innerConeAngle) - cos(outerConeAngle));
        lightAngleOffset = -cos(outerConeAngle) * lightAngleScale;
        float cd = dot(spotlightDir, normalizedLightVector);
        float angularAttenuation = saturate(cd * lightAngleScale + lightAngleOffset);
        angularAttenuation *= angularAttenuation;
    """
    cos_inner, cos_outer = math.cos(math.radians(inner_deg)), math.cos(math.radians(outer_deg))
    scale = 1.0 / max(0.001, cos_inner - cos_outer)
    offset = -cos_outer * scale
    a = np.clip(np.asarray(cos_angle, np.float64) * scale + offset, 0.0, 1.0)
    return a * a


def test_spot_texture_is_the_gltf_cone():
    """The bitmap the reference hands Mitsuba's ``spot`` (its ``texture``) holds glTF's cone at
    each texel's direction (uv = 0.5 + 0.5 (x, y) / (z tan cutoff), the cutoff the outer angle):
    float32 rounding, measured 2.8e-8. Fails for a linear t (no square), a cone in the angle instead
    of its cosine, or inner and outer swapped."""
    n, inner, outer = 64, 20.0, 40.0
    tex = spot_texture(inner, outer, n)
    c = (np.arange(n) + 0.5) / n * 2.0 - 1.0
    x, y = np.meshgrid(c, c)
    cos_angle = 1.0 / np.sqrt(1.0 + (x * x + y * y) * math.tan(math.radians(outer)) ** 2)
    want = gltf_spot_attenuation(cos_angle, inner, outer)
    assert ((want > 0.05) & (want < 0.95)).sum() > 500 and want.max() == 1.0  # in the falloff
    np.testing.assert_allclose(tex, np.repeat(want[..., None], 3, -1), atol=1e-6)


def test_spot_texture_check_fails_on_a_linear_cone(monkeypatch):
    """The check above against a deliberately broken cone factor (t instead of t^2)."""
    from relight.reference import lights

    monkeypatch.setattr(lights, "spot_cone_factor", lambda c, o, i: np.clip(
        (c - o) / max(i - o, 1e-3), 0.0, 1.0))
    with pytest.raises(AssertionError, match="Not equal to tolerance"):
        test_spot_texture_is_the_gltf_cone()


def test_spot_light_cone_is_gltf(mitsuba_llvm):
    """A spot light straight down, inner 20 deg, outer 40: the floor follows glTF's cone factor
    (:func:`gltf_spot_attenuation`, the extension's reference implementation) everywhere: 0
    outside the outer cone's circle (r = tan 40 m), full inside the inner one; Mitsuba's own
    linear-in-angle falloff does not pass."""
    light = {"type": "spot", "position": [0.0, 1.0, 0.0], "direction": [0.0, 1.0, 0.0],
             "intensity": 2.0, "inner_cone_deg": 20.0, "outer_cone_deg": 40.0}
    scene = _floor_scene(light)
    ref = render_reference(scene, ReferenceOptions(spp=64, max_depth=2), progress=False)
    p = _floor_points(scene)
    irr = _point_irradiance(p, light["position"], light["intensity"])
    cos_angle = 1.0 / np.sqrt(1.0 + p[..., 0] ** 2 + p[..., 2] ** 2)
    cone = gltf_spot_attenuation(cos_angle, 20.0, 40.0)
    r = np.hypot(p[..., 0], p[..., 2])
    lit = ref.radiance[..., 0] - ALBEDO * ENV  # the spot's share, +- the environment's noise
    noise = 5.0 * ref.stderr[..., 0] + 1e-6
    edge = math.tan(math.radians(40.0))
    assert (np.abs(lit) < noise)[r > edge * 1.02].all()  # dark past the cone's edge
    assert (lit > noise)[r < edge * 0.9].all()           # lit inside it
    _check(ref, irr * cone)
    angle = np.degrees(np.arccos(np.clip(cos_angle, -1.0, 1.0)))
    linear = np.clip((40.0 - angle) / 20.0, 0.0, 1.0)  # Mitsuba's spot without our texture
    assert not z_test(_expected(irr * linear), ref,
                      floor=FLOAT * float(irr.max())).passed


@pytest.mark.parametrize("diameter", [0.0, 8.0])
def test_directional_light_floor_irradiance(mitsuba_llvm, diameter):
    """A directional light 30 deg from the zenith: irradiance E cos(theta) on the floor, for a
    delta (diameter 0: Mitsuba's ``directional``) and for an 8 deg disc (the far disc of
    relight/reference/lights.py: a uniform cap above the horizon gives exactly E cos(theta))."""
    theta = math.radians(30.0)
    light = {"type": "directional", "direction": [math.sin(theta), math.cos(theta), 0.0],
             "intensity": 3.0, "angular_diameter_deg": diameter}
    scene = _floor_scene(light)
    ref = render_reference(scene, ReferenceOptions(spp=64, max_depth=2), progress=False)
    _check(ref, np.full(ref.radiance.shape[:2], 3.0 * math.cos(theta)))


def test_range_is_traced_without_it_with_a_warning(mitsuba_llvm):
    mi, _, _ = mitsuba_llvm
    light = Light(type="point", position=(0.0, 1.0, 0.0), intensity=2.0, range=3.0)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        d = mitsuba_light(light, mi, where="scene.toml")
    assert d["type"] == "point"
    text = [str(w.message) for w in caught]
    assert len(text) == 1 and "range = 3.0" in text[0] and "\n" not in text[0], text


@pytest.mark.parametrize("light", [
    {"type": "point", "position": [0.2, 1.0, -0.1], "intensity": 2.0},
    {"type": "spot", "position": [0.0, 1.0, 0.0], "direction": [0.0, 1.0, 0.0],
     "intensity": 2.0, "inner_cone_deg": 20.0, "outer_cone_deg": 40.0},
    {"type": "directional", "direction": [0.5, 0.866, 0.0], "intensity": 3.0},
], ids=["point", "spot", "directional"])
def test_rasteriser_matches_reference_under_punctual_light(mitsuba_llvm, renderer, light):
    """The rasteriser (default model) against the path tracer on the same Lambertian floor with no
    environment: both evaluate the same closed form, so they agree to float32 rounding (measured:
    6e-6 of the peak for point and spot; the test's floor is 1e-4 of it). The directional light's
    default 0.53 deg disc is sampled (far disc): it differs by that sampling noise, which the
    z-test's per-pixel standard errors carry."""
    scene = _floor_scene(light, env=0.0)
    # 64 samples: the disc's per-pixel standard error (7e-5 here) is itself estimated well enough
    ref = render_reference(scene, ReferenceOptions(spp=64, max_depth=2), progress=False)
    image = renderer.render(scene).radiance
    result = z_test(image, ref, floor=1e-4 * float(ref.radiance[..., :3].max()))
    assert result.passed, result
