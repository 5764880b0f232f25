"""glTF textures as the spec defines them: samplers (wrap modes, filters, mipmaps), texture
coordinate sets, ``KHR_texture_transform`` and ``COLOR_0``, each in a small file built with
pygltflib (gltf_builder.py) and drawn into a G-buffer."""
import math

import numpy as np
import pytest

from gltf_builder import (BLUE, GREEN, NEAREST, QUAD_UV, RED, WHITE, GltfBuilder, color_at, image,
                          px, quad)


# ---- samplers, texture coordinate sets, KHR_texture_transform, COLOR_0 ------------------------
def _textured_quad(tmp_path, name, img, sampler=None, info_extra=None, uv=QUAD_UV,
                   extra_attrs=None, **material):
    b = GltfBuilder()
    tex = b.image(img, sampler=sampler)
    info = {"index": tex, **(info_extra or {})}
    m = b.material(pbrMetallicRoughness={"baseColorTexture": info}, doubleSided=True, **material)
    attrs = {k: b.accessor(v) for k, v in (extra_attrs or {}).items()}
    quad(b, m, uv=uv, extra_attrs=attrs)
    return b.save(tmp_path / f"{name}.gltf")


def test_texture_transform_rotates_as_the_spec_example(tmp_path, gbuffer_of):
    # The extension's JSON example: offset [0, 1], rotation pi/2, scale [0.5, 0.5] "utilizes only
    # the lower left quadrant of the source image, rotated clockwise 90 degrees". That quadrant
    # here is [[red, green], [blue, white]] (rows top to bottom); rotated clockwise it reads
    # [[blue, red], [white, green]]. By hand: uv -> (v / 2, 1 - u / 2), so the quad's top right
    # (u ~ 0.75, v ~ 0.25) reads texel (0.125, 0.625) -> column 0, row 2: red.
    k = (0, 0, 0, 255)
    img = image([[k, k, k, k], [k, k, k, k], [RED, GREEN, k, k], [BLUE, WHITE, k, k]])
    transform = {"KHR_texture_transform": {"offset": [0, 1], "rotation": math.pi / 2,
                                           "scale": [0.5, 0.5]}}
    path = _textured_quad(tmp_path, "rotated", img, sampler={**NEAREST, "wrapS": 33071,
                                                              "wrapT": 33071},
                          info_extra={"extensions": transform})
    g = gbuffer_of(path)
    np.testing.assert_allclose(color_at(g, 0.5, 0.5), [1, 0, 0], atol=1e-3)  # top right: red
    np.testing.assert_allclose(color_at(g, 0.5, -0.5), [0, 1, 0], atol=1e-3)  # bottom right
    np.testing.assert_allclose(color_at(g, -0.5, 0.5), [0, 0, 1], atol=1e-3)  # top left: blue
    np.testing.assert_allclose(color_at(g, -0.5, -0.5), [1, 1, 1], atol=1e-3)


@pytest.mark.parametrize("wrap, want", [(10497, "RGRG"), (33648, "RGGR"), (33071, "RGGG")],
                         ids=["repeat", "mirrored_repeat", "clamp_to_edge"])
def test_wrap_modes(tmp_path, gbuffer_of, wrap, want):
    img = image([[RED, GREEN]])
    uv = QUAD_UV * np.float32([2.0, 1.0])  # u from 0 to 2 across the quad
    path = _textured_quad(tmp_path, f"wrap{wrap}", img,
                          sampler={**NEAREST, "wrapS": wrap, "wrapT": 33071}, uv=uv)
    g = gbuffer_of(path)
    colors = {"R": [1, 0, 0], "G": [0, 1, 0]}
    for x, letter in zip((-0.75, -0.25, 0.25, 0.75), want):
        np.testing.assert_allclose(color_at(g, x, 0.0), colors[letter], atol=1e-3,
                                   err_msg=f"u = {x + 1:.2f}")


def test_linear_filter_and_mipmaps_by_sampler(tmp_path, gbuffer_of):
    img = image([[RED, GREEN]])
    nearest = gbuffer_of(_textured_quad(tmp_path, "nearest", img, sampler=NEAREST))
    linear = gbuffer_of(_textured_quad(tmp_path, "linear", img,
                                       sampler={"magFilter": 9729, "minFilter": 9729}))
    centre = px(0.0, 0.0)  # u = 0.5: the boundary of the two texels
    assert set(np.round(nearest["albedo"][centre], 3)) <= {0.0, 1.0}
    np.testing.assert_allclose(linear["albedo"][px(0.02, 0.0)][:2], [0.5, 0.5], atol=0.05)


def test_texcoord_sets_and_the_transform_override(tmp_path, gbuffer_of):
    img = image([[RED, GREEN]])
    uv0 = np.tile(np.float32([0.25, 0.5]), (4, 1))  # the red texel
    uv1 = np.tile(np.float32([0.75, 0.5]), (4, 1))  # the green texel
    for name, info, want in (("set0", {"texCoord": 0}, [1, 0, 0]),
                             ("set1", {"texCoord": 1}, [0, 1, 0]),
                             ("override", {"texCoord": 0, "extensions": {
                                 "KHR_texture_transform": {"texCoord": 1}}}, [0, 1, 0])):
        path = _textured_quad(tmp_path, name, img, sampler=NEAREST, info_extra=info, uv=uv0,
                              extra_attrs={"TEXCOORD_1": uv1})
        np.testing.assert_allclose(color_at(gbuffer_of(path), 0.3, 0.2), want, atol=1e-3,
                                   err_msg=name)


@pytest.mark.parametrize("encoding", ["float", "unorm8", "rgb_unorm16"])
def test_vertex_colour_multiplies_the_base_colour(tmp_path, gbuffer_of, encoding):
    rgba = np.float32([0.4, 0.2, 1.0, 1.0])
    if encoding == "float":
        colors = np.tile(rgba, (4, 1))
    elif encoding == "unorm8":
        colors = np.tile(np.round(rgba * 255).astype(np.uint8), (4, 1))
    else:
        colors = np.tile(np.round(rgba[:3] * 65535).astype(np.uint16), (4, 1))
    b = GltfBuilder()
    m = b.material(pbrMetallicRoughness={"baseColorFactor": [0.5, 1.0, 0.5, 1.0]},
                   doubleSided=True)
    quad(b, m, uv=None, extra_attrs={"COLOR_0": b.accessor(colors,
                                                           normalized=encoding != "float")})
    g = gbuffer_of(b.save(tmp_path / f"color_{encoding}.gltf"))
    np.testing.assert_allclose(color_at(g, 0.1, 0.1), [0.2, 0.2, 0.5], atol=2e-3)
