"""The neural student's floor speckle on a real asset (issue 36 item 3, issue 38): under the
default render's rays its irradiance and prefiltered inputs are the rays'; without rays the
shipped student's network reads no screen-space evidence (``features = "ssao"``), so neither
draws more speckle than split-sum with the same evidence. The student shipped before, whose
network read the SSAO pass's S(x) and O(x), does without rays: the check can fail.

Scene: the gallery's textured glTF (the plasma gun) on its floor under lobby.exr (no compact
light: the HDRI where the student's screen-space speckle was worst). The floor's high-frequency
energy (mean |luminance - its 3x3 median|) is compared with split-sum's under the same rays: the
path-traced reference cannot be the yardstick here, its own Monte-Carlo noise is 10x larger.
Measured (llvmpipe, 144 x 96): student with rays 0.0048, split-sum with rays 0.0048; without rays
(the bounce denoised, the default) student 0.0026, split-sum 0.0026, the S(x) student 0.0112 (the
failure this guards against)."""
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


def test_the_student_draws_no_speckle_on_the_floor(renderer):
    from relight.bench.real_assets_cases import sx_student_file

    scene = _scene().with_render(tonemap="none")
    screen = {"raytrace": False, "ssao": True, "indirect": True}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the gun's skins and animations are not used
        split = renderer.render(scene.with_render(model="ggx_split_sum"), size=SIZE,
                                aovs=("normal",))
        floor = (split.aovs["normal"][..., 1] > 0.99) & (split.radiance[..., 3] > 0.5)
        student = renderer.render(scene.with_render(model="neural"), size=SIZE)
        split_screen = renderer.render(scene.with_render(model="ggx_split_sum", **screen),
                                       size=SIZE)
        screen_student = renderer.render(scene.with_render(model="neural", **screen), size=SIZE)
        sx_student = renderer.render(scene.with_render(
            model="neural", weights=str(sx_student_file()), **screen), size=SIZE)
    assert floor.sum() > 2000
    ours, base = _speckle(student, floor), _speckle(split, floor)
    ours_s, base_s, old = (_speckle(f, floor) for f in (screen_student, split_screen, sx_student))
    print(f"floor speckle: rays: student {ours:.4f}, split-sum {base:.4f}; screen-space: "
          f"student {ours_s:.4f}, split-sum {base_s:.4f}, the S(x) student {old:.4f}")
    assert ours <= 1.15 * base, (ours, base)
    assert ours_s <= 1.15 * base_s, (ours_s, base_s)  # the real-asset bench's tolerance
    assert old > 2.0 * base_s, (old, base_s)  # the check can fail: it does on the old inputs
