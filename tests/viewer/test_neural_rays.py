"""The neural student under the default render's rays (issue 36 item 3, towards issue 38): its
irradiance and prefiltered inputs are the rays' and its screen-space visibility input S(x) is not
computed, so the speckle it drew from S(x)'s noise on real assets is gone.

Scene: the gallery's textured glTF (the plasma gun) on its floor under lobby.exr (no compact
light: the HDRI where the student's screen-space speckle was worst). The floor's high-frequency
energy (mean |luminance - its 3x3 median|) is compared with split-sum's under the same rays: the
path-traced reference cannot be the yardstick here, its own Monte-Carlo noise is 10x larger.
Measured (llvmpipe, 144 x 96): student with rays 0.0036, split-sum with rays 0.0036, student
without rays 0.0135 (the failure this guards against)."""
import warnings

import pytest

from assets import ASSET_ROOT
from relight.bench.real_assets_metrics import speckle
from viewer.renderer import Renderer
from viewer.scene.description import load_scene

SIZE = (144, 96)


@pytest.fixture(scope="module")
def renderer(ctx):
    r = Renderer(ctx=ctx)
    yield r
    r.release()


def _scene():
    return load_scene(ASSET_ROOT / "scenes" / "gallery.toml").with_environment(
        path=str(ASSET_ROOT / "environments" / "lobby.exr"), rotation_deg=0.0)


def _speckle(frame, floor) -> float:
    return speckle(frame.radiance, floor)  # the real-asset bench's measure


def test_the_student_under_rays_draws_no_speckle_on_the_floor(renderer):
    scene = _scene().with_render(tonemap="none")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the gun's skins and animations are not used
        split = renderer.render(scene.with_render(model="ggx_split_sum"), size=SIZE,
                                aovs=("normal",))
        floor = (split.aovs["normal"][..., 1] > 0.99) & (split.radiance[..., 3] > 0.5)
        student = renderer.render(scene.with_render(model="neural"), size=SIZE)
        screen = renderer.render(scene.with_render(model="neural", raytrace=False), size=SIZE)
    assert floor.sum() > 2000
    ours, base, old = _speckle(student, floor), _speckle(split, floor), _speckle(screen, floor)
    print(f"floor speckle: student {ours:.4f}, split-sum {base:.4f}, student without rays {old:.4f}")
    assert ours <= 1.15 * base, (ours, base)
    assert old > 2.0 * ours, (old, ours)  # the check can fail: it does on the old inputs
