"""viewer.environment.maps: loading equirect files and procedural environments."""
import warnings

import numpy as np
import pytest

from viewer.environment.maps import (
    EnvironmentSpec,
    _pow2,
    load_environment,
    resample,
    texel_directions,
)
from viewer.errors import InputError, SceneError
from viewer.imageio import write_exr


def _load(path):
    return load_environment(EnvironmentSpec(path=str(path)))


def test_exr_round_trip(tmp_path):
    rng = np.random.default_rng(0)
    env = rng.uniform(0.0, 50.0, size=(32, 64, 3)).astype(np.float32)
    write_exr(tmp_path / "env.exr", env)
    got = _load(tmp_path / "env.exr")
    assert got.dtype == np.float32 and got.shape == (32, 64, 3)
    np.testing.assert_array_equal(got, env)


def test_alpha_dropped_and_grey_expanded(tmp_path):
    rgba = np.random.default_rng(1).uniform(size=(16, 32, 4)).astype(np.float32)
    write_exr(tmp_path / "rgba.exr", rgba)
    np.testing.assert_array_equal(_load(tmp_path / "rgba.exr"), rgba[:, :, :3])
    grey = rgba[:, :, :1].copy()
    write_exr(tmp_path / "grey.exr", grey, channel_names=["Y"])
    np.testing.assert_array_equal(_load(tmp_path / "grey.exr"), np.repeat(grey, 3, axis=2))


def test_resampled_to_nearest_power_of_two(tmp_path):
    env = np.random.default_rng(2).uniform(0.5, 1.5, size=(40, 80, 3)).astype(np.float32)
    write_exr(tmp_path / "odd.exr", env)
    got = _load(tmp_path / "odd.exr")
    assert got.shape == (32, 64, 3)
    assert abs(got.mean() - env.mean()) < 0.01
    assert _pow2(80) == 64 and _pow2(96) == 128 and _pow2(5000) == 2048 and _pow2(1) == 4


def test_integer_shrink_is_an_area_average():
    img = np.arange(8 * 16 * 3, dtype=np.float32).reshape(8, 16, 3)
    got = resample(img, 8, 4)
    np.testing.assert_allclose(got, img.reshape(4, 2, 8, 2, 3).mean(axis=(1, 3)))


def test_bad_texels_zeroed_with_one_warning(tmp_path):
    env = np.ones((16, 32, 3), np.float32)
    env[0, 0, 0] = np.nan
    env[1, 2, 1] = -3.0
    env[5, 5, :] = np.inf
    path = tmp_path / "bad.exr"
    write_exr(path, env)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        got = _load(path)
    assert len(caught) == 1
    message = str(caught[0].message)
    assert "bad.exr" in message and "5 " in message
    assert np.isfinite(got).all() and got.min() == 0.0
    assert got[0, 0, 0] == 0 and got[1, 2, 1] == 0 and (got[5, 5] == 0).all()
    assert got[3, 3, 0] == 1.0


def test_all_zero_environment_is_allowed(tmp_path):
    write_exr(tmp_path / "black.exr", np.zeros((8, 16, 3), np.float32))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert (_load(tmp_path / "black.exr") == 0).all()


def test_truncated_exr_is_an_input_error(tmp_path):
    path = tmp_path / "cut.exr"
    write_exr(path, np.random.default_rng(3).uniform(size=(64, 128, 3)).astype(np.float32))
    data = path.read_bytes()
    path.write_bytes(data[: len(data) // 2])
    with pytest.raises(InputError, match="cut.exr"):
        _load(path)


def test_garbage_file_is_an_input_error(tmp_path):
    path = tmp_path / "junk.exr"
    path.write_bytes(b"not an image at all" * 10)
    with pytest.raises(InputError, match="junk.exr"):
        _load(path)


def test_wrong_aspect_is_an_input_error(tmp_path):
    write_exr(tmp_path / "square.exr", np.ones((32, 32, 3), np.float32))
    with pytest.raises(InputError, match="2:1"):
        _load(tmp_path / "square.exr")


@pytest.mark.parametrize("name", ["sky", "studio", "white"])
def test_procedural_environments(name):
    env = load_environment(EnvironmentSpec(procedural=name, width=128))
    assert env.shape == (64, 128, 3) and env.dtype == np.float32
    assert np.isfinite(env).all() and env.min() >= 0.0


def test_white_is_one_and_width_rounds_to_power_of_two():
    env = load_environment(EnvironmentSpec(procedural="white", width=100))
    assert env.shape == (64, 128, 3)
    assert (env == 1.0).all()


def test_sky_sun_is_bright_and_where_asked():
    env = load_environment(EnvironmentSpec(procedural="sky", width=256, sun_elevation_deg=30.0,
                                           sun_azimuth_deg=90.0))
    lum = env.mean(axis=2)
    row, col = np.unravel_index(np.argmax(lum), lum.shape)
    d = texel_directions(256)[row, col]
    assert lum[row, col] > 500.0 * np.median(lum)
    # azimuth 90 = +X, elevation 30: direction (cos 30, sin 30, 0)
    assert np.dot(d, [np.cos(np.radians(30)), 0.5, 0.0]) > np.cos(np.radians(3.0))


def test_texel_directions_follow_the_convention():
    d = texel_directions(8)  # u = (i + 0.5) / 8; column 4 starts at u = 0.5 (-Z), column 6 at +X
    assert d.shape == (4, 8, 3)
    assert (d[0, :, 1] > 0.9).all() and (d[-1, :, 1] < -0.9).all()  # row 0: zenith (+Y)
    mid = texel_directions(1024)[256, 512]  # v ~ 0.5, u ~ 0.5
    np.testing.assert_allclose(mid, [0.0, 0.0, -1.0], atol=1e-2)
    east = texel_directions(1024)[256, 768]
    np.testing.assert_allclose(east, [1.0, 0.0, 0.0], atol=1e-2)


def test_unknown_procedural_is_a_scene_error():
    with pytest.raises(SceneError, match="nebula"):
        load_environment(EnvironmentSpec(procedural="nebula"))
    with pytest.raises(SceneError):
        load_environment(EnvironmentSpec())
