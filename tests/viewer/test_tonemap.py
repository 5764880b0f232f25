"""Tone mappers: Khronos PBR Neutral against its published formula (values computed here by hand,
not through the twin), and the displayed colour of a Lambertian sphere under a white environment
(a white furnace: its radiance is its albedo) against the albedo's own colour, in CIELAB.

Measured on llvmpipe (CIELAB hue angle h_ab and chroma C*_ab of the displayed pixels against the
sRGB swatch of the albedo; ``pytest tests/viewer/test_tonemap.py -s`` prints them):

    albedo (0.85, 0.55, 0.25): pbr_neutral dh 0.1 deg, C* +6 %; aces dh 5.3 deg, C* -22 %
                               (the beige/tan reading); agx dh 1.6 deg, C* -53 %
    albedo (0.80, 0.20, 0.20): pbr_neutral dh 0.9 deg, C* +9 %; aces dh 0.9 deg, C* -10 %;
                               agx dh 1.2 deg, C* -46 %
"""
import numpy as np
import pytest
import torch

from learned.twins.tonemap import srgb_to_linear, tonemap_pbr_neutral
from viewer.renderer import Renderer
from viewer.scene.description import scene_from_dict


def _spec_pbr_neutral(r, g, b):
    """KhronosGroup/ToneMapping PBR_Neutral/README.md, written out in plain floats."""
    f90 = 0.04
    k_s, k_d = 0.8 - f90, 0.15
    x = min(r, g, b)
    f = x - x * x / (4 * f90) if x <= 2 * f90 else f90
    p = max(r - f, g - f, b - f)
    if p <= k_s:
        return [r - f, g - f, b - f]
    p_n = 1 - (1 - k_s) ** 2 / (p + 1 - 2 * k_s)
    gg = 1 / (k_d * (p - p_n) + 1)
    return [(c - f) * p_n / p * gg + p_n * (1 - gg) for c in (r, g, b)]


def test_pbr_neutral_twin_matches_the_published_formula():
    # worked by hand: (0.85, 0.55, 0.25): f = 0.04, p = 0.81 > 0.76, p_n = 1 - 0.0576 / 0.29
    p_n = 1 - 0.0576 / 0.29
    g = 1 / (0.15 * (0.81 - p_n) + 1)
    by_hand = [(c - 0.04) * p_n / 0.81 * g + p_n * (1 - g) for c in (0.85, 0.55, 0.25)]
    # (0.05, 0.2, 0.3): the toe, f = 0.05 - 0.05^2 / 0.16 = 0.034375, no compression
    toe = [0.05 - 0.034375, 0.2 - 0.034375, 0.3 - 0.034375]
    # (2, 1, 0.5): p = 1.96, p_n = 1 - 0.0576 / 1.44 = 0.96, g = 1 / 1.15
    bright = [(c - 0.04) * 0.96 / 1.96 / 1.15 + 0.96 * 0.15 / 1.15 for c in (2.0, 1.0, 0.5)]
    cases = {(0.85, 0.55, 0.25): by_hand, (0.05, 0.2, 0.3): toe, (2.0, 1.0, 0.5): bright}
    rng = np.random.default_rng(0)
    for c in rng.uniform(0.0, 4.0, size=(64, 3)):
        cases[tuple(float(v) for v in c)] = _spec_pbr_neutral(*c)
    for c, want in cases.items():
        got = tonemap_pbr_neutral(torch.tensor(c, dtype=torch.float64)).numpy()
        np.testing.assert_allclose(got, want, rtol=1e-12, atol=1e-12, err_msg=str(c))
    assert np.allclose(_spec_pbr_neutral(0.85, 0.55, 0.25), by_hand)


_XYZ = np.array([[0.4124, 0.3576, 0.1805], [0.2126, 0.7152, 0.0722], [0.0193, 0.1192, 0.9505]])


def _lab_hue_chroma(linear_rgb):
    """CIELAB (D65) hue angle (degrees) and chroma of a linear sRGB colour."""
    xyz = _XYZ @ np.asarray(linear_rgb, np.float64) / np.array([0.95047, 1.0, 1.08883])
    f = np.where(xyz > (6 / 29) ** 3, np.cbrt(xyz), xyz / (3 * (6 / 29) ** 2) + 4 / 29)
    a, b = 500 * (f[0] - f[1]), 200 * (f[1] - f[2])
    return float(np.degrees(np.arctan2(b, a))), float(np.hypot(a, b))


@pytest.fixture(scope="module")
def renderer(ctx):
    r = Renderer(ctx=ctx)
    yield r
    r.release()


def _displayed(renderer, albedo, tonemap):
    scene = scene_from_dict({
        "camera": {"position": [0, 0, 3], "target": [0, 0, 0], "fov_y": 30, "size": [32, 32]},
        "environment": {"procedural": "white"},
        "objects": [{"type": "sphere", "center": [0, 0, 0], "radius": 0.6,
                     "material": {"albedo": list(albedo), "roughness": 1.0, "specular": 0.0}}],
        "render": {"tonemap": tonemap, "aa": "none"}})
    frame = renderer.render(scene)
    # a white furnace: the Lambertian sphere's radiance is its albedo everywhere
    np.testing.assert_allclose(frame.radiance[10:22, 10:22, :3],
                               np.broadcast_to(albedo, (12, 12, 3)), atol=2e-3)
    srgb = frame.display[10:22, 10:22, :3].reshape(-1, 3).astype(np.float64).mean(0) / 255.0
    return srgb_to_linear(torch.tensor(srgb)).numpy()


@pytest.mark.parametrize("albedo", [(0.85, 0.55, 0.25), (0.8, 0.2, 0.2)])
def test_pbr_neutral_keeps_a_base_colour_under_a_white_environment(renderer, albedo):
    h0, c0 = _lab_hue_chroma(albedo)
    out = {}
    for tonemap in ("pbr_neutral", "aces", "agx"):
        h, c = _lab_hue_chroma(_displayed(renderer, albedo, tonemap))
        out[tonemap] = (abs((h - h0 + 180) % 360 - 180), c / c0 - 1)
    print(albedo, {k: f"dh {dh:.1f} deg, C* {dc:+.0%}" for k, (dh, dc) in out.items()})
    dh, dc = out["pbr_neutral"]
    assert dh < 1.5 and abs(dc) < 0.12, out
    if albedo == (0.85, 0.55, 0.25):  # ACES turns this orange towards yellow and greys it
        assert out["aces"][0] > 3.0 and out["aces"][1] < -0.15, out
    assert out["aces"][1] < dc and out["agx"][1] < dc  # both lose chroma PBR Neutral keeps
