"""Anti-aliasing against a supersampled truth: a bright silhouette (an unlit slanted quad, an unlit
sphere) on a black background at 64x64, its edge pixels compared with the same frame rendered at
8 x 8 supersampling (``ssaa = 8``; a 4 x 4 truth would make ``ssaa = 4`` exact by construction).
Errors: mean |display - truth| over the pixels the truth covers partly (0.01 < coverage < 0.99),
in linear light (the displayed sRGB bytes decoded).

Measured on llvmpipe (``pytest tests/viewer/test_antialias.py -s`` prints them):

    quad:   none 0.153, fxaa 0.066 (2.3x less), ssaa 2 0.042, ssaa 4 0.019 (7.8x less)
    sphere: none 0.139, fxaa 0.065 (2.1x less), ssaa 2 0.064, ssaa 4 0.020 (6.9x less)
"""
import numpy as np
import pytest
import torch
from scipy import ndimage

from learned.twins.tonemap import srgb_to_linear
from viewer.errors import SceneError
from viewer.renderer import Renderer
from viewer.scene.description import scene_from_dict

WHITE = {"albedo": [0.9, 0.9, 0.9]}
SHAPES = {
    "quad": {"type": "plane", "center": [0, 0, 0], "size": [0.9, 0.9],
             "normal": [0.35, 0.2, 1.0], "material": WHITE},
    "sphere": {"type": "sphere", "center": [0, 0, 0], "radius": 0.5, "material": WHITE},
}


def _scene(shape, **render):
    return scene_from_dict({
        "camera": {"position": [0, 0, 3], "target": [0, 0, 0], "fov_y": 30, "size": [64, 64]},
        "environment": {"procedural": "white", "intensity": 0.0},
        "objects": [SHAPES[shape]], "render": {"model": "unlit", **render}})


@pytest.fixture(scope="module")
def renderer(ctx):
    r = Renderer(ctx=ctx)
    yield r
    r.release()


def _linear(frame):
    return srgb_to_linear(torch.tensor(frame.display[..., :3] / 255.0)).numpy()


@pytest.mark.parametrize("shape", list(SHAPES))
def test_fxaa_halves_and_ssaa_quarters_the_edge_error(renderer, shape):
    truth = renderer.render(_scene(shape, ssaa=8))
    coverage = truth.radiance[..., 3]
    edge = (coverage > 0.01) & (coverage < 0.99)
    assert edge.sum() > 60  # a silhouette, not a handful of pixels
    ref = _linear(truth)

    def error(**render):
        frame = renderer.render(_scene(shape, **render))
        return float(np.abs(_linear(frame) - ref).mean(-1)[edge].mean())
    none, fxaa = error(aa="none"), error(aa="fxaa")
    ssaa2, ssaa4 = error(ssaa=2), error(ssaa=4)
    print(shape, f"none {none:.3f}, fxaa {fxaa:.3f} ({none / fxaa:.1f}x less), ssaa 2 "
                 f"{ssaa2:.3f}, ssaa 4 {ssaa4:.3f} ({none / ssaa4:.1f}x less)")
    assert fxaa <= none / 2.0
    assert ssaa4 <= none / 4.0 and ssaa4 < ssaa2 < none


def test_fxaa_leaves_a_flat_interior_alone(renderer):
    plain = renderer.render(_scene("quad", aa="none"))
    fxaa = renderer.render(_scene("quad", aa="fxaa"))
    inside = ndimage.binary_erosion(plain.radiance[..., 3] >= 1.0, iterations=2)
    outside = ndimage.binary_erosion(plain.radiance[..., 3] <= 0.0, iterations=2)
    assert inside.sum() > 300 and outside.sum() > 1000
    for region in (inside, outside):  # more than two pixels from the silhouette
        np.testing.assert_array_equal(fxaa.display[region], plain.display[region])
    assert (fxaa.display != plain.display).any()  # the silhouette itself was filtered


def test_supersampling_resolves_radiance_and_aovs_at_the_output_size(renderer):
    frame = renderer.render(_scene("sphere", ssaa=3), aovs=("albedo", "normal", "depth", "alpha"))
    one = renderer.render(_scene("sphere"), aovs=("depth",))
    assert frame.radiance.shape == (64, 64, 4) and frame.display.shape == (64, 64, 4)
    for name, channels in (("albedo", 3), ("normal", 3), ("depth", 1), ("alpha", 1)):
        assert frame.aovs[name].shape == (64, 64, channels), name
    alpha = frame.aovs["alpha"][..., 0]
    # the G-buffer coverage is box-filtered as the radiance's alpha is
    np.testing.assert_allclose(alpha, frame.radiance[..., 3], atol=1e-6)
    assert ((alpha > 0.0) & (alpha < 1.0)).sum() > 60
    n = np.linalg.norm(frame.aovs["normal"], axis=-1)
    np.testing.assert_allclose(n[alpha > 0.0], 1.0, atol=1e-5)
    inside = ndimage.binary_erosion(alpha >= 1.0, iterations=2)
    # depth is point-sampled: inside the silhouette it is the 1x frame's to within the offset
    np.testing.assert_allclose(frame.aovs["depth"][inside], one.aovs["depth"][inside], rtol=2e-3)


@pytest.mark.parametrize("render, message", [
    ({"aa": "msaa"}, "render.aa = 'msaa' is not one of fxaa, none"),
    ({"ssaa": 0}, "render.ssaa must be an integer in [1, 8]"),
    ({"ssaa": 16}, "render.ssaa must be an integer in [1, 8]"),
    ({"ssaa": 2.0}, "render.ssaa must be an integer in [1, 8]"),
])
def test_bad_aa_settings_are_one_line_errors(render, message):
    with pytest.raises(SceneError, match=message.replace("[", r"\[").replace("]", r"\]")):
        _scene("quad", **render)


def test_the_frame_declares_the_aa_passes_it_needs(renderer):
    def names(**render):
        return [p.name for p in renderer.graph(_scene("quad", **render)).passes]
    assert names()[-2:] == ["tonemap", "fxaa"]  # the default: FXAA
    assert names(aa="none")[-1] == "tonemap" and "fxaa" not in names(aa="none")
    # supersampled: resolved before tone mapping, and no FXAA on its filtered edges
    assert names(ssaa=2)[-2:] == ["ssaa_resolve", "tonemap"]
