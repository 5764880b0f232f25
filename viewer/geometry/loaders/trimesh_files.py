"""OBJ (+MTL), PLY, STL and OFF files as meshes, through trimesh: the scene graph's transforms
applied, MTL materials as PBR parameters, OBJ texture coordinates flipped to glTF's (v down)."""
from __future__ import annotations

import logging
from pathlib import Path

import numpy as np
import trimesh
from trimesh.visual.material import PBRMaterial

from ...scene.material import Material
from ..mesh import Mesh, _normalize, smooth_normals
from .images import _color_texture, _pil_to_float


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
