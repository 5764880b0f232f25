"""glTF vertex data as the spec defines it: ``KHR_mesh_quantization`` (normalised and integer
attributes), sparse accessors and Draco-compressed primitives, each in a small file built with
pygltflib (gltf_builder.py) and compared with the float positions."""
import numpy as np
import pytest

from gltf_builder import (BLUE, GREEN, NEAREST, QUAD_IDX, QUAD_POS, QUAD_UV, RED, WHITE,
                          GltfBuilder, color_at, image, load_warnings, quad)
from viewer.geometry.loaders import load_mesh


# ---- KHR_mesh_quantization, sparse accessors, Draco -------------------------------------------
def _float_reference(tmp_path):
    b = GltfBuilder()
    quad(b, b.material(doubleSided=True), node={"translation": [0.1, 0.2, 0.0]})
    (mesh,) = load_mesh(b.save(tmp_path / "float.gltf"))
    return mesh


def test_quantised_attributes_give_the_float_positions(tmp_path, gbuffer_of):
    """KHR_mesh_quantization as gltfpack writes it (the quantised Duck): int16 positions rescaled
    by the node, int8 normalised normals, uint16 texture coordinates that the material's
    KHR_texture_transform maps back to [0, 1]."""
    ref = _float_reference(tmp_path)
    b = GltfBuilder()
    img = image([[RED, GREEN], [BLUE, WHITE]])
    tex = b.image(img, sampler=NEAREST)
    scale = 1.0 / 4000.0
    transform = {"KHR_texture_transform": {"scale": [scale, scale]}}
    m = b.material(pbrMetallicRoughness={"baseColorTexture": {"index": tex,
                                                              "extensions": transform}},
                   doubleSided=True)
    pos_q = np.round(QUAD_POS * 1000).astype(np.int16)  # positions x 1000, node scale 1e-3
    nrm_q = np.tile(np.int8([0, 0, 127]), (4, 1))
    uv_q = np.round(QUAD_UV * 4000).astype(np.uint16)
    attrs = {"POSITION": b.accessor(pos_q, minmax=True),
             "NORMAL": b.accessor(nrm_q, normalized=True),
             "TEXCOORD_0": b.accessor(uv_q)}
    b.mesh(attrs, b.accessor(QUAD_IDX), m,
           node={"translation": [0.1, 0.2, 0.0], "scale": [1e-3, 1e-3, 1e-3]})
    b.doc["extensionsUsed"] = ["KHR_mesh_quantization", "KHR_texture_transform"]
    b.doc["extensionsRequired"] = ["KHR_mesh_quantization"]
    path = b.save(tmp_path / "quantised.gltf")
    (mesh,), messages = load_warnings(path)
    assert messages == []
    np.testing.assert_allclose(mesh.positions, ref.positions, atol=1e-6)
    np.testing.assert_allclose(mesh.normals, ref.normals, atol=1e-6)
    g = gbuffer_of([mesh])
    np.testing.assert_allclose(color_at(g, -0.4, 0.3), [1, 0, 0], atol=1e-3)  # not one colour
    np.testing.assert_allclose(color_at(g, 0.3, -0.4), [1, 1, 1], atol=1e-3)


def test_sparse_accessors(tmp_path):
    ref = _float_reference(tmp_path)
    b = GltfBuilder()
    wrong = QUAD_POS.copy()
    wrong[[1, 3]] = 9.0  # overridden by the sparse block
    which = np.uint16([1, 3])
    values = QUAD_POS[[1, 3]]
    sparse = {"count": 2, "indices": {"bufferView": b.view(which.tobytes()), "componentType": 5123},
              "values": {"bufferView": b.view(values.tobytes())}}
    pos = b.accessor(wrong, minmax=True, sparse=sparse)
    # a sparse accessor without a bufferView: zeros, then the substitutions (all 4 normals)
    nrm_values = np.tile(np.float32([0, 0, 1]), (4, 1))
    nrm = b.accessor(np.zeros((0, 3), np.float32), sparse={
        "count": 4, "indices": {"bufferView": b.view(np.uint8([0, 1, 2, 3]).tobytes()),
                                "componentType": 5121},
        "values": {"bufferView": b.view(nrm_values.tobytes())}})
    b.doc["accessors"][nrm]["count"] = 4
    b.mesh({"POSITION": pos, "NORMAL": nrm}, b.accessor(QUAD_IDX), b.material(doubleSided=True),
           node={"translation": [0.1, 0.2, 0.0]})
    (mesh,) = load_mesh(b.save(tmp_path / "sparse.gltf"))
    np.testing.assert_allclose(mesh.positions, ref.positions, atol=1e-6)
    np.testing.assert_allclose(mesh.normals, ref.normals, atol=1e-6)


def test_draco_compressed_primitive(tmp_path):
    DracoPy = pytest.importorskip("DracoPy", reason="KHR_draco_mesh_compression needs DracoPy")
    ref = _float_reference(tmp_path)
    data = DracoPy.encode(QUAD_POS.astype(np.float64), QUAD_IDX.reshape(-1, 3).astype(np.uint32),
                          quantization_bits=16, preserve_order=True,
                          normals=np.tile([0.0, 0.0, 1.0], (4, 1)))
    decoded = DracoPy.decode(data)
    ids = {a["attribute_type"]: a["unique_id"] for a in decoded.attributes}
    b = GltfBuilder()
    view = b.view(data)
    pos = b.accessor(np.zeros((0, 3), np.float32))
    b.doc["accessors"][pos].update(count=4, min=[-1, -1, 0], max=[1, 1, 0])
    nrm = b.accessor(np.zeros((0, 3), np.float32))
    b.doc["accessors"][nrm]["count"] = 4
    idx = b.accessor(np.zeros(0, np.uint16))
    b.doc["accessors"][idx]["count"] = 6
    b.mesh({"POSITION": pos, "NORMAL": nrm}, idx, b.material(doubleSided=True),
           node={"translation": [0.1, 0.2, 0.0]},
           extensions={"KHR_draco_mesh_compression": {
               "bufferView": view, "attributes": {"POSITION": ids[0], "NORMAL": ids[1]}}})
    b.doc["extensionsUsed"] = ["KHR_draco_mesh_compression"]
    b.doc["extensionsRequired"] = ["KHR_draco_mesh_compression"]
    (mesh,), messages = load_warnings(b.save(tmp_path / "draco.gltf"))
    assert messages == []
    # the same triangles (Draco may reorder vertices): compare corner positions per triangle
    got = np.sort(mesh.positions[mesh.indices].reshape(-1, 9), axis=0)
    want = np.sort(ref.positions[ref.indices].reshape(-1, 9), axis=0)
    np.testing.assert_allclose(got, want, atol=1e-4)  # 16-bit quantisation of a 2-unit box
    np.testing.assert_allclose(mesh.normals, np.tile([0, 0, 1], (len(mesh.normals), 1)),
                               atol=1e-3)
