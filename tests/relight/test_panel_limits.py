"""The settings panel's slider ranges (``relight.app.panels.choices.LIMITS``) are the ranges the
scene checks accept (``viewer.scene.checks``): both ends are valid, one step beyond each is
refused with a one-line error naming the key, so a slider can reach every valid value and
none that the render would refuse."""
import pytest

from relight.app.panels.choices import LIMITS
from viewer.errors import SceneError
from viewer.scene.description import load_scene

# a slider's useful range, narrower than what a scene may set: exposure beyond +-10 stops, more
# samples than 65536 (the checks take any finite exposure and any positive count)
UNCHECKED = {"exposure", "samples"}


@pytest.mark.parametrize("key", sorted(set(LIMITS) - UNCHECKED))
def test_a_slider_reaches_exactly_the_valid_values(key):
    scene = load_scene("assets/scenes/reference/park_sphere_on_plane.toml")
    lo, hi = LIMITS[key]
    scene.with_render(**{key: lo})
    scene.with_render(**{key: hi})
    for bad in (lo - 1, hi + 1):
        with pytest.raises(SceneError, match=key) as err:
            scene.with_render(**{key: bad})
        assert "\n" not in str(err.value)
