"""glTF alphaMode BLEND: transparent surfaces through the forward pass after deferred shading
(viewer/passes/forward.py): premultiplied "over", back-to-front order per mesh, depth-tested
against the opaque G-buffer, coverage in the radiance's alpha. Fixtures built here with
pygltflib (the builder in gltf_builder.py)."""
import warnings

import numpy as np
import pytest
from gltf_builder import QUAD_POS, GltfBuilder, image, quad

from viewer.renderer import Renderer
from viewer.scene.description import scene_from_dict

SIZE = 48
CENTRE = (SIZE // 2, SIZE // 2)  # (row, column): the point (0, 0) of every quad below
RED, GREEN, BLUE = (1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0)


@pytest.fixture
def renderer(ctx):
    r = Renderer(ctx=ctx)
    yield r
    r.release()


def _material(b, color, alpha=1.0, mode="OPAQUE", **extra):
    return b.material(pbrMetallicRoughness={"baseColorFactor": [*color, alpha],
                                            "metallicFactor": 0.0, "roughnessFactor": 0.5},
                      alphaMode=mode, doubleSided=True, **extra)


def _quad_file(tmp_path, name, quads):
    """A glTF of quads, each ``(colour, alpha, mode, z, half size)``, in this file order."""
    b = GltfBuilder()
    for color, alpha, mode, z, half in quads:
        pos = QUAD_POS * np.float32([half, half, 1.0]) + np.float32([0.0, 0.0, z])
        quad(b, _material(b, color, alpha, mode), positions=pos)
    return b.save(tmp_path / name)


def _scene(*paths, model="unlit", background="environment", intensity=1.0, light=None,
           **render):
    doc = {"camera": {"position": [0, 0, 3], "target": [0, 0, 0], "fov_y": 40,
                      "size": [SIZE, SIZE]},
           "environment": {"procedural": "sky", "intensity": intensity, "width": 64},
           "objects": [{"type": "mesh", "path": str(p)} for p in paths],
           "render": {"model": model, "tonemap": "none", "background": background, **render}}
    if light is not None:
        doc["light"] = light
    return scene_from_dict(doc)


GREEN_WALL = (GREEN, 1.0, "OPAQUE", 0.0, 1.0)


def test_blend_loads_without_a_warning(tmp_path):
    from viewer.geometry.loaders import load_mesh

    path = _quad_file(tmp_path, "blend.gltf", [(RED, 0.5, "BLEND", 0.0, 1.0)])
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        (mesh,) = load_mesh(path)
    assert mesh.alpha_mode == "BLEND" and mesh.base_alpha == 0.5
    assert [str(w.message) for w in caught] == []


def test_half_transparent_red_over_opaque_green_is_the_over_colour(tmp_path, renderer):
    path = _quad_file(tmp_path, "over.gltf", [GREEN_WALL, (RED, 0.5, "BLEND", 0.5, 0.5)])
    frame = renderer.render(_scene(path), aovs=("albedo", "alpha"))
    # unlit: radiance = albedo; premultiplied over: 0.5 red + (1 - 0.5) green
    np.testing.assert_allclose(frame.radiance[CENTRE], [0.5, 0.5, 0.0, 1.0], atol=1e-6)
    # the blended quad is not in the G-buffer: the AOVs show the opaque wall
    np.testing.assert_allclose(frame.aovs["albedo"][CENTRE], GREEN, atol=0)
    # outside the red quad the wall is untouched
    np.testing.assert_allclose(frame.radiance[4, SIZE // 2], [0.0, 1.0, 0.0, 1.0], atol=0)


def test_alpha_is_factor_times_texture_times_vertex_colour(tmp_path, renderer):
    b = GltfBuilder()
    quad(b, _material(b, GREEN))
    tex = b.image(image([[(255, 0, 0, 102)]]))  # alpha 102/255 = 0.4, linear (never sRGB)
    m = b.material(pbrMetallicRoughness={"baseColorFactor": [1, 1, 1, 0.5],
                                         "baseColorTexture": {"index": tex}},
                   alphaMode="BLEND", doubleSided=True)
    color0 = b.accessor(np.tile(np.float32([1, 1, 1, 0.5]), (4, 1)))
    quad(b, m, positions=QUAD_POS * np.float32([0.5, 0.5, 1]) + np.float32([0, 0, 0.5]),
         extra_attrs={"COLOR_0": color0})
    frame = renderer.render(_scene(b.save(tmp_path / "alpha.gltf")))
    a = 0.5 * (102 / 255) * 0.5
    np.testing.assert_allclose(frame.radiance[CENTRE], [a, 1 - a, 0.0, 1.0], atol=2e-3)


@pytest.mark.parametrize("model,light", [("ggx_split_sum", False), ("ggx_split_sum", True),
                                         ("blinn_phong", True)])
def test_lit_blend_is_the_opaque_shading_put_over(tmp_path, renderer, model, light):
    """The forward pass shades with the model's own lighting pass: the blended pixel is
    alpha x (the same quad drawn opaque) + (1 - alpha) x (the scene without it)."""
    wall = _quad_file(tmp_path, "wall.gltf", [GREEN_WALL])
    kw = {"model": model, "light": {"direction": [0.3, 0.5, 1.0], "intensity": 2.0}
          if light else None}
    alpha = 0.35
    frames = {}
    for mode in ("OPAQUE", "BLEND"):
        red = _quad_file(tmp_path, f"red_{mode}.gltf", [(RED, alpha, mode, 0.5, 0.5)])
        frames[mode] = renderer.render(_scene(wall, red, **kw)).radiance
    behind = renderer.render(_scene(wall, **kw)).radiance
    want = alpha * frames["OPAQUE"][CENTRE] + (1 - alpha) * behind[CENTRE]
    np.testing.assert_allclose(frames["BLEND"][CENTRE], want, rtol=1e-5, atol=1e-6)


def test_two_transparent_quads_in_either_file_order_give_the_same_image(tmp_path, renderer):
    red = (RED, 0.5, "BLEND", 0.5, 0.5)  # nearer
    blue = (BLUE, 0.6, "BLEND", 0.2, 0.6)  # farther
    images = [renderer.render(_scene(_quad_file(tmp_path, f"order{i}.gltf",
                                                [GREEN_WALL, *quads]))).radiance
              for i, quads in enumerate(([red, blue], [blue, red]))]
    np.testing.assert_array_equal(images[0], images[1])
    # back to front: green, then blue over it, then red over both
    under = 0.6 * np.float32(BLUE) + 0.4 * np.float32(GREEN)
    np.testing.assert_allclose(images[0][CENTRE][:3], 0.5 * np.float32(RED) + 0.5 * under,
                               atol=1e-6)


def test_blend_quad_behind_an_opaque_one_is_hidden(tmp_path, renderer):
    path = _quad_file(tmp_path, "hidden.gltf",
                      [(GREEN, 1.0, "OPAQUE", 0.0, 0.5), (RED, 0.5, "BLEND", -0.5, 1.0)])
    frame = renderer.render(_scene(path, background="transparent"))
    np.testing.assert_array_equal(frame.radiance[CENTRE], [0.0, 1.0, 0.0, 1.0])
    # beside the green quad nothing is in front of the red one: half covered, premultiplied
    np.testing.assert_allclose(frame.radiance[8, SIZE // 2], [0.5, 0.0, 0.0, 0.5], atol=1e-6)


def test_coverage_and_emission_of_a_lone_blended_quad(tmp_path, renderer):
    """Transparent background: the radiance is premultiplied and its alpha is the quad's alpha;
    emission is weighted by alpha like reflected light; the G-buffer stays empty."""
    b = GltfBuilder()
    quad(b, b.material(pbrMetallicRoughness={"baseColorFactor": [0.8, 0.8, 0.8, 0.25]},
                       emissiveFactor=[1.0, 0.5, 0.25], alphaMode="BLEND", doubleSided=True))
    scene = _scene(b.save(tmp_path / "glow.gltf"), model="ggx_split_sum",
                   background="transparent", intensity=0.0)
    frame = renderer.render(scene, aovs=("alpha",))
    np.testing.assert_allclose(frame.radiance[CENTRE], [0.25, 0.125, 0.0625, 0.25], rtol=1e-6)
    assert frame.aovs["alpha"].max() == 0.0
    assert not renderer.specialization(scene).layout.with_emission  # not in the G-buffer
    assert "depth" not in renderer.specialization(scene).layout.omit  # the forward depth test


def test_single_sided_blend_back_face_is_culled(tmp_path, renderer):
    b = GltfBuilder()
    quad(b, _material(b, GREEN))
    m = b.material(pbrMetallicRoughness={"baseColorFactor": [1, 0, 0, 0.5]}, alphaMode="BLEND",
                   doubleSided=False)
    # wound clockwise as seen from the camera: its back faces the viewer
    pos = QUAD_POS[::-1].copy() * np.float32([0.5, 0.5, 1]) + np.float32([0, 0, 0.5])
    quad(b, m, positions=pos)
    frame = renderer.render(_scene(b.save(tmp_path / "back.gltf")))
    np.testing.assert_array_equal(frame.radiance[CENTRE], [0.0, 1.0, 0.0, 1.0])


def test_models_that_cannot_run_forward_use_split_sum_and_warn_once(tmp_path, renderer):
    from viewer.passes import forward

    forward._FALLBACK_WARNED.discard("ggx_mc")
    path = _quad_file(tmp_path, "mc.gltf", [(RED, 0.5, "BLEND", 0.0, 1.0)])
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        mc = renderer.render(_scene(path, model="ggx_mc", samples=2, background="transparent"))
        renderer.render(_scene(path, model="ggx_mc", samples=2, background="transparent"))
    messages = [str(w.message) for w in caught if "alphaMode BLEND" in str(w.message)]
    assert len(messages) == 1 and "ggx_split_sum" in messages[0]
    split = renderer.render(_scene(path, model="ggx_split_sum", background="transparent"))
    np.testing.assert_allclose(mc.radiance[CENTRE], split.radiance[CENTRE], rtol=1e-6)


def test_blended_surfaces_receive_the_frames_shadows(tmp_path, renderer):
    """A half-transparent red pane in the shadow of a small opaque square (off the centre's line
    of sight) over a lit green wall, under one directional light and a black environment: with
    shadows the pane's own light is gone at the centre (its red is 0) while the wall seen through
    it keeps its light; without shadows the pane is lit. The frame draws the maps the forward
    pass reads, so nothing is warned."""
    from viewer.passes import forward

    d = np.array([0.3, 0.5, 1.0]) / np.linalg.norm([0.3, 0.5, 1.0])  # towards the light
    # where the ray from the pane's centre (0, 0, 0.5) to the light crosses z = 1
    hit = np.array([0.0, 0.0, 0.5]) + d * (0.5 / d[2])
    b = GltfBuilder()
    for color, alpha, mode, centre, half in [
            (GREEN, 1.0, "OPAQUE", (0.0, 0.0, 0.0), 1.0),
            (RED, 0.5, "BLEND", (0.0, 0.0, 0.5), 0.5),
            (BLUE, 1.0, "OPAQUE", tuple(hit), 0.12)]:
        pos = QUAD_POS * np.float32([half, half, 1.0]) + np.float32(centre)
        quad(b, _material(b, color, alpha, mode), positions=pos)
    path = b.save(tmp_path / "pane.gltf")
    scene = _scene(path, model="ggx_split_sum", intensity=0.0,
                   light={"direction": d.tolist(), "intensity": 3.0})
    forward._UNSHADOWED_WARNED.clear()
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        shadowed = renderer.render(scene).radiance[CENTRE]
    assert not [w for w in caught if "receive no shadow" in str(w.message)]
    lit = renderer.render(scene.with_render(shadows=False)).radiance[CENTRE]
    # red over blue is the pane's diffuse light (the wall seen through it reflects a white
    # specular, the same in every channel, and no red): lit without shadows, none in the umbra
    assert lit[0] - lit[2] > 0.05, lit
    assert abs(shadowed[0] - shadowed[2]) < 1e-3 * (lit[0] - lit[2]), shadowed
    assert shadowed[2] < lit[2]  # the pane's own specular is gone too
    # the wall behind is lit in both (its ray to the light passes beside the square): its green
    # diffuse seen through the pane (green over blue: the pane adds no green of its own) is equal
    np.testing.assert_allclose(shadowed[1] - shadowed[2], lit[1] - lit[2], rtol=1e-5)


def test_the_sun_map_is_drawn_for_blended_surfaces_alone(tmp_path, renderer):
    """ggx_mc samples the environment's sun with the rest of the sky and draws no sun map for
    itself; the forward pass's split-sum shades the sun analytically, so the frame draws the
    sun's map for it (and nothing is warned), and a blended pane in a square's shadow is darker
    than without shadows."""
    from viewer.passes import forward

    path = _quad_file(tmp_path, "glass.gltf", [GREEN_WALL, (RED, 0.5, "BLEND", 0.5, 0.5)])
    scene = _scene(path, model="ggx_mc", samples=1)
    forward._UNSHADOWED_WARNED.clear()
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        targets = renderer.draw(scene)
    assert "shadowmapsun" in targets.targets
    assert not [w for w in caught if "receive no shadow" in str(w.message)]
    opaque = _scene(_quad_file(tmp_path, "wall.gltf", [GREEN_WALL]), model="ggx_mc", samples=1)
    assert "shadowmapsun" not in renderer.draw(opaque).targets  # only what the frame reads


def test_a_map_the_frame_does_not_draw_is_warned_once():
    """The safety net: a forward variant that reads a map absent from the frame's maps warns once,
    naming the light; one whose maps are all there does not."""
    from viewer.lighting.lights import Light
    from viewer.models import ShadeVariant
    from viewer.passes import forward

    lights = (Light(direction=(0.0, 1.0, 0.0)), Light(direction=(1.0, 1.0, 0.0)))
    variant = ShadeVariant("ggx_split_sum", (("LIGHT_SHADOWS", 1), ("SUN_SHADOW", 1)))
    forward._UNSHADOWED_WARNED.clear()
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        forward.warn_unshadowed(variant, {0: None, 1: None, "sun": None}, lights)
        assert not caught
        forward.warn_unshadowed(variant, {0: None}, lights)
        forward.warn_unshadowed(variant, {0: None}, lights)
    messages = [str(w.message) for w in caught]
    assert len(messages) == 1 and "sun" in messages[0] and "light 1" in messages[0], messages
    forward._UNSHADOWED_WARNED.clear()
