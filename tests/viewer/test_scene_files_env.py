"""Scenes written as TOML (viewer/scene/files.py) with a file environment: no procedural sky keys
(``width``, ``sun_*``), and still loaded back equal; a procedural sky keeps its sun."""
import tomllib
from dataclasses import replace

from assets import ASSET_ROOT

from viewer.environment.maps import EnvironmentSpec
from viewer.scene.description import load_scene
from viewer.scene.files import scene_to_dict, scene_toml

PROCEDURAL_KEYS = {"width", "sun_elevation_deg", "sun_azimuth_deg", "sun_radiance"}
PARK = ASSET_ROOT / "environments" / "park.exr"
GUN = ASSET_ROOT / "models" / "cge_plasma_gun" / "plasma.gltf"


def _round_trip(scene, tmp_path):
    path = tmp_path / "scene.toml"
    path.write_text(scene_toml(scene))
    return replace(load_scene(path), source=scene.source)


def test_relight_scene_with_a_file_environment_has_no_sun_keys(tmp_path, capsys):
    from relight.cli import main

    assert main(["scene", str(GUN), "--env", str(PARK), "--floor"]) == 0
    text = capsys.readouterr().out
    env = tomllib.loads(text)["environment"]
    assert env["path"] == str(PARK.resolve()) and not PROCEDURAL_KEYS & set(env)
    (tmp_path / "s.toml").write_text(text)
    scene = load_scene(tmp_path / "s.toml")
    assert scene.environment == EnvironmentSpec(path=str(PARK.resolve()))
    assert _round_trip(scene, tmp_path) == scene  # and it writes itself back the same


def test_file_environment_round_trips_equal(tmp_path):
    scene = load_scene(ASSET_ROOT / "scenes" / "gallery.toml")
    assert scene.environment.path is not None
    scene = scene.with_environment(rotation_deg=40.0, intensity=1.5)
    doc = scene_to_dict(scene)
    assert not PROCEDURAL_KEYS & set(doc["environment"])
    assert _round_trip(scene, tmp_path) == scene


def test_file_environment_leaves_inert_sun_values_out(tmp_path):
    """Sun values a file environment carries (the viewer keeps them when a file is dropped on a
    sky) do nothing for the file: they are not written, and load back as the defaults."""
    scene = load_scene(ASSET_ROOT / "scenes" / "gallery.toml")
    scene = scene.with_environment(sun_elevation_deg=10.0, sun_radiance=5.0, width=128)
    assert not PROCEDURAL_KEYS & set(scene_to_dict(scene)["environment"])
    back = _round_trip(scene, tmp_path)
    defaults = EnvironmentSpec()
    assert back.environment == replace(scene.environment, width=defaults.width,
                                       sun_elevation_deg=defaults.sun_elevation_deg,
                                       sun_radiance=defaults.sun_radiance)
    assert replace(back, environment=scene.environment) == scene


def test_procedural_sky_keeps_its_sun(tmp_path):
    scene = load_scene(ASSET_ROOT / "scenes" / "demo.toml").with_environment(
        path=None, procedural="sky", sun_elevation_deg=12.5, sun_azimuth_deg=-40.0, width=256)
    env = scene_to_dict(scene)["environment"]
    assert env["sun_elevation_deg"] == 12.5 and env["sun_azimuth_deg"] == -40.0
    assert env["width"] == 256 and "path" not in env
    assert _round_trip(scene, tmp_path) == scene
