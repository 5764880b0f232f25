"""Published glTF assets, as their authors made them, rendered headlessly (issue 13: "a real-world
glTF with emission, alpha-masked and blended parts and texture transforms renders as authored").
No one published file has all four, so three do (sources and licences: each folder's README.md):

- ``assets/models/texture_transform_test``: Khronos' TextureTransformTest (CC0, Microsoft), whose
  README says what a correct renderer shows; shipped by Debian's ``assimp-testmodels``.
- ``assets/models/cge_base_level``: a Castle Game Engine demo level made in Blender: an
  alpha-MASKed fence, a BLENDed glass booth (baseColorFactor alpha 0.6), opaque parts.
- ``assets/models/cge_plasma_gun``: a plasma gun from OpenGameArt with an emissive texture.

Each assertion compares the render with what the file itself prescribes, against copies of the
file that differ in one material field (written to tmp_path with absolute resource paths).
"""
import copy
import json
import warnings
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from viewer.geometry.loaders import load_mesh
from viewer.geometry.mesh import srgb_to_linear
from viewer.renderer import Renderer
from viewer.scene.description import scene_from_dict

MODELS = Path(__file__).resolve().parents[2] / "assets" / "models"
TT = MODELS / "texture_transform_test" / "TextureTransformTest.gltf"
LEVEL = MODELS / "cge_base_level" / "levels" / "base_level.gltf"
GUN = MODELS / "cge_plasma_gun" / "plasma.gltf"


@pytest.fixture(scope="module")
def renderer(ctx):
    r = Renderer(ctx=ctx)
    yield r
    r.release()


def _render(renderer, path, camera, size, model="unlit", intensity=1.0, aovs=()):
    scene = scene_from_dict({
        "camera": {**camera, "size": [size, size]},
        "environment": {"procedural": "sky", "intensity": intensity, "width": 64},
        "objects": [{"type": "mesh", "path": str(path)}],
        # no rays: with them the gun's glowing parts light its others (the tier's bounce), and
        # these tests read each surface's own terms
        "render": {"model": model, "tonemap": "none", "raytrace": False}})
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the loader's warnings are checked on their own below
        frame = renderer.render(scene, aovs=aovs)
    assert not np.isnan(frame.radiance).any()
    for name in aovs:
        assert not np.isnan(frame.aovs[name]).any(), name
    return frame


def _variant(tmp_path, src: Path, name: str, edit) -> Path:
    """A copy of ``src`` in tmp_path, its resources referred to by absolute path, after
    ``edit(doc)``."""
    doc = json.loads(src.read_text())
    for item in doc.get("buffers", []) + doc.get("images", []):
        if "uri" in item and not item["uri"].startswith("data:"):
            item["uri"] = str((src.parent / item["uri"]).resolve())
    doc = copy.deepcopy(doc)
    edit(doc)
    out = tmp_path / f"{name}.gltf"
    out.write_text(json.dumps(doc))
    return out


def _material(doc, name):
    (m,) = [m for m in doc["materials"] if m.get("name") == name]
    return m


@pytest.mark.parametrize("path, ignored", [
    (TT, None),
    (LEVEL, None),  # its KHR_lights_punctual lights are loaded (tests/viewer/test_lights.py)
    (GUN, "animations; attribute JOINTS_0; attribute WEIGHTS_0; skins")],
    ids=["texture_transform_test", "cge_base_level", "cge_plasma_gun"])
def test_loads_with_only_the_expected_warning(path, ignored):
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        meshes = load_mesh(path)
    messages = [str(w.message) for w in caught]
    want = [] if ignored is None else [f"{path}: ignored (not supported): {ignored}"]
    assert messages == want
    assert meshes and all(np.isfinite(m.positions).all() for m in meshes)


# ---- TextureTransformTest -----------------------------------------------------------------------
TT_SIZE = 192
TT_CAMERA = {"position": [0.0, 0.0, 5.0], "target": [0.0, 0.0, 0.0], "fov_y": 40.0}


def _tt_pixel(x, y, z=0.0):
    """(row, column) of the point (x, y, z) seen by TT_CAMERA."""
    half = (5.0 - z) * np.tan(np.radians(20.0))
    return (int((1.0 - (y / half + 1.0) / 2.0) * TT_SIZE), int((x / half + 1.0) / 2.0 * TT_SIZE))


@pytest.fixture(scope="module")
def tt_frame(renderer):
    return _render(renderer, TT, TT_CAMERA, TT_SIZE, aovs=("albedo", "alpha"))


def _uv_png_quadrant_colours():
    """The background colour of each quadrant of UV.png (sRGB-decoded): the most frequent one."""
    rgb = np.asarray(Image.open(TT.parent / "UV.png").convert("RGB"))
    h, w = rgb.shape[:2]
    out = {}
    for name, (r, c) in {"none": (0, 0), "u": (0, 1), "v": (1, 0), "uv": (1, 1)}.items():
        q = rgb[r * h // 2:(r + 1) * h // 2, c * w // 2:(c + 1) * w // 2].reshape(-1, 3)
        values, counts = np.unique(q, axis=0, return_counts=True)
        out[name] = srgb_to_linear(values[counts.argmax()] / 255.0)
    return out


@pytest.mark.parametrize("quad_x, quadrant", [(-1.1, "u"), (0.0, "v"), (1.1, "uv")],
                         ids=["offset_u", "offset_v", "offset_uv"])
def test_texture_transform_offsets_show_the_checked_quadrant(tt_frame, quad_x, quadrant):
    """README: the top row maps uv (0, 0)-(0.5, 0.5) offset by (0.5, 0), (0, 0.5), (0.5, 0.5);
    "a yellow image indicates that offset was not applied"."""
    colours = _uv_png_quadrant_colours()
    r0, c0 = _tt_pixel(quad_x - 0.45, 1.0)
    r1, c1 = _tt_pixel(quad_x + 0.45, 0.1)
    region = tt_frame.aovs["albedo"][r0:r1, c0:c1].reshape(-1, 3)
    # the quadrant's background colour covers most of the square (the tick and letter are white)
    near = np.abs(region - colours[quadrant]).max(axis=1) < 0.02
    assert near.mean() > 0.6, near.mean()
    assert (np.abs(region - colours["none"]).max(axis=1) < 0.05).mean() < 0.01  # no yellow


def _markers():
    """Centres of the marker quads, by name, from the loaded file."""
    out = {}
    for m in load_mesh(TT):
        if m.name.endswith("Marker"):
            out.setdefault(m.name, []).append(m.positions.mean(axis=0))
    return out


@pytest.mark.parametrize("quad_x, others", [(-1.1, ("Not Supported Marker", "Error Marker")),
                                            (0.0, ("Not Supported Marker",)),
                                            (1.1, ())],
                         ids=["rotation", "scale", "all"])
def test_texture_transform_arrow_points_at_the_green_marker(tt_frame, quad_x, others):
    """README: rotation 22.5 degrees, scale 1.5, and all three: "the green marker indicates the
    correct rotation/scale", yellow "not applied", red "applied in the opposite direction";
    "the arrow should point to the green marker"."""
    markers = _markers()

    def in_quad(p):  # each marker belongs to the quad whose centre is nearest
        return min((-1.1, 0.0, 1.1), key=lambda c: abs(p[0] - c)) == quad_x

    (green,) = [p for p in markers["Correct Marker"] if in_quad(p)]
    wrong = [p for name in others for p in markers[name] if in_quad(p)]
    assert len(wrong) == len(others)
    albedo = tt_frame.aovs["albedo"]
    r0, c0 = _tt_pixel(quad_x - 0.5, -0.05)
    r1, c1 = _tt_pixel(quad_x + 0.5, -1.05)
    covered = tt_frame.aovs["alpha"][r0:r1, c0:c1, 0] > 0  # not the (dark) ground behind
    black = np.argwhere((albedo[r0:r1, c0:c1].max(axis=2) < 0.05) & covered) + np.int64([r0, c0])
    assert len(black) > 30  # the arrow is there

    # the arrow's two ends: the black pixels farthest apart; its tip: the end with the head
    # (more black pixels around it than around the tail)
    d = np.hypot(*(black[:, None, :] - black[None, :, :]).transpose(2, 0, 1))
    ends = black[list(np.unravel_index(d.argmax(), d.shape))]
    length = d.max()
    mass = [(np.hypot(*(black - e).T) < 0.25 * length).sum() for e in ends]
    tip = ends[int(np.argmax(mass))]

    def distance(p):
        return float(np.hypot(*(tip - np.float64(_tt_pixel(*p)))))

    # the tip is at the green marker (0.1-0.15 wide: 5-8 pixels), well away from the others
    assert distance(green) < 12.0, distance(green)
    for p in wrong:
        assert distance(p) > 2.0 * distance(green), (distance(p), distance(green))


# ---- Castle Game Engine level: MASK fence, BLEND glass ------------------------------------------
LEVEL_SIZE = 160
LEVEL_CAMERA = {"position": [6.0, 4.0, 6.0], "target": [0.0, 0.5, 0.0], "fov_y": 50.0}


def _level(renderer, path):
    return _render(renderer, path, LEVEL_CAMERA, LEVEL_SIZE).radiance[..., :3]


def test_masked_fence_is_cut_at_the_cutoff(renderer, tmp_path):
    """Material.001 (the fence): alphaMode MASK, alphaCutoff 0.5, fence.png's alpha. Every fence
    pixel is either the fence drawn opaque or what is behind it (no blending), and the texels
    below the cutoff are cut."""
    authored = _level(renderer, LEVEL)
    opaque = _level(renderer, _variant(tmp_path, LEVEL, "fence_opaque", lambda d: _material(
        d, "Material.001").update(alphaMode="OPAQUE")))
    gone = _level(renderer, _variant(tmp_path, LEVEL, "fence_gone", lambda d: _material(
        d, "Material.001").update(alphaCutoff=1.01)))
    fence = np.abs(opaque - gone).max(axis=2) > 1e-3
    assert fence.sum() > 200, fence.sum()
    is_opaque = np.abs(authored - opaque).max(axis=2)[fence] < 1e-5
    is_gone = np.abs(authored - gone).max(axis=2)[fence] < 1e-5
    assert (is_opaque | is_gone).mean() > 0.99, (is_opaque | is_gone).mean()
    # fence.png has holes (alpha 0) among its bars: both kinds of pixel are there. (Their shares
    # differ from the texels' since the sampler mipmaps: far away the thin bars average below
    # the cutoff, as in any MASK renderer.)
    alpha = np.asarray(Image.open(LEVEL.parent.parent / "textures" / "fence.png").convert("RGBA"))
    assert 0.05 < (alpha[..., 3] >= 128).mean() < 0.95
    assert 0.05 < is_opaque.mean() < 0.95, is_opaque.mean()  # kept: MASK is not ignored...
    assert is_gone.mean() > 0.05  # ...nor everything cut
    # outside the fence the level is unchanged by it
    np.testing.assert_array_equal(authored[~fence], opaque[~fence])


def test_blended_glass_is_sixty_percent_over_what_is_behind(renderer, tmp_path):
    """MatBudka (the booth's glass): alphaMode BLEND, baseColorFactor (0.8, 0.8, 0.8, 0.6),
    unlit here so a layer's colour is 0.8. Seen through k glass walls (k = 1 or 2) a pixel is
    0.8 (1 - 0.4^k) + 0.4^k x behind."""
    authored = _level(renderer, LEVEL)
    behind = _level(renderer, _variant(tmp_path, LEVEL, "glass_gone", lambda d: _material(
        d, "MatBudka")["pbrMetallicRoughness"]["baseColorFactor"].__setitem__(3, 0.0)))
    opaque = _level(renderer, _variant(tmp_path, LEVEL, "glass_opaque", lambda d: _material(
        d, "MatBudka").update(alphaMode="OPAQUE")))
    glass = np.abs(opaque - behind).max(axis=2) > 1e-3
    assert glass.sum() > 100, glass.sum()
    np.testing.assert_allclose(opaque[glass], 0.8, atol=1e-5)  # unlit: the factor's colour
    one = 0.8 * 0.6 + 0.4 * behind[glass]
    two = 0.8 * 0.84 + 0.16 * behind[glass]
    got = authored[glass]
    err1 = np.abs(got - one).max(axis=1)
    err2 = np.abs(got - two).max(axis=1)
    assert (np.minimum(err1, err2) < 1e-4).mean() > 0.97
    assert (err1 < 1e-4).mean() > 0.1 and (err2 < 1e-4).mean() > 0.1  # both walls are seen
    np.testing.assert_array_equal(authored[~glass], behind[~glass])


# ---- plasma gun: emissive texture ------------------------------------------------------------------
GUN_SIZE = 128
GUN_CAMERA = {"position": [1.0, 0.0, 0.8], "target": [-0.35, -0.26, 0.78], "fov_y": 50.0}


def test_emissive_texture_glows_under_a_black_environment(renderer, tmp_path):
    """The gun's material: emissiveFactor (1, 1, 1) x plasma_emission.png. Under a black
    environment a lit model shows exactly the emission: where the texture is black nothing, the
    rest in the texture's colours; with the factor zeroed the gun is black."""
    lit = _render(renderer, GUN, GUN_CAMERA, GUN_SIZE, model="ggx_split_sum", intensity=0.0,
                  aovs=("emission", "alpha"))
    covered = lit.aovs["alpha"][..., 0] > 0
    assert covered.sum() > 500, covered.sum()
    rgb = lit.radiance[..., :3]
    np.testing.assert_allclose(rgb, lit.aovs["emission"], rtol=1e-5, atol=1e-7)
    assert rgb[~covered].max() == 0.0
    glowing = rgb.max(axis=2) > 0.05
    # the texture, not a constant: part of the gun glows, part stays dark
    assert 0.02 < glowing[covered].mean() < 0.8, glowing[covered].mean()
    # colours: the brightest texels of plasma_emission.png are cyan/green, not red
    texture = srgb_to_linear(np.asarray(Image.open(GUN.parent / "plasma_emission.png")
                                        .convert("RGB")) / 255.0).reshape(-1, 3)
    bright = texture[texture.max(axis=1) > 0.05]
    want = bright.mean(axis=0) / bright.mean(axis=0).sum()
    got = rgb[glowing].mean(axis=0) / rgb[glowing].mean(axis=0).sum()
    np.testing.assert_allclose(got, want, atol=0.12)
    assert rgb.max() <= 1.0 + 1e-6 and rgb.max() > 0.5

    dark = _render(renderer, _variant(tmp_path, GUN, "no_emission", lambda d: d["materials"][0]
                                      .update(emissiveFactor=[0.0, 0.0, 0.0])),
                   GUN_CAMERA, GUN_SIZE, model="ggx_split_sum", intensity=0.0)
    assert dark.radiance[..., :3].max() == 0.0
