"""glTF test files built in code (:class:`GltfBuilder`, :func:`quad`: one feature each) and the
test camera of the G-buffer fixture ``gbuffer_of`` (tests/viewer/conftest.py): :func:`px` is the
pixel that shows a point of the z = 0 plane, :func:`color_at` its albedo."""
import base64
import io
import json
import math
import warnings

import numpy as np
import pygltflib

from viewer.geometry.loaders import load_mesh


_COMPONENT = {np.dtype(np.int8): 5120, np.dtype(np.uint8): 5121, np.dtype(np.int16): 5122,
              np.dtype(np.uint16): 5123, np.dtype(np.uint32): 5125, np.dtype(np.float32): 5126}
_TYPE = {1: "SCALAR", 2: "VEC2", 3: "VEC3", 4: "VEC4"}


def png_uri(rgba_u8: np.ndarray) -> str:
    from PIL import Image

    buf = io.BytesIO()
    Image.fromarray(rgba_u8).save(buf, format="PNG")
    return "data:image/png;base64," + base64.b64encode(buf.getvalue()).decode()


class GltfBuilder:
    """A glTF document as a dict with one embedded buffer; ``save`` writes it through pygltflib."""

    def __init__(self):
        self.blob = bytearray()
        self.doc = {"asset": {"version": "2.0"}, "buffers": [], "bufferViews": [],
                    "accessors": [], "meshes": [], "nodes": [], "scenes": [{"nodes": []}],
                    "scene": 0, "materials": [], "images": [], "textures": [], "samplers": []}

    def view(self, data: bytes, stride: int | None = None) -> int:
        while len(self.blob) % 4:
            self.blob += b"\0"
        view = {"buffer": 0, "byteOffset": len(self.blob), "byteLength": len(data)}
        if stride:
            view["byteStride"] = stride
        self.blob += data
        self.doc["bufferViews"].append(view)
        return len(self.doc["bufferViews"]) - 1

    def accessor(self, arr: np.ndarray, normalized: bool = False, minmax: bool = False,
                 **extra) -> int:
        arr = np.ascontiguousarray(arr)
        nc = 1 if arr.ndim == 1 else arr.shape[1]
        acc = {"componentType": _COMPONENT[arr.dtype], "count": len(arr), "type": _TYPE[nc]}
        if arr.size:
            acc["bufferView"] = self.view(arr.tobytes())
        if normalized:
            acc["normalized"] = True
        if minmax:
            acc["min"] = arr.reshape(len(arr), -1).min(0).tolist()
            acc["max"] = arr.reshape(len(arr), -1).max(0).tolist()
        acc.update(extra)
        self.doc["accessors"].append(acc)
        return len(self.doc["accessors"]) - 1

    def image(self, rgba_u8: np.ndarray, sampler: dict | None = None) -> int:
        """A texture of the PNG image; returns the texture index."""
        self.doc["images"].append({"uri": png_uri(rgba_u8)})
        tex = {"source": len(self.doc["images"]) - 1}
        if sampler is not None:
            self.doc["samplers"].append(sampler)
            tex["sampler"] = len(self.doc["samplers"]) - 1
        self.doc["textures"].append(tex)
        return len(self.doc["textures"]) - 1

    def material(self, **m) -> int:
        self.doc["materials"].append(m)
        return len(self.doc["materials"]) - 1

    def mesh(self, attributes: dict, indices: int | None, material: int | None = None,
             node: dict | None = None, **prim) -> int:
        p = {"attributes": attributes, **prim}
        if indices is not None:
            p["indices"] = indices
        if material is not None:
            p["material"] = material
        self.doc["meshes"].append({"primitives": [p]})
        self.doc["nodes"].append({"mesh": len(self.doc["meshes"]) - 1, **(node or {})})
        self.doc["scenes"][0]["nodes"].append(len(self.doc["nodes"]) - 1)
        return len(self.doc["meshes"]) - 1

    def save(self, path):
        doc = dict(self.doc)
        doc["buffers"] = [{"byteLength": len(self.blob),
                           "uri": "data:application/octet-stream;base64,"
                                  + base64.b64encode(bytes(self.blob)).decode()}]
        doc = {k: v for k, v in doc.items() if v != []}
        gltf = pygltflib.GLTF2.from_json(json.dumps(doc))
        gltf.save(str(path))
        return path


# A unit quad in the z = 0 plane facing +Z; uv (0, 0) at the top left (glTF), u right, v down.
QUAD_POS = np.float32([[-1, 1, 0], [-1, -1, 0], [1, -1, 0], [1, 1, 0]])
QUAD_UV = np.float32([[0, 0], [0, 1], [1, 1], [1, 0]])
QUAD_IDX = np.uint16([0, 1, 2, 0, 2, 3])


def quad(b: GltfBuilder, material: int | None = None, uv=QUAD_UV, extra_attrs=None,
         positions=QUAD_POS, node=None) -> int:
    attrs = {"POSITION": b.accessor(np.asarray(positions, np.float32), minmax=True),
             "NORMAL": b.accessor(np.tile(np.float32([0, 0, 1]), (len(positions), 1)))}
    if uv is not None:
        attrs["TEXCOORD_0"] = b.accessor(np.asarray(uv, np.float32))
    attrs.update(extra_attrs or {})
    return b.mesh(attrs, b.accessor(QUAD_IDX), material, node=node)


SIZE = 64
TAN = math.tan(math.radians(20.0))  # half the field of view of the test camera


def px(x: float, y: float = 0.0) -> tuple[int, int]:
    """(row, column) of the pixel showing the point (x, y, 0) to the test camera."""
    col = (x / (3.0 * TAN) + 1.0) / 2.0 * SIZE
    row = (1.0 - (y / (3.0 * TAN) + 1.0) / 2.0) * SIZE
    return int(row), int(col)


RED, GREEN, BLUE, WHITE = (255, 0, 0, 255), (0, 255, 0, 255), (0, 0, 255, 255), (255,) * 4
NEAREST = {"magFilter": 9728, "minFilter": 9728}


def image(rows) -> np.ndarray:
    return np.asarray(rows, np.uint8)


def color_at(g, x, y):
    return g["albedo"][px(x, y)]


def load_warnings(path):
    """``(meshes, warning messages)`` of loading ``path``."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        meshes = load_mesh(path)
    return meshes, [str(w.message) for w in caught]
