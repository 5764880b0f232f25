"""``[environment] sun_strength`` (viewer/environment/maps.py scale_sun): the compact sun's
light scaled in the map itself, so the viewer, the path model and the reference see the same
sky. What changes (only the sun's texels, energy linear in the strength, no compact light left at
0), what is refused, what keys it keeps (the caches' and the reference's at the default), and
that the viewer lights a sunless sky exactly as it lights the same map saved without its sun."""
import math
import warnings

import numpy as np
import pytest

from viewer.environment.maps import EnvironmentSpec, load_environment, scale_sun
from viewer.environment.sun import extract_lights, texel_solid_angles
from viewer.errors import SceneError
from viewer.imageio import write_exr
from viewer.renderer import Renderer
from viewer.scene.description import scene_from_dict

SKY = {"procedural": "sky", "width": 256, "sun_radiance": 2e4, "sun_elevation_deg": 40.0}


def _energy(env: np.ndarray) -> np.ndarray:
    h, w = env.shape[:2]
    return (env.astype(np.float64) * texel_solid_angles(h, w)[:, None, None]).sum((0, 1))


def test_only_the_suns_texels_change_and_its_energy_scales_linearly():
    full = load_environment(EnvironmentSpec(**SKY))
    assert extract_lights(full)[1]  # the sky has its sun
    maps = {s: load_environment(EnvironmentSpec(**SKY, sun_strength=s)) for s in (0.0, 0.5, 2.0)}
    changed = np.any(maps[0.0] != full, axis=2)
    # the sun's region: a few dozen texels of the 256 x 128, nothing else moves
    assert 0 < changed.sum() < 200
    for s, env in maps.items():
        np.testing.assert_array_equal(env[~changed], full[~changed])
        # E(s) = E(0) + s (E(1) - E(0)): the sun's light times s, the sky's kept
        want = _energy(maps[0.0]) + s * (_energy(full) - _energy(maps[0.0]))
        np.testing.assert_allclose(_energy(env), want, rtol=1e-5)
    # the sun carried most of the sky's light (2e4 radiance); at 0 no compact light is left
    assert _energy(maps[0.0]).sum() < 0.5 * _energy(full).sum()
    assert extract_lights(maps[0.0])[1] == ()
    # 1 is the map itself
    np.testing.assert_array_equal(load_environment(EnvironmentSpec(**SKY, sun_strength=1.0)),
                                  full)


def test_a_bundled_hdri_loses_every_compact_light_at_zero():
    """esplanade.exr: two lamps near the zenith, then a third that passes the share rule once
    they are gone (scale_sun's rounds); none is left."""
    from assets import ASSET_ROOT

    path = str(ASSET_ROOT / "environments" / "esplanade.exr")
    env = load_environment(EnvironmentSpec(path=path, sun_strength=0.0))
    assert extract_lights(env)[1] == ()
    ratio = _energy(env).sum() / _energy(load_environment(EnvironmentSpec(path=path))).sum()
    assert 0.3 < ratio < 0.8, ratio


def test_a_map_without_a_sun_is_left_as_it_is_with_one_warning_naming_it():
    white = load_environment(EnvironmentSpec(procedural="white", width=64))
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        env = scale_sun(white, 0.0, "white")
        np.testing.assert_array_equal(
            load_environment(EnvironmentSpec(procedural="white", width=64, sun_strength=0.0)),
            white)
    np.testing.assert_array_equal(env, white)
    messages = [str(w.message) for w in caught]
    assert len(messages) == 2 and all(m.startswith("white: no compact sun found") and
                                       "changes nothing" in m for m in messages), messages


@pytest.mark.parametrize("bad", [-1.0, math.nan, math.inf, True, "0"])
def test_bad_strengths_are_refused_in_one_line(bad):
    with pytest.raises(ValueError, match="sun_strength must be a finite number >= 0"):
        EnvironmentSpec(procedural="sky", sun_strength=bad)
    if not isinstance(bad, (bool, str)) and math.isfinite(bad):
        with pytest.raises(SceneError, match="environment.sun_strength") as err:
            scene_from_dict({"environment": {"procedural": "sky", "sun_strength": bad}})
        assert "\n" not in str(err.value)


def test_the_default_keeps_every_key_made_before_it(tmp_path):
    """At 1 the spec's repr is what it was before the setting (the reference's config_key and
    the gallery's truth cache hash it); any other value changes the reference's key and the
    environment's disk key."""
    from relight.reference.keys import config_key
    from relight.reference.render import ReferenceOptions
    from viewer.environment.ibl import IBLOptions
    from viewer.environment.store import EnvironmentStore

    assert "sun_strength" not in repr(EnvironmentSpec(procedural="sky"))
    scene = scene_from_dict({"environment": SKY})
    opts = ReferenceOptions()
    key = config_key(scene, opts)
    assert config_key(scene.with_environment(sun_strength=1.0), opts) == key
    assert config_key(scene.with_environment(sun_strength=0.0), opts) != key
    assert EnvironmentSpec(**SKY) != EnvironmentSpec(**SKY, sun_strength=0.0)  # memory key
    store = EnvironmentStore.__new__(EnvironmentStore)  # only _disk_key: the disk cache and options
    store.disk, store.options = object(), IBLOptions()
    spec = EnvironmentSpec(**SKY)
    assert store._disk_key(spec) != store._disk_key(EnvironmentSpec(**SKY, sun_strength=0.0))


@pytest.fixture(scope="module")
def renderer(ctx):
    r = Renderer(ctx=ctx)
    yield r
    r.release()


def _sphere_on_floor(env: dict):
    return scene_from_dict({
        "camera": {"position": [0, 2.0, 4.0], "target": [0, 0.3, 0], "fov_y": 40,
                   "size": [64, 48]},
        "environment": env,
        "objects": [{"type": "sphere", "center": [0, 0.5, 0], "radius": 0.5,
                     "material": {"albedo": [0.8, 0.4, 0.2], "roughness": 0.4}},
                    {"type": "plane", "center": [0, 0, 0], "size": [8, 8],
                     "material": {"albedo": [0.5, 0.5, 0.5], "roughness": 0.9}}],
        "render": {"raytrace": False, "tonemap": "none", "background": "transparent"}})


def test_the_viewer_lights_a_sunless_sky_as_the_same_map_saved_without_its_sun(renderer, tmp_path):
    """The sky at strength 0 renders exactly as an EXR of that map does (the same IBL, no sun light and
    no sun shadow map), and darker than the sky with its sun, most of all on the floor the sun
    lit; at strength 1 the sun light is compiled in."""
    sunless = load_environment(EnvironmentSpec(**SKY, sun_strength=0.0))
    path = tmp_path / "sunless.exr"
    write_exr(path, sunless)
    file_scene = _sphere_on_floor({"path": str(path)})
    scene = _sphere_on_floor({**SKY, "sun_strength": 0.0})
    drawn = renderer.draw(scene)
    assert drawn.variant.defines["SUN_LIGHT"] == 0
    assert renderer.draw(_sphere_on_floor(SKY)).variant.defines["SUN_LIGHT"] == 1
    img = renderer.render(scene).radiance
    ref = renderer.render(file_scene).radiance
    np.testing.assert_array_equal(img, ref)  # the same map: the same IBL, bit for bit
    lit = renderer.render(_sphere_on_floor(SKY)).radiance
    fg = img[..., 3] > 0.99
    assert img[..., :3][fg].sum() < 0.5 * lit[..., :3][fg].sum()


def test_the_reference_sees_the_same_sunless_map():
    """relight reference's envmap bitmap is made from load_environment: at strength 0 it holds
    the sky without the sun (its brightest texel a sky texel, not the 2e4 sun)."""
    from relight.reference.scene import environment_bitmap

    full = environment_bitmap(scene_from_dict({"environment": SKY}))
    dark = environment_bitmap(scene_from_dict({"environment": {**SKY, "sun_strength": 0.0}}))
    assert full.max() > 1e3 and dark.max() < 50.0, (full.max(), dark.max())
