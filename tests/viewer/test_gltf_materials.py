"""glTF 2.0 materials as the spec defines them: small files built with pygltflib
(gltf_builder.py), one feature each, asserted numerically (G-buffer values, coverage, radiance):
doubleSided, alphaMode MASK, emission, and the warnings for what is not used. Textures and
samplers: test_gltf_textures.py; quantised, sparse and Draco data: test_gltf_accessors.py."""
import numpy as np
import pytest
from gltf_builder import (
    NEAREST,
    QUAD_POS,
    SIZE,
    GltfBuilder,
    image,
    load_warnings,
    px,
    quad,
)


# ---- warnings for everything not used ------------------------------------------------------------
def test_unused_extensions_attributes_and_features_are_named_once(tmp_path):
    b = GltfBuilder()
    m = b.material(pbrMetallicRoughness={"baseColorFactor": [1, 1, 1, 1]},
                   extensions={"KHR_materials_diffuse_transmission": {},
                               "KHR_materials_pbrSpecularGlossiness": {}})
    joints = b.accessor(np.zeros((4, 4), np.uint16))
    quad(b, m, extra_attrs={"JOINTS_0": joints, "_TEMPERATURE": b.accessor(np.zeros(4, np.float32))})
    b.doc["extensionsUsed"] = ["KHR_materials_diffuse_transmission",
                               "KHR_materials_pbrSpecularGlossiness", "EXT_mesh_gpu_instancing"]
    b.doc["animations"] = [{"channels": [], "samplers": []}]
    path = b.save(tmp_path / "ignored.gltf")
    (mesh,), messages = load_warnings(path)
    assert mesh.triangle_count == 2
    assert len(messages) == 1, messages
    (msg,) = messages
    assert "\n" not in msg and str(path) in msg
    for item in ("KHR_materials_diffuse_transmission (changes the BSDF",
                 "KHR_materials_pbrSpecularGlossiness (changes the BSDF",
                 "extension EXT_mesh_gpu_instancing", "attribute JOINTS_0",
                 "attribute _TEMPERATURE", "animations"):
        assert item in msg, (item, msg)


def test_a_plain_file_loads_without_warnings(tmp_path):
    b = GltfBuilder()
    quad(b, b.material(pbrMetallicRoughness={"baseColorFactor": [0.5, 0.5, 0.5, 1]},
                       doubleSided=True))
    _, messages = load_warnings(b.save(tmp_path / "plain.gltf"))
    assert messages == []


# ---- doubleSided, alphaMode MASK ---------------------------------------------------------------
@pytest.mark.parametrize("double_sided", [False, True])
def test_back_face_absent_when_single_sided_flipped_when_double_sided(tmp_path, gbuffer_of,
                                                                       double_sided):
    b = GltfBuilder()
    m = b.material(pbrMetallicRoughness={"baseColorFactor": [0.5, 0.5, 0.5, 1]},
                   doubleSided=double_sided)
    quad(b, m, node={"rotation": [0.0, 1.0, 0.0, 0.0]})  # 180 degrees about y: faces -z
    quad(b, m, positions=QUAD_POS * 0.25 + np.float32([0.6, 0.6, 0.5]))  # faces the camera
    g = gbuffer_of(b.save(tmp_path / "sides.gltf"))
    assert g["alpha"][px(0.75, 0.75)][0] == 1.0  # the front face, always there
    np.testing.assert_allclose(g["normal"][px(0.75, 0.75)], [0, 0, 1], atol=1e-6)
    back = px(-0.5, -0.5)
    if double_sided:
        assert g["alpha"][back][0] == 1.0
        np.testing.assert_allclose(g["normal"][back], [0, 0, 1], atol=1e-6)  # flipped from -z
    else:
        assert g["alpha"][back][0] == 0.0
        assert (g["alpha"][..., 0] > 0).sum() < 0.1 * SIZE * SIZE  # only the small front quad


def _masked_quad(tmp_path, mode, factor_alpha=1.0, cutoff=None):
    b = GltfBuilder()
    # left column alpha 0.2, right column alpha 0.9
    tex = b.image(image([[(255, 255, 255, 51), (255, 255, 255, 230)]] * 2),
                  sampler={**NEAREST, "wrapS": 33071, "wrapT": 33071})
    m = b.material(pbrMetallicRoughness={"baseColorTexture": {"index": tex},
                                         "baseColorFactor": [1, 1, 1, factor_alpha]},
                   alphaMode=mode, doubleSided=True,
                   **({} if cutoff is None else {"alphaCutoff": cutoff}))
    quad(b, m)
    return b.save(tmp_path / f"mask_{mode}.gltf")


def test_alpha_mask_discards_below_the_cutoff(tmp_path, gbuffer_of):
    quad_pixels = np.zeros((SIZE, SIZE), bool)
    r0, c0 = px(-1, 1)
    r1, c1 = px(1, -1)
    quad_pixels[r0 + 1:r1, c0 + 1:c1] = True
    opaque = gbuffer_of(_masked_quad(tmp_path, "OPAQUE"))["alpha"][..., 0] > 0
    assert opaque[quad_pixels].all()
    masked = gbuffer_of(_masked_quad(tmp_path, "MASK"))["alpha"][..., 0] > 0
    # coverage: the right half of the quad exactly (0.9 >= 0.5 > 0.2)
    assert masked[px(0.5, 0.5)] and masked[px(0.5, -0.5)]
    assert not masked[px(-0.5, 0.5)] and not masked[px(-0.5, -0.5)]
    assert abs(masked.sum() / opaque.sum() - 0.5) < 0.05
    # the factor's alpha multiplies: 0.6 x 0.9 = 0.54 >= 0.5 stays, 0.5 x 0.9 = 0.45 goes
    assert (gbuffer_of(_masked_quad(tmp_path, "MASK", 0.6))["alpha"][..., 0] > 0).sum() \
        == masked.sum()
    assert (gbuffer_of(_masked_quad(tmp_path, "MASK", 0.5))["alpha"][..., 0] > 0).sum() == 0
    # the cutoff is the file's: 0.1 keeps both columns
    assert (gbuffer_of(_masked_quad(tmp_path, "MASK", cutoff=0.1))["alpha"][..., 0] > 0).sum() \
        == opaque.sum()


# ---- emission -------------------------------------------------------------------------------------
def _emissive_file(tmp_path, strength=None, texture=True):
    b = GltfBuilder()
    m = {"pbrMetallicRoughness": {"baseColorFactor": [0.8, 0.8, 0.8, 1]}, "doubleSided": True,
         "emissiveFactor": [1.0, 0.5, 0.25]}
    if texture:  # sRGB 255 / 128: linear 1 and 0.2158605
        tex = b.image(image([[(255, 255, 255, 255), (128, 128, 128, 255)]]), sampler=NEAREST)
        m["emissiveTexture"] = {"index": tex}
    if strength is not None:
        m["extensions"] = {"KHR_materials_emissive_strength": {"emissiveStrength": strength}}
        b.doc["extensionsUsed"] = ["KHR_materials_emissive_strength"]
    quad(b, b.material(**m))
    return b.save(tmp_path / "emissive.gltf")


@pytest.mark.parametrize("model", ["unlit", "blinn_phong", "ggx_split_sum", "ggx_mc", "neural"])
def test_emitted_radiance_under_a_black_environment(tmp_path, ctx, model):
    from viewer.renderer import Renderer
    from viewer.scene.description import scene_from_dict

    path = _emissive_file(tmp_path, strength=4.0)
    scene = scene_from_dict({
        "camera": {"position": [0, 0, 3], "target": [0, 0, 0], "fov_y": 40, "size": [SIZE, SIZE]},
        "environment": {"procedural": "sky", "intensity": 0.0},
        "objects": [{"type": "mesh", "path": str(path)}],
        "render": {"model": model, "samples": 2, "tonemap": "none"}})
    renderer = Renderer(ctx=ctx)
    try:
        frame = renderer.render(scene, aovs=("emission",))
        assert renderer.specialization(scene).layout.with_emission
    finally:
        renderer.release()
    lit = np.float32([1.0, 0.5, 0.25]) * 4.0  # factor x strength
    left, right = frame.radiance[px(-0.5, 0.0)][:3], frame.radiance[px(0.5, 0.0)][:3]
    # unlit shows the albedo too; every lit model reflects nothing of a black environment
    base = np.float32([0.8] * 3) if model == "unlit" else 0.0
    np.testing.assert_allclose(left, base + lit * 1.0, rtol=1e-5, atol=1e-6)
    np.testing.assert_allclose(right, base + lit * 0.2158605, rtol=1e-3, atol=1e-6)
    np.testing.assert_allclose(frame.aovs["emission"][px(-0.5, 0.0)], lit, rtol=1e-6)
    assert frame.radiance[0, 0, :3].max() == 0.0  # background: the black environment


def test_emission_channel_only_where_a_scene_emits(tmp_path, ctx):
    from viewer.renderer import Renderer
    from viewer.scene.description import scene_from_dict

    b = GltfBuilder()
    quad(b, b.material(doubleSided=True))
    plain = b.save(tmp_path / "plain.gltf")
    renderer = Renderer(ctx=ctx)
    try:
        for path, want in ((plain, False), (_emissive_file(tmp_path, texture=False), True)):
            scene = scene_from_dict({"objects": [{"type": "mesh", "path": str(path)}]})
            assert renderer.specialization(scene).layout.with_emission == want
    finally:
        renderer.release()
