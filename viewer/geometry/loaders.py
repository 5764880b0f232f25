"""Mesh files: glTF 2.0 (``.gltf``, ``.glb``) via pygltflib; OBJ (+MTL), PLY, STL, OFF via trimesh.

Every problem with a file (missing, corrupt, truncated, unsupported, no triangles) is an
:class:`~viewer.errors.InputError` whose one-line message names the file; library exceptions are
never let through.

glTF: the default scene's node hierarchy is flattened (node matrices or TRS applied), one
:class:`Mesh` per primitive. Read: POSITION, NORMAL, TEXCOORD_n, TANGENT, indices (triangles,
strips, fans), baseColorFactor/Texture, metallicFactor, roughnessFactor, metallicRoughnessTexture,
normalTexture (+ scale), occlusionTexture (+ strength). Textures decode to float32 in [0, 1];
base colour is sRGB-decoded. Everything else in a file (extensions, material features, attributes,
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
from .mesh import Mesh, _normalize, smooth_normals, srgb_to_linear

log = logging.getLogger(__name__)

GLTF_SUFFIXES = (".gltf", ".glb")
TRIMESH_SUFFIXES = (".obj", ".ply", ".stl", ".off")
_UNSUPPORTED_EXTENSIONS = ("KHR_draco_mesh_compression", "EXT_meshopt_compression")
# glTF extensions this loader implements; any other one a file uses is named in a warning
GLTF_EXTENSIONS: frozenset[str] = frozenset()
# the primitive attributes it reads (others: JOINTS_n, WEIGHTS_n, COLOR_n, TEXCOORD_n, _CUSTOM)
GLTF_ATTRIBUTES = frozenset({"POSITION", "NORMAL", "TANGENT", "TEXCOORD_0", "TEXCOORD_1"})


def load_mesh(path: str | os.PathLike, transform: np.ndarray | None = None,
              material_override: Material | None = None) -> list[Mesh]:
    """Load every triangle mesh in ``path`` into world space.

    ``transform`` (``[4, 4]``, column vectors) is applied after the file's own node transforms.
    ``material_override`` replaces each mesh's material and drops its base colour,
    metallic-roughness and occlusion maps (a normal map is kept: it is shape, not material).
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
        if material_override is not None:
            m.material = material_override
            m.textures = {k: v for k, v in m.textures.items() if k == "normal"}
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

    def accessor(self, index: int) -> np.ndarray:
        """Accessor ``index`` as a ``[count, components]`` array (normalised ints -> float32)."""
        acc = self.gltf.accessors[index]
        if acc.sparse is not None:
            raise InputError(f"accessor {index} is sparse (not supported)", where=self.path)
        dtype = np.dtype(_COMPONENT[acc.componentType])
        nc = _NCOMP[acc.type]
        if acc.bufferView is None:
            return np.zeros((acc.count, nc), dtype)
        bv = self.gltf.bufferViews[acc.bufferView]
        data = self.buffer(bv.buffer)
        start = (bv.byteOffset or 0) + (acc.byteOffset or 0)
        stride = bv.byteStride or dtype.itemsize * nc
        end = start + stride * max(acc.count - 1, 0) + dtype.itemsize * nc
        if acc.count and end > len(data):
            raise InputError(f"accessor {index} runs past the end of buffer {bv.buffer} "
                             f"({end} > {len(data)} bytes; truncated file?)", where=self.path)
        arr = np.ndarray((acc.count, nc), dtype, buffer=data, offset=start,
                         strides=(stride, dtype.itemsize)).copy()
        if acc.normalized and dtype.kind in "iu":
            info = np.iinfo(dtype)
            arr = np.maximum(arr.astype(np.float32) / info.max, -1.0)
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


def _load_gltf(path: Path) -> list[Mesh]:
    reader = _GltfReader(path)
    g = reader.gltf
    out: list[Mesh] = []
    skipped = 0
    for mesh_index, world in reader.node_matrices():
        gmesh = g.meshes[mesh_index]
        for prim_index, prim in enumerate(gmesh.primitives):
            mode = 4 if prim.mode is None else prim.mode
            attrs = prim.attributes
            if attrs.POSITION is None:
                skipped += 1
                continue
            positions = reader.accessor(attrs.POSITION).astype(np.float32)
            indices = (reader.accessor(prim.indices) if prim.indices is not None
                       else np.arange(len(positions), dtype=np.uint32))
            tris = _triangles(indices, mode)
            if tris is None or len(tris) == 0:
                skipped += 1
                continue
            if int(tris.max()) >= len(positions):
                raise InputError(f"mesh {mesh_index} primitive {prim_index} has an index out of "
                                 f"range", where=path)
            normals = (reader.accessor(attrs.NORMAL).astype(np.float32)
                       if attrs.NORMAL is not None else smooth_normals(positions, tris))
            tangents = (reader.accessor(attrs.TANGENT).astype(np.float32)
                        if attrs.TANGENT is not None else None)
            material, textures, scales, texcoord = _gltf_material(reader, prim.material)
            uv_attr = getattr(attrs, f"TEXCOORD_{texcoord}", None)
            uvs = reader.accessor(uv_attr).astype(np.float32) if uv_attr is not None else None
            if uvs is None and textures:
                log.warning("%s: mesh %d has textures but no TEXCOORD_%d; textures ignored",
                            path, mesh_index, texcoord)
                textures = {}
            name = gmesh.name or f"mesh{mesh_index}"
            if len(gmesh.primitives) > 1:
                name += f".{prim_index}"
            mesh = Mesh(positions=positions, normals=_normalize(normals), uvs=uvs,
                        tangents=tangents, indices=tris, material=material, textures=textures,
                        normal_scale=scales[0], occlusion_strength=scales[1], name=name)
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
    for index, material in enumerate(g.materials or []):
        items.update(f"{what} (material {index})" for what in _ignored_material_features(material))
    if g.samplers and _SAMPLERS_IGNORED:
        items.add("texture sampler wrap/filter modes")
    if g.skins:
        items.add("skins")
    if g.animations:
        items.add("animations")
    if g.cameras:
        items.add("cameras (the scene file's camera is used)")
    return sorted(items)


_SAMPLERS_IGNORED = True


def _ignored_material_features(m) -> list[str]:
    out = []
    if (m.alphaMode or "OPAQUE") != "OPAQUE":
        out.append(f"alphaMode {m.alphaMode}")
    if not m.doubleSided:
        out.append("doubleSided false (drawn double-sided)")
    if m.emissiveTexture is not None or any(float(c) != 0.0 for c in (m.emissiveFactor or [])):
        out.append("emission")
    return out


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


def _gltf_material(reader: _GltfReader, index: int | None):
    """(Material, textures, (normal_scale, occlusion_strength), texcoord set) of a glTF material."""
    if index is None:
        return Material(), {}, (1.0, 1.0), 0
    gm = reader.gltf.materials[index]
    pbr = gm.pbrMetallicRoughness
    base = list(pbr.baseColorFactor) if pbr is not None and pbr.baseColorFactor else [1, 1, 1, 1]
    metallic = 1.0 if pbr is None or pbr.metallicFactor is None else float(pbr.metallicFactor)
    rough = 1.0 if pbr is None or pbr.roughnessFactor is None else float(pbr.roughnessFactor)
    material = Material(albedo=tuple(float(np.clip(c, 0.0, 1.0)) for c in base[:3]),
                        roughness=float(np.clip(rough, 0.0, 1.0)),
                        metallic=float(np.clip(metallic, 0.0, 1.0)))
    textures: dict[str, np.ndarray] = {}
    texcoords = []
    slots = [("base_color", pbr.baseColorTexture if pbr else None),
             ("metallic_roughness", pbr.metallicRoughnessTexture if pbr else None),
             ("normal", gm.normalTexture), ("occlusion", gm.occlusionTexture)]
    for key, info in slots:
        if info is None or info.index is None:
            continue
        img = reader.image(info.index, key.replace("_", " "))
        textures[key] = _color_texture(img) if key == "base_color" else img
        texcoords.append(info.texCoord or 0)
    if len(set(texcoords)) > 1:
        warnings.warn(f"{reader.path}: material {index} mixes texture coordinate sets "
                      f"{sorted(set(texcoords))}; using TEXCOORD_{texcoords[0]} for all")
    nt = gm.normalTexture
    normal_scale = 1.0 if nt is None or getattr(nt, "scale", None) is None else float(nt.scale)
    occ = gm.occlusionTexture
    strength = getattr(occ, "strength", None) if occ is not None else None
    return material, textures, (normal_scale, 1.0 if strength is None else float(strength)), \
        (texcoords[0] if texcoords else 0)


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
