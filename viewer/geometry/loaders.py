"""Mesh files: glTF 2.0 (``.gltf``, ``.glb``) via pygltflib; OBJ (+MTL), PLY, STL, OFF via trimesh.

Every problem with a file (missing, corrupt, truncated, unsupported, no triangles) is an
:class:`~viewer.errors.InputError` whose one-line message names the file; library exceptions are
never let through.

glTF: the default scene's node hierarchy is flattened (node matrices or TRS applied), one
:class:`Mesh` per primitive. Read: POSITION, NORMAL, TANGENT, TEXCOORD_0/1, COLOR_0, indices
(triangles, strips, fans) - float, normalised or integer (``KHR_mesh_quantization``), sparse, or
Draco-compressed (``KHR_draco_mesh_compression``, decoded by DracoPy); baseColorFactor/Texture,
metallicFactor, roughnessFactor, metallicRoughnessTexture, normalTexture (+ scale),
occlusionTexture (+ strength), emissiveFactor/Texture (+ ``KHR_materials_emissive_strength``),
alphaMode (OPAQUE; MASK with alphaCutoff; BLEND, drawn by the forward pass
:mod:`viewer.passes.forward`), doubleSided; per texture its sampler (wrap, filters), texCoord and
``KHR_texture_transform``. Textures decode to float32 in [0, 1]; base colour and emission are
sRGB-decoded. Everything else in a file (extensions, material features, attributes,
skins, animations, cameras) is named in one warning per file (``warnings.warn``): nothing is
ignored silently.

OBJ (and PLY/STL/OFF): ``trimesh.load(path, force="scene", process=False)``; the scene graph's
transforms are applied, MTL materials become PBR parameters through trimesh
(``SimpleMaterial.to_pbr``: ``Kd`` is taken as linear, ``map_Kd`` as sRGB). OBJ texture
coordinates (v up) are flipped to the glTF convention (v down) used by :class:`Mesh`.

Meshes without normals get smooth, area-weighted normals.
"""
from __future__ import annotations

import base64
import io
import logging
import os
import urllib.parse
import warnings
from pathlib import Path

import numpy as np
import pygltflib
import trimesh
from PIL import Image
from trimesh.visual.material import PBRMaterial

from ..errors import InputError
from ..material import Material
from .mesh import Mesh, TextureSampling, _normalize, smooth_normals, srgb_to_linear

log = logging.getLogger(__name__)

GLTF_SUFFIXES = (".gltf", ".glb")
TRIMESH_SUFFIXES = (".obj", ".ply", ".stl", ".off")
_UNSUPPORTED_EXTENSIONS = ("EXT_meshopt_compression",)
# glTF extensions this loader implements; any other one a file uses is named in a warning
GLTF_EXTENSIONS = frozenset({"KHR_texture_transform", "KHR_mesh_quantization",
                             "KHR_materials_emissive_strength", "KHR_draco_mesh_compression"})
# the primitive attributes it reads (others: JOINTS_n, WEIGHTS_n, COLOR_1.., TEXCOORD_2..,
# _CUSTOM)
GLTF_ATTRIBUTES = frozenset({"POSITION", "NORMAL", "TANGENT", "TEXCOORD_0", "TEXCOORD_1",
                             "COLOR_0"})


def load_mesh(path: str | os.PathLike, transform: np.ndarray | None = None,
              material_override: Material | None = None) -> list[Mesh]:
    """Load every triangle mesh in ``path`` into world space.

    ``transform`` (``[4, 4]``, column vectors) is applied after the file's own node transforms.
    ``material_override`` replaces each mesh's material and drops its base colour,
    metallic-roughness, occlusion and emissive maps, vertex colours, emission and alpha modes (a
    normal map and the sidedness are kept: they are shape, not material).
    """
    path = Path(path)
    if not path.is_file():
        raise InputError("mesh file not found", where=path)
    suffix = path.suffix.lower()
    if suffix in GLTF_SUFFIXES:
        meshes = _guarded(_load_gltf, path, "glTF")
    elif suffix in TRIMESH_SUFFIXES:
        meshes = _guarded(_load_trimesh, path, suffix[1:].upper())
    else:
        known = ", ".join(GLTF_SUFFIXES + TRIMESH_SUFFIXES)
        raise InputError(f"unsupported mesh format {suffix or '(no extension)'!r} "
                         f"(supported: {known})", where=path)
    meshes = [m for m in meshes if m.triangle_count > 0]
    if not meshes:
        raise InputError("contains no triangles", where=path)
    if transform is not None:
        t = np.asarray(transform, np.float64)
        if t.shape != (4, 4) or not np.isfinite(t).all():
            raise InputError(f"transform must be a finite 4x4 matrix, got shape {t.shape}",
                             where=path)
        meshes = [m.transformed(t) for m in meshes]
    out = []
    for i, m in enumerate(meshes):
        if material_override is not None:  # opaque, not emissive; shape (normal map,
            m.material = material_override  # sidedness) stays
            m.textures = {k: v for k, v in m.textures.items() if k == "normal"}
            m.sampling = {k: v for k, v in m.sampling.items() if k == "normal"}
            m.colors, m.emissive, m.alpha_mode, m.base_alpha = None, (0.0, 0.0, 0.0), "OPAQUE", 1.0
        m.source = str(path)
        out.append(m.validated(where=f"{path} (mesh {i}: {m.name})" if m.name else
                               f"{path} (mesh {i})"))
    return out


def _guarded(loader, path: Path, kind: str) -> list[Mesh]:
    """Run ``loader`` and turn anything but an InputError into a one-line InputError."""
    try:
        return loader(path)
    except InputError:
        raise
    except Exception as exc:  # parsers raise anything: struct.error, KeyError, ValueError...
        detail = " ".join(str(exc).split())[:200]
        raise InputError(f"corrupt or unreadable {kind} file ({type(exc).__name__}"
                         f"{': ' + detail if detail else ''})", where=path) from None


# ---- images --------------------------------------------------------------------------------------
def _pil_to_float(img) -> np.ndarray:
    """A PIL image as float32 ``[H, W, C]`` in [0, 1] (no colour decoding)."""
    mode = img.mode
    if mode in ("P", "PA", "1", "CMYK", "YCbCr", "LAB", "HSV"):
        img = img.convert("RGBA" if ("transparency" in img.info or mode == "PA") else "RGB")
        mode = img.mode
    arr = np.asarray(img)
    if mode.startswith("I;16") or mode == "I":
        arr = arr.astype(np.float32) / 65535.0
    elif mode == "F":
        arr = arr.astype(np.float32)
    else:
        arr = arr.astype(np.float32) / 255.0
    if arr.ndim == 2:
        arr = arr[:, :, None]
    return np.ascontiguousarray(arr, np.float32)


def _decode_image(data: bytes, what: str) -> np.ndarray:
    try:
        img = Image.open(io.BytesIO(data))
        img.load()
    except Exception as exc:
        raise InputError(f"cannot decode {what} ({type(exc).__name__}: "
                         f"{' '.join(str(exc).split())[:150]})") from None
    return _pil_to_float(img)


def _color_texture(rgba: np.ndarray) -> np.ndarray:
    """sRGB-encoded colour in [0, 1] -> linear, alpha (if any) kept linear."""
    out = rgba.copy()
    if out.shape[2] <= 2:  # grey (+ alpha): make it RGB(A)
        grey = out[:, :, :1]
        out = np.concatenate([grey, grey, grey] + ([out[:, :, 1:2]] if out.shape[2] == 2 else []),
                             axis=2)
    out[:, :, :3] = srgb_to_linear(out[:, :, :3])
    return out


# ---- glTF ----------------------------------------------------------------------------------------
_COMPONENT = {5120: np.int8, 5121: np.uint8, 5122: np.int16, 5123: np.uint16, 5125: np.uint32,
              5126: np.float32}
_NCOMP = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4, "MAT2": 4, "MAT3": 9, "MAT4": 16}


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
        tex = self.gltf.textures[texture_index]
        source = tex.source
        if source is None:
            raise InputError(f"{what} texture {texture_index} has no image source", where=self.path)
        if source not in self._images:
            img = self.gltf.images[source]
            label = f"{what} image {source}"
            if img.bufferView is not None:
                data = self.view_bytes(img.bufferView)
            elif img.uri:
                data = self._uri_bytes(img.uri, label)
            else:
                raise InputError(f"{label} has neither uri nor bufferView", where=self.path)
            try:
                self._images[source] = _decode_image(data, label)
            except InputError as exc:
                raise InputError(exc.problem, where=self.path) from None
        return self._images[source]

    # scene
    def node_matrices(self) -> list[tuple[int, np.ndarray]]:
        """(mesh index, world matrix) for every mesh instance in the default scene."""
        g = self.gltf
        if g.scenes:
            scene = g.scenes[g.scene if g.scene is not None else 0]
            roots = list(scene.nodes or [])
        elif g.nodes:
            children = {c for n in g.nodes for c in (n.children or [])}
            roots = [i for i in range(len(g.nodes)) if i not in children]
        else:  # meshes without nodes
            return [(i, np.eye(4)) for i in range(len(g.meshes or []))]
        out: list[tuple[int, np.ndarray]] = []
        stack = [(r, np.eye(4), 0) for r in reversed(roots)]
        while stack:
            idx, parent, depth = stack.pop()
            if depth > 256:
                raise InputError("node hierarchy is too deep (a cycle?)", where=self.path)
            node = g.nodes[idx]
            world = parent @ _node_matrix(node)
            if node.mesh is not None:
                out.append((node.mesh, world))
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


def _triangles(indices: np.ndarray, mode: int) -> np.ndarray | None:
    idx = indices.reshape(-1).astype(np.uint32)
    if mode == 4:
        return idx[: len(idx) // 3 * 3].reshape(-1, 3)
    if mode == 5 and len(idx) >= 3:  # strip: flip every other triangle to keep the winding
        k = np.arange(len(idx) - 2)
        a, b, c = idx[k], idx[k + 1], idx[k + 2]
        odd = k % 2 == 1
        a, b = np.where(odd, b, a), np.where(odd, a, b)
        return np.stack([a, b, c], axis=1)
    if mode == 6 and len(idx) >= 3:  # fan
        k = np.arange(1, len(idx) - 1)
        return np.stack([np.full_like(k, idx[0]), idx[k], idx[k + 1]], axis=1).astype(np.uint32)
    return None  # points and lines


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


def _load_gltf(path: Path) -> list[Mesh]:
    reader = _GltfReader(path)
    g = reader.gltf
    out: list[Mesh] = []
    skipped = 0
    for mesh_index, world in reader.node_matrices():
        gmesh = g.meshes[mesh_index]
        for prim_index, prim in enumerate(gmesh.primitives):
            where = f"mesh {mesh_index} primitive {prim_index}"
            mode = 4 if prim.mode is None else prim.mode
            attrs = prim.attributes
            if attrs.POSITION is None:
                skipped += 1
                continue
            draco = _draco_attributes(reader, prim, where)

            def attribute(name: str):
                index = getattr(attrs, name, None)
                if index is None:
                    return None
                return reader.accessor(index, raw=None if draco is None else draco.get(name))

            positions = attribute("POSITION").astype(np.float32)
            if draco is not None:
                indices = draco["_indices"]
            elif prim.indices is not None:
                indices = reader.accessor(prim.indices)
            else:
                indices = np.arange(len(positions), dtype=np.uint32)
            tris = _triangles(indices, mode)
            if tris is None or len(tris) == 0:
                skipped += 1
                continue
            if int(tris.max()) >= len(positions):
                raise InputError(f"{where} has an index out of range", where=path)
            normals = attribute("NORMAL")
            normals = (normals.astype(np.float32) if normals is not None
                       else smooth_normals(positions, tris))
            tangents = attribute("TANGENT")
            if tangents is not None:
                tangents = tangents.astype(np.float32)
            uv_sets = [attribute(f"TEXCOORD_{k}") for k in (0, 1)]
            uv_sets = [None if uv is None else uv.astype(np.float32) for uv in uv_sets]
            colors = attribute("COLOR_0")
            if colors is not None:
                colors = colors.astype(np.float32)
                if colors.shape[1] == 3:
                    colors = np.concatenate([colors, np.ones_like(colors[:, :1])], axis=1)
            fields = _gltf_material(reader, prim.material)
            for key, sampling in list(fields["sampling"].items()):
                if uv_sets[sampling.texcoord] is None:
                    warnings.warn(f"{path}: {where}: the {key} texture reads TEXCOORD_"
                                  f"{sampling.texcoord}, which the primitive lacks; texture "
                                  f"ignored", stacklevel=3)
                    del fields["textures"][key], fields["sampling"][key]
            name = gmesh.name or f"mesh{mesh_index}"
            if len(gmesh.primitives) > 1:
                name += f".{prim_index}"
            mesh = Mesh(positions=positions, normals=_normalize(normals), uvs=uv_sets[0],
                        uvs1=uv_sets[1], colors=colors, tangents=tangents, indices=tris,
                        name=name, **fields)
            out.append(mesh.transformed(world) if not np.allclose(world, np.eye(4)) else mesh)
    if skipped:
        log.info("%s: skipped %d non-triangle primitives", path, skipped)
    _warn_ignored(reader)
    return out


# KHR_materials_* extensions that change the BSDF (none is implemented): named as such
_BSDF_EXTENSIONS = ("KHR_materials_clearcoat", "KHR_materials_transmission", "KHR_materials_sheen",
                    "KHR_materials_volume", "KHR_materials_ior", "KHR_materials_specular",
                    "KHR_materials_iridescence", "KHR_materials_anisotropy",
                    "KHR_materials_diffuse_transmission", "KHR_materials_dispersion",
                    "KHR_materials_pbrSpecularGlossiness", "KHR_materials_unlit")


def _extension_names(obj) -> set[str]:
    ext = getattr(obj, "extensions", None)
    return set(ext) if isinstance(ext, dict) else set()


def _ignored_items(reader: "_GltfReader") -> list[str]:
    """Everything in the file the loader does not use, one short phrase each (sorted, unique)."""
    g = reader.gltf
    used_ext = set(g.extensionsUsed or []) | _extension_names(g)
    for coll in (g.materials, g.nodes, g.meshes, g.textures, g.images, g.samplers, g.accessors):
        for obj in coll or []:
            used_ext |= _extension_names(obj)
    for mesh in g.meshes or []:
        for prim in mesh.primitives:
            used_ext |= _extension_names(prim)
    for material in g.materials or []:
        for info in _texture_infos(material):
            used_ext |= _extension_names(info)
    items: set[str] = set()
    for name in sorted(used_ext - GLTF_EXTENSIONS):
        if name in _BSDF_EXTENSIONS:
            items.add(f"{name} (changes the BSDF; not implemented)")
        else:
            items.add(f"extension {name}")
    for mesh in g.meshes or []:
        for prim in mesh.primitives:
            attrs = {k for k, v in vars(prim.attributes).items() if v is not None}
            for name in sorted(attrs - GLTF_ATTRIBUTES):
                items.add(f"attribute {name}")
            if prim.targets:
                items.add("morph targets")
    if g.skins:
        items.add("skins")
    if g.animations:
        items.add("animations")
    if g.cameras:
        items.add("cameras (the scene file's camera is used)")
    return sorted(items)


def _texture_infos(m) -> list:
    """The textureInfo objects of a glTF material (None where a slot is empty)."""
    pbr = m.pbrMetallicRoughness
    return [m.normalTexture, m.occlusionTexture, m.emissiveTexture,
            pbr.baseColorTexture if pbr is not None else None,
            pbr.metallicRoughnessTexture if pbr is not None else None]


def _warn_ignored(reader: "_GltfReader") -> None:
    """One warning line naming everything in the file the loader does not use."""
    items = _ignored_items(reader)
    if items:
        warnings.warn(f"{reader.path}: ignored (not supported): {'; '.join(items)}",
                      stacklevel=2)


_WRAP = {33071: "clamp", 33648: "mirror", 10497: "repeat"}
_MAG = {9728: "nearest", 9729: "linear"}
_MIN = {9728: "nearest", 9729: "linear", 9984: "nearest_mipmap_nearest",
        9985: "linear_mipmap_nearest", 9986: "nearest_mipmap_linear",
        9987: "linear_mipmap_linear"}


def _texture_sampling(reader: _GltfReader, info, what: str) -> TextureSampling:
    """The sampler, texCoord and ``KHR_texture_transform`` of a glTF textureInfo."""
    g = reader.gltf
    texcoord = int(info.texCoord or 0)
    kw = {}
    transform = (info.extensions or {}).get("KHR_texture_transform")
    if transform is not None:
        try:
            kw["offset"] = tuple(float(x) for x in transform.get("offset", (0.0, 0.0)))
            kw["rotation"] = float(transform.get("rotation", 0.0))
            kw["scale"] = tuple(float(x) for x in transform.get("scale", (1.0, 1.0)))
            texcoord = int(transform.get("texCoord", texcoord))
        except (TypeError, ValueError, AttributeError):
            raise InputError(f"{what} texture: malformed KHR_texture_transform {transform!r}",
                             where=reader.path) from None
        if len(kw["offset"]) != 2 or len(kw["scale"]) != 2:
            raise InputError(f"{what} texture: KHR_texture_transform offset and scale need 2 "
                             f"numbers", where=reader.path)
    if texcoord not in (0, 1):
        raise InputError(f"{what} texture reads TEXCOORD_{texcoord}; only sets 0 and 1 are "
                         f"supported", where=reader.path)
    tex = g.textures[info.index]
    if tex.sampler is not None:
        sampler = g.samplers[tex.sampler]
        kw["wrap"] = (_WRAP.get(sampler.wrapS or 10497), _WRAP.get(sampler.wrapT or 10497))
        kw["mag_filter"] = _MAG.get(sampler.magFilter or 9729)
        kw["min_filter"] = _MIN.get(sampler.minFilter or 9987)
        if None in kw["wrap"] or kw["mag_filter"] is None or kw["min_filter"] is None:
            raise InputError(f"sampler {tex.sampler} has an unknown wrap or filter mode "
                             f"({sampler.wrapS}, {sampler.wrapT}, {sampler.magFilter}, "
                             f"{sampler.minFilter})", where=reader.path)
    return TextureSampling(texcoord=texcoord, **kw).validated(f"{reader.path} ({what} texture)")


def _gltf_material(reader: _GltfReader, index: int | None) -> dict:
    """The :class:`Mesh` fields of glTF material ``index``: material, textures, sampling, normal
    scale, occlusion strength, double-sidedness, alpha mode, cutoff and factor, emission."""
    if index is None:  # the spec's default material: opaque, single-sided, white, rough metal
        return {"material": Material(albedo=(1.0, 1.0, 1.0), roughness=1.0, metallic=1.0),
                "textures": {}, "sampling": {}, "double_sided": False}
    gm = reader.gltf.materials[index]
    pbr = gm.pbrMetallicRoughness
    base = list(pbr.baseColorFactor) if pbr is not None and pbr.baseColorFactor else [1, 1, 1, 1]
    metallic = 1.0 if pbr is None or pbr.metallicFactor is None else float(pbr.metallicFactor)
    rough = 1.0 if pbr is None or pbr.roughnessFactor is None else float(pbr.roughnessFactor)
    material = Material(albedo=tuple(float(np.clip(c, 0.0, 1.0)) for c in base[:3]),
                        roughness=float(np.clip(rough, 0.0, 1.0)),
                        metallic=float(np.clip(metallic, 0.0, 1.0)))
    textures: dict[str, np.ndarray] = {}
    sampling: dict[str, TextureSampling] = {}
    slots = [("base_color", pbr.baseColorTexture if pbr else None),
             ("metallic_roughness", pbr.metallicRoughnessTexture if pbr else None),
             ("normal", gm.normalTexture), ("occlusion", gm.occlusionTexture),
             ("emissive", gm.emissiveTexture)]
    for key, info in slots:
        if info is None or info.index is None:
            continue
        what = key.replace("_", " ")
        img = reader.image(info.index, what)
        textures[key] = _color_texture(img) if key in ("base_color", "emissive") else img
        sampling[key] = _texture_sampling(reader, info, what)
    nt = gm.normalTexture
    normal_scale = 1.0 if nt is None or getattr(nt, "scale", None) is None else float(nt.scale)
    occ = gm.occlusionTexture
    strength = getattr(occ, "strength", None) if occ is not None else None
    emissive = np.asarray(gm.emissiveFactor if gm.emissiveFactor else [0, 0, 0], np.float64)
    ext = gm.extensions or {}
    if "KHR_materials_emissive_strength" in ext:
        emissive = emissive * float(ext["KHR_materials_emissive_strength"].get(
            "emissiveStrength", 1.0))
    if emissive.shape != (3,) or not np.isfinite(emissive).all() or emissive.min() < 0:
        raise InputError(f"material {index}: emissive {emissive.tolist()} must be 3 finite "
                         f"numbers >= 0", where=reader.path)
    cutoff = 0.5 if gm.alphaCutoff is None else float(gm.alphaCutoff)
    return {"material": material, "textures": textures, "sampling": sampling,
            "normal_scale": normal_scale,
            "occlusion_strength": 1.0 if strength is None else float(strength),
            "double_sided": bool(gm.doubleSided), "alpha_mode": gm.alphaMode or "OPAQUE",
            "alpha_cutoff": cutoff, "base_alpha": float(np.clip(base[3], 0.0, 1.0)),
            "emissive": tuple(float(c) for c in emissive)}


# ---- trimesh (OBJ, PLY, STL, OFF) --------------------------------------------------------------
def _load_trimesh(path: Path) -> list[Mesh]:
    logging.getLogger("trimesh").setLevel(logging.ERROR)  # it logs missing MTLs etc. per file
    scene = trimesh.load(str(path), force="scene", process=False)
    out: list[Mesh] = []
    for node in scene.graph.nodes_geometry:
        matrix, geom_name = scene.graph[node]
        geom = scene.geometry[geom_name]
        if not isinstance(geom, trimesh.Trimesh) or len(geom.faces) == 0:
            continue
        positions = np.asarray(geom.vertices, np.float32)
        indices = np.asarray(geom.faces, np.uint32)
        normals = np.asarray(geom.vertex_normals, np.float32)
        if normals.shape != positions.shape or not np.isfinite(normals).all():
            normals = smooth_normals(positions, indices)
        material, textures, uvs = Material(), {}, None
        visual = geom.visual
        if getattr(visual, "kind", None) == "texture":
            if visual.uv is not None and len(visual.uv) == len(positions):
                uvs = np.asarray(visual.uv, np.float32).copy()
                uvs[:, 1] = 1.0 - uvs[:, 1]  # OBJ/trimesh: v up; Mesh: v down (glTF)
            if visual.material is not None:
                material, textures = _trimesh_material(visual.material)
            if uvs is None:
                textures = {}
        mesh = Mesh(positions=positions, normals=_normalize(normals), uvs=uvs,
                    indices=indices, material=material, textures=textures, name=str(geom_name))
        m = np.asarray(matrix, np.float64)
        out.append(mesh.transformed(m) if not np.allclose(m, np.eye(4)) else mesh)
    return out


def _trimesh_material(mat) -> tuple[Material, dict[str, np.ndarray]]:
    if not isinstance(mat, PBRMaterial):
        mat = mat.to_pbr()
    base = mat.baseColorFactor
    base = (np.asarray(base, np.float64) / (255.0 if np.asarray(base).dtype.kind in "ui" else 1.0)
            if base is not None else np.ones(4))
    # Unlike glTF's defaults (1, 1), a material without these factors (OBJ) is a dielectric
    # with Material's default roughness.
    metallic = 0.0 if mat.metallicFactor is None else float(mat.metallicFactor)
    rough = Material().roughness if mat.roughnessFactor is None else float(mat.roughnessFactor)
    material = Material(albedo=tuple(float(np.clip(c, 0.0, 1.0)) for c in base[:3]),
                        roughness=float(np.clip(rough, 0.0, 1.0)),
                        metallic=float(np.clip(metallic, 0.0, 1.0)))
    textures = {}
    for key, img in (("base_color", mat.baseColorTexture),
                     ("metallic_roughness", mat.metallicRoughnessTexture),
                     ("normal", mat.normalTexture), ("occlusion", mat.occlusionTexture)):
        if img is None:
            continue
        arr = _pil_to_float(img)
        textures[key] = _color_texture(arr) if key == "base_color" else arr
    return material, textures
