"""What loading an environment warns about: nothing for the bundled HDRIs (their files hold no
negative, NaN or Inf texels, so the loader has nothing to clamp and no tutorial render prints a
warning), and display-referred images named with the right article ("an 8-bit", "a 16-bit")."""
import warnings

import numpy as np
import OpenImageIO as oiio
import pytest
from assets import ASSET_ROOT

from viewer.environment.maps import EnvironmentSpec, load_environment
from viewer.imageio import read_image

BUNDLED = sorted(p for p in (ASSET_ROOT / "environments").iterdir()
                 if p.suffix.lower() in (".exr", ".hdr"))


def test_every_bundled_environment_is_found():
    names = {p.name for p in BUNDLED}
    assert {"sky.exr", "park.exr", "esplanade.exr", "studio.exr", "lobby.exr"} <= names


@pytest.mark.parametrize("path", BUNDLED, ids=lambda p: p.name)
def test_bundled_environment_loads_without_a_warning(path):
    raw, _ = read_image(path)
    assert np.isfinite(raw).all() and raw.min() >= 0.0  # the file itself, before any clamp
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # any warning fails the test
        env = load_environment(EnvironmentSpec(path=str(path)))
    assert env.shape == (256, 512, 3) and env.dtype == np.float32
    assert np.array_equal(env, raw[:, :, :3])  # nothing was changed on the way in


def _write_display_image(path, bits: int) -> None:
    kind = oiio.UINT8 if bits == 8 else oiio.UINT16
    top = 255 if bits == 8 else 65535
    pixels = np.random.default_rng(bits).integers(0, top + 1, (16, 32, 3))
    pixels = pixels.astype(np.uint8 if bits == 8 else np.uint16)
    out = oiio.ImageOutput.create(str(path))
    assert out.open(str(path), oiio.ImageSpec(32, 16, 3, kind))
    assert out.write_image(pixels)
    out.close()


@pytest.mark.parametrize("bits, phrase", [(8, "an 8-bit image"), (16, "a 16-bit image")])
def test_display_image_warning_has_the_right_article(tmp_path, bits, phrase):
    path = tmp_path / f"env{bits}.png"
    _write_display_image(path, bits)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        load_environment(EnvironmentSpec(path=str(path)))
    messages = [str(w.message) for w in caught]
    assert len(messages) == 1 and f"{path}: {phrase}, decoded from sRGB" in messages[0]
