"""glTF 2.0 files (``.gltf``, ``.glb``) as meshes: one :class:`~viewer.geometry.mesh.Mesh` per
triangle primitive of the flattened default scene, the lights its nodes place
(``KHR_lights_punctual``: :mod:`.gltf_lights`) and one warning naming everything in the file the
loader does not use."""
from __future__ import annotations

import logging
import warnings
from pathlib import Path

import numpy as np

from ...errors import InputError
from ..mesh import Mesh, MeshList, _normalize, smooth_normals
from .gltf_material import _gltf_material
from .gltf_lights import gltf_lights
from .gltf_reader import _draco_attributes, _GltfReader

log = logging.getLogger(__package__)  # the loaders' logger, viewer.geometry.loaders


# glTF extensions this loader implements; any other one a file uses is named in a warning
GLTF_EXTENSIONS = frozenset({"KHR_texture_transform", "KHR_mesh_quantization",
                             "KHR_materials_emissive_strength", "KHR_draco_mesh_compression",
                             "KHR_lights_punctual", "KHR_materials_ior", "KHR_materials_specular",
                             "KHR_materials_unlit", "KHR_materials_clearcoat",
                             "KHR_materials_transmission", "KHR_materials_volume",
                             "KHR_materials_variants", "KHR_materials_sheen",
                             "KHR_materials_anisotropy", "KHR_materials_iridescence",
                             "KHR_materials_dispersion"})
# the primitive attributes it reads (others: JOINTS_n, WEIGHTS_n, COLOR_1.., TEXCOORD_2..,
# _CUSTOM)
GLTF_ATTRIBUTES = frozenset({"POSITION", "NORMAL", "TANGENT", "TEXCOORD_0", "TEXCOORD_1",
                             "COLOR_0"})


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


def variant_names(gltf) -> list[str]:
    """The names of a glTF's ``KHR_materials_variants`` (file order; [] without any)."""
    table = (gltf.extensions or {}).get("KHR_materials_variants") or {}
    variants = table.get("variants", []) if isinstance(table, dict) else []
    return [str(v.get("name", f"variant{i}")) if isinstance(v, dict) else f"variant{i}"
            for i, v in enumerate(variants if isinstance(variants, list) else [])]


def _variant_index(reader, variant: str | None) -> int | None:
    """The index of ``variant`` among the file's variants (None: the default materials); an
    unknown name is one InputError listing the names."""
    if variant is None:
        return None
    names = variant_names(reader.gltf)
    if variant not in names:
        have = f"its variants are: {', '.join(names)}" if names else "it has no variants"
        raise InputError(f"material variant {variant!r} is not in the file "
                         f"(KHR_materials_variants; {have})", where=reader.path)
    return names.index(variant)


def _variant_material(reader, prim, index: int | None, where: str):
    """The primitive's material under variant ``index``: the mapping naming it, else its own
    (KHR_materials_variants: a primitive no mapping names keeps its default)."""
    if index is None:
        return prim.material
    table = (prim.extensions or {}).get("KHR_materials_variants") or {}
    for m in table.get("mappings", []) if isinstance(table, dict) else []:
        if isinstance(m, dict) and index in (m.get("variants") or []):
            material = m.get("material")
            if not isinstance(material, int) or not \
                    0 <= material < len(reader.gltf.materials or ()):
                raise InputError(f"{where}: KHR_materials_variants mapping names material "
                                 f"{material!r}, not one of the file's", where=reader.path)
            return material
    return prim.material


def _load_gltf(path: Path, variant: str | None = None) -> MeshList:
    reader = _GltfReader(path)
    g = reader.gltf
    chosen = _variant_index(reader, variant)
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
            fields = _gltf_material(reader, _variant_material(reader, prim, chosen, where))
            for key, sampling in list(fields["sampling"].items()):
                if uv_sets[sampling.texcoord] is None:
                    warnings.warn(f"{path}: {where}: the {key} texture reads TEXCOORD_"
                                  f"{sampling.texcoord}, which the primitive lacks; texture "
                                  f"ignored", stacklevel=3)
                    del fields["textures"][key], fields["sampling"][key]
            if fields["material"].has_anisotropy and tangents is None and uv_sets[0] is None \
                    and uv_sets[1] is None:
                warnings.warn(f"{path}: {where}: KHR_materials_anisotropy needs a tangent space "
                              f"(TANGENT or TEXCOORD_n), which the primitive lacks; its direction "
                              f"is arbitrary", stacklevel=3)
            name = gmesh.name or f"mesh{mesh_index}"
            if len(gmesh.primitives) > 1:
                name += f".{prim_index}"
            mesh = Mesh(positions=positions, normals=_normalize(normals), uvs=uv_sets[0],
                        uvs1=uv_sets[1], colors=colors, tangents=tangents, indices=tris,
                        name=name, **fields)
            out.append(mesh.transformed(world) if not np.allclose(world, np.eye(4)) else mesh)
    if skipped:
        log.info("%s: skipped %d non-triangle primitives", path, skipped)
    lights, unused = gltf_lights(reader)
    _warn_ignored(reader, unused)
    return MeshList(out, lights)


# KHR_materials_* extensions that change the BSDF and are not implemented: named as such
# (ior, specular, unlit, clearcoat, transmission, volume, sheen, anisotropy, iridescence and
# dispersion are: loaders/gltf_material.py)
_BSDF_EXTENSIONS = ("KHR_materials_diffuse_transmission", "KHR_materials_pbrSpecularGlossiness")


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


def _warn_ignored(reader: "_GltfReader", extra: list[str] = ()) -> None:
    """One warning line naming everything in the file the loader does not use (``extra``: what
    of KHR_lights_punctual was not used)."""
    items = sorted(set(_ignored_items(reader)) | set(extra))
    if items:
        warnings.warn(f"{reader.path}: ignored (not supported): {'; '.join(items)}",
                      stacklevel=2)
