"""A one-quad glTF for the reference's material tests (test_reference_maps.py,
test_reference_alpha.py)."""
import base64
import io
import json

import numpy as np


def quad_gltf(path, material: dict, image=None, slot: str = "normalTexture",
              sampler: dict | None = None):
    """A 1 x 1 quad at z = 0 facing +Z (u along +x, v down along -y, glTF conventions) with
    ``material`` (a glTF material dict, copied); ``image`` (8-bit, [H, W, 3 or 4]) becomes its
    texture in ``slot``: ``normalTexture`` (the material's) or ``baseColorTexture`` (its
    ``pbrMetallicRoughness``'s), read with ``sampler`` (glTF sampler keys; None: the default)."""
    from PIL import Image

    pos = np.float32([[-0.5, -0.5, 0], [0.5, -0.5, 0], [0.5, 0.5, 0], [-0.5, 0.5, 0]])
    nrm = np.float32([[0, 0, 1]] * 4)
    uv = np.float32([[0, 1], [1, 1], [1, 0], [0, 0]])
    idx = np.uint16([0, 1, 2, 0, 2, 3])
    blob = pos.tobytes() + nrm.tobytes() + uv.tobytes() + idx.tobytes()
    material = json.loads(json.dumps(material))
    doc = {
        "asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": [0]}],
        "nodes": [{"mesh": 0}],
        "buffers": [{"byteLength": len(blob), "uri": "data:application/octet-stream;base64,"
                     + base64.b64encode(blob).decode()}],
        "bufferViews": [{"buffer": 0, "byteOffset": 0, "byteLength": 48},
                        {"buffer": 0, "byteOffset": 48, "byteLength": 48},
                        {"buffer": 0, "byteOffset": 96, "byteLength": 32},
                        {"buffer": 0, "byteOffset": 128, "byteLength": 12}],
        "accessors": [{"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3",
                       "min": [-0.5, -0.5, 0], "max": [0.5, 0.5, 0]},
                      {"bufferView": 1, "componentType": 5126, "count": 4, "type": "VEC3"},
                      {"bufferView": 2, "componentType": 5126, "count": 4, "type": "VEC2"},
                      {"bufferView": 3, "componentType": 5123, "count": 6, "type": "SCALAR"}],
        "materials": [material],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0, "NORMAL": 1, "TEXCOORD_0": 2},
                                    "indices": 3, "material": 0}]}]}
    if image is not None:
        png = io.BytesIO()
        Image.fromarray(np.asarray(image, np.uint8)).save(png, format="PNG")
        doc["images"] = [{"uri": "data:image/png;base64,"
                          + base64.b64encode(png.getvalue()).decode()}]
        doc["textures"] = [{"source": 0}]
        if sampler is not None:
            doc["samplers"] = [sampler]
            doc["textures"][0]["sampler"] = 0
        owner = material if slot == "normalTexture" else material["pbrMetallicRoughness"]
        owner[slot] = {"index": 0}
    path.write_text(json.dumps(doc))
    return path
