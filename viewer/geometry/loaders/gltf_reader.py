"""Reading a glTF file's data: buffers, bufferViews, accessors (normalised, sparse, Draco-decoded),
images and the default scene's node hierarchy (:class:`_GltfReader`)."""
from __future__ import annotations

import base64
import urllib.parse
from pathlib import Path

import numpy as np
import pygltflib

from ...errors import InputError
from .images import _decode_image


_UNSUPPORTED_EXTENSIONS = ("EXT_meshopt_compression",)  # refused when required
_COMPONENT = {5120: np.int8, 5121: np.uint8, 5122: np.int16, 5123: np.uint16, 5125: np.uint32,
              5126: np.float32}
_NCOMP = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4, "MAT2": 4, "MAT3": 9, "MAT4": 16}


class ImageUnavailable(InputError):
    """A texture image that is missing or cannot be decoded: the material loads without that map
    (:func:`.gltf_material._gltf_material` warns), as three.js does; corrupt buffers and JSON
    stay :class:`InputError`."""


class _GltfReader:
    def __init__(self, path: Path):
        self.path = path
        self.gltf = pygltflib.GLTF2().load(str(path))
        if self.gltf is None:
            raise InputError("cannot parse glTF file", where=path)
        required = set(self.gltf.extensionsRequired or [])
        bad = sorted(required & set(_UNSUPPORTED_EXTENSIONS))
        if bad:
            raise InputError(f"uses unsupported required extension {', '.join(bad)}", where=path)
        self._buffers: dict[int, bytes] = {}
        self._images: dict[int, np.ndarray] = {}
        self.unavailable_warned: set[str] = set()  # warnings given about missing texture images

    # raw data
    def _uri_bytes(self, uri: str, what: str) -> bytes:
        if uri.startswith("data:"):
            try:
                return base64.b64decode(uri.split(",", 1)[1])
            except Exception:
                raise InputError(f"{what} has a corrupt data URI", where=self.path) from None
        file = self.path.parent / urllib.parse.unquote(uri)
        if not file.is_file():
            raise InputError(f"{what} refers to missing file {uri!r}", where=self.path)
        return file.read_bytes()

    def buffer(self, index: int) -> bytes:
        if index not in self._buffers:
            buf = self.gltf.buffers[index]
            if buf.uri is None:
                data = self.gltf.binary_blob()
                if data is None:
                    raise InputError("binary chunk missing (truncated .glb?)", where=self.path)
            else:
                data = self._uri_bytes(buf.uri, f"buffer {index}")
            if buf.byteLength is not None and len(data) < buf.byteLength:
                raise InputError(f"buffer {index} has {len(data)} bytes, expected "
                                 f"{buf.byteLength} (truncated file?)", where=self.path)
            self._buffers[index] = bytes(data)
        return self._buffers[index]

    def view_bytes(self, index: int) -> bytes:
        bv = self.gltf.bufferViews[index]
        data = self.buffer(bv.buffer)
        start = bv.byteOffset or 0
        if start + bv.byteLength > len(data):
            raise InputError(f"bufferView {index} runs past the end of its buffer (truncated?)",
                             where=self.path)
        return data[start:start + bv.byteLength]

    def _typed(self, view: int | None, byte_offset: int, dtype: np.dtype, nc: int, count: int,
               what: str, use_stride: bool = True) -> np.ndarray:
        """``count`` elements of ``nc`` components of ``dtype`` from bufferView ``view``."""
        if view is None:
            return np.zeros((count, nc), dtype)
        bv = self.gltf.bufferViews[view]
        data = self.buffer(bv.buffer)
        start = (bv.byteOffset or 0) + (byte_offset or 0)
        stride = (bv.byteStride if use_stride else None) or dtype.itemsize * nc
        end = start + stride * max(count - 1, 0) + dtype.itemsize * nc
        view_end = (bv.byteOffset or 0) + bv.byteLength
        if count and end > min(len(data), view_end):
            raise InputError(f"{what} runs past the end of its bufferView {view} "
                             f"({end} > {min(len(data), view_end)} bytes; truncated file?)",
                             where=self.path)
        return np.ndarray((count, nc), dtype, buffer=data, offset=start,
                          strides=(stride, dtype.itemsize)).copy()

    def accessor(self, index: int, raw: np.ndarray | None = None) -> np.ndarray:
        """Accessor ``index`` as a ``[count, components]`` array: sparse substitutions applied,
        normalised integers -> float32 (glTF 3.11: c / (2^b - 1), signed max(c / (2^(b-1) - 1),
        -1)); non-normalised integers stay integers (callers convert). ``raw``: the accessor's
        data decoded elsewhere (Draco), taken instead of its bufferView."""
        acc = self.gltf.accessors[index]
        if acc.componentType not in _COMPONENT or acc.type not in _NCOMP:
            raise InputError(f"accessor {index} has an unknown componentType "
                             f"{acc.componentType} or type {acc.type!r}", where=self.path)
        dtype = np.dtype(_COMPONENT[acc.componentType])
        nc = _NCOMP[acc.type]
        if raw is not None:
            arr = np.asarray(raw).reshape(len(raw), -1)
            if arr.shape[1] != nc:
                raise InputError(f"accessor {index}: decoded data has {arr.shape[1]} components, "
                                 f"expected {nc}", where=self.path)
        else:
            arr = self._typed(acc.bufferView, acc.byteOffset, dtype, nc, acc.count,
                              f"accessor {index}")
        if acc.sparse is not None:
            arr = self._apply_sparse(index, acc, arr, dtype, nc)
        if acc.normalized and arr.dtype.kind in "iu":
            info = np.iinfo(arr.dtype)
            arr = np.maximum(arr.astype(np.float32) / info.max, -1.0)
        return arr

    def _apply_sparse(self, index: int, acc, arr: np.ndarray, dtype, nc: int) -> np.ndarray:
        """glTF 3.6.2.3 sparse accessors: ``values[i]`` replaces element ``indices[i]``."""
        sp = acc.sparse
        count = int(sp.count or 0)
        ind, val = sp.indices, sp.values
        if ind is None or val is None or count < 1:
            raise InputError(f"accessor {index} has an incomplete sparse block", where=self.path)
        if ind.componentType not in (5121, 5123, 5125):
            raise InputError(f"accessor {index}: sparse indices componentType "
                             f"{ind.componentType} is not an unsigned integer", where=self.path)
        idx = self._typed(ind.bufferView, ind.byteOffset, np.dtype(_COMPONENT[ind.componentType]),
                          1, count, f"accessor {index} sparse indices", use_stride=False)[:, 0]
        values = self._typed(val.bufferView, val.byteOffset, dtype, nc, count,
                             f"accessor {index} sparse values", use_stride=False)
        if count and int(idx.max()) >= len(arr):
            raise InputError(f"accessor {index}: sparse index {int(idx.max())} is out of range "
                             f"for {len(arr)} elements", where=self.path)
        arr = arr.astype(values.dtype, copy=True)
        arr[idx.astype(np.int64)] = values
        return arr

    def image(self, texture_index: int, what: str) -> np.ndarray:
        """The decoded image of texture ``texture_index``; :class:`ImageUnavailable` when the
        image is missing or cannot be decoded (a truncated buffer stays an :class:`InputError`)."""
        tex = self.gltf.textures[texture_index]
        source = tex.source
        if source is None:
            raise ImageUnavailable(f"{what} texture {texture_index} has no image source",
                                   where=self.path)
        if source not in self._images:
            img = self.gltf.images[source]
            label = f"{what} image {img.uri!r}" if img.uri and not img.uri.startswith("data:") \
                else f"{what} image {source}"
            if img.bufferView is not None:
                data = self.view_bytes(img.bufferView)
            elif img.uri:
                file = self.path.parent / urllib.parse.unquote(img.uri)
                if not img.uri.startswith("data:") and not file.is_file():
                    raise ImageUnavailable(f"{label} is missing (no file {str(file)!r})",
                                           where=self.path)
                try:
                    data = self._uri_bytes(img.uri, label)
                except InputError as exc:
                    raise ImageUnavailable(exc.problem, where=self.path) from None
            else:
                raise ImageUnavailable(f"{label} has neither uri nor bufferView", where=self.path)
            try:
                self._images[source] = _decode_image(data, label)
            except InputError as exc:
                raise ImageUnavailable(exc.problem, where=self.path) from None
        return self._images[source]

    # scene
    def node_matrices(self) -> list[tuple[int, np.ndarray]]:
        """(mesh index, world matrix) for every mesh instance in the default scene."""
        g = self.gltf
        if not g.scenes and not g.nodes:  # meshes without nodes
            return [(i, np.eye(4)) for i in range(len(g.meshes or []))]
        return [(node.mesh, world) for node, world in self.scene_nodes() if node.mesh is not None]

    def light_nodes(self) -> list[tuple[int, np.ndarray]]:
        """(KHR_lights_punctual light index, world matrix) for every light a node of the default
        scene places."""
        out = []
        for node, world in self.scene_nodes():
            ext = (node.extensions or {}).get("KHR_lights_punctual") \
                if isinstance(node.extensions, dict) else None
            if isinstance(ext, dict) and "light" in ext:
                out.append((ext["light"], world))
        return out

    def scene_nodes(self) -> list[tuple[object, np.ndarray]]:
        """(node, world matrix) for every node of the default scene, depth first."""
        g = self.gltf
        if g.scenes:
            scene = g.scenes[g.scene if g.scene is not None else 0]
            roots = list(scene.nodes or [])
        elif g.nodes:
            children = {c for n in g.nodes for c in (n.children or [])}
            roots = [i for i in range(len(g.nodes)) if i not in children]
        else:
            return []
        out: list[tuple[object, np.ndarray]] = []
        stack = [(r, np.eye(4), 0) for r in reversed(roots)]
        while stack:
            idx, parent, depth = stack.pop()
            if depth > 256:
                raise InputError("node hierarchy is too deep (a cycle?)", where=self.path)
            node = g.nodes[idx]
            world = parent @ _node_matrix(node)
            out.append((node, world))
            stack.extend((c, world, depth + 1) for c in reversed(node.children or []))
        return out


def _node_matrix(node) -> np.ndarray:
    if node.matrix is not None and len(node.matrix) == 16:
        return np.asarray(node.matrix, np.float64).reshape(4, 4).T  # glTF is column-major
    m = np.eye(4)
    if node.scale is not None:
        m = np.diag([*node.scale, 1.0]) @ m
    if node.rotation is not None:
        x, y, z, w = (float(v) for v in node.rotation)
        r = np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                      [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                      [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])
        rot = np.eye(4)
        rot[:3, :3] = r
        m = rot @ m
    if node.translation is not None:
        t = np.eye(4)
        t[:3, 3] = node.translation
        m = t @ m
    return m


def _draco_attributes(reader: _GltfReader, prim, where: str) -> dict[str, np.ndarray] | None:
    """``KHR_draco_mesh_compression``: the primitive's attributes (glTF name -> array) and
    ``"_indices"`` decoded by DracoPy; None without the extension."""
    ext = (prim.extensions or {}).get("KHR_draco_mesh_compression")
    if ext is None:
        return None
    try:
        import DracoPy
    except ImportError:  # pragma: no cover - DracoPy is a declared dependency
        raise InputError("uses KHR_draco_mesh_compression but DracoPy is not installed "
                         "(pip install DracoPy)", where=reader.path) from None
    if not isinstance(ext, dict) or "bufferView" not in ext or "attributes" not in ext:
        raise InputError(f"{where}: KHR_draco_mesh_compression lacks bufferView or attributes",
                         where=reader.path)
    try:
        decoded = DracoPy.decode(reader.view_bytes(int(ext["bufferView"])))
    except InputError:
        raise
    except Exception as exc:
        raise InputError(f"{where}: corrupt Draco data ({type(exc).__name__})",
                         where=reader.path) from None
    out = {"_indices": np.asarray(decoded.faces, np.uint32).reshape(-1)}
    for name, unique_id in ext["attributes"].items():
        attr = decoded.get_attribute_by_unique_id(int(unique_id))
        if attr is None:
            raise InputError(f"{where}: Draco attribute {name} (id {unique_id}) is missing",
                             where=reader.path)
        out[name] = np.asarray(attr["data"])
    return out
