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
sRGB-decoded. A texture image that is missing or cannot be decoded is the one exception to
"every problem is an error": a warning names the file and the image, and the material loads
without that map (its factors stay), as three.js does. Everything else in a file (extensions, material features, attributes,
skins, animations, cameras) is named in one warning per file (``warnings.warn``): nothing is
ignored silently.

OBJ (and PLY/STL/OFF): ``trimesh.load(path, force="scene", process=False)``; the scene graph's
transforms are applied, MTL materials become PBR parameters through trimesh
(``SimpleMaterial.to_pbr``: ``Kd`` is taken as linear, ``map_Kd`` as sRGB). OBJ texture
coordinates (v up) are flipped to the glTF convention (v down) used by :class:`Mesh`.

Meshes without normals get smooth, area-weighted normals.

One module per job: :mod:`.gltf` (glTF files and the warning of what they hold that is not used),
:mod:`.gltf_reader` (buffers, accessors, images, nodes, Draco), :mod:`.gltf_material` (materials
and texture samplers), :mod:`.trimesh_files` (OBJ, PLY, STL, OFF) and :mod:`.images` (texture
decoding); :func:`load_mesh`, here, picks the loader by suffix and validates what it returns.
"""
from __future__ import annotations

import functools
import os
import warnings
from pathlib import Path

import numpy as np

from ...errors import InputError
from ...scene.material import Material
from ..mesh import Mesh, MeshList
from .gltf import GLTF_ATTRIBUTES, GLTF_EXTENSIONS, _load_gltf, variant_names
from .trimesh_files import _load_trimesh

GLTF_SUFFIXES = (".gltf", ".glb")
TRIMESH_SUFFIXES = (".obj", ".ply", ".stl", ".off")

__all__ = ["GLTF_ATTRIBUTES", "GLTF_EXTENSIONS", "GLTF_SUFFIXES", "TRIMESH_SUFFIXES", "load_mesh",
           "material_variants"]


def material_variants(path: str | os.PathLike) -> tuple[str, ...]:
    """The names of a glTF file's ``KHR_materials_variants`` (file order), for a picker: () for
    other formats and for a file that cannot be read (loading it says why). The last few files'
    names are kept (a bounded cache keyed by path, size and modification time), so asking every
    frame reads a file once."""
    path = Path(path)
    if path.suffix.lower() not in GLTF_SUFFIXES or not path.is_file():
        return ()
    st = path.stat()
    return _variants_of(str(path.resolve()), st.st_size, st.st_mtime_ns)


@functools.lru_cache(maxsize=16)
def _variants_of(path: str, size: int, mtime_ns: int) -> tuple[str, ...]:
    import pygltflib

    try:
        gltf = pygltflib.GLTF2().load(path)
    except Exception:  # noqa: BLE001 - loading the file reports its problem, naming it
        return ()
    return tuple(variant_names(gltf)) if gltf is not None else ()


def load_mesh(path: str | os.PathLike, transform: np.ndarray | None = None,
              material_override: Material | None = None, variant: str | None = None
              ) -> MeshList:
    """Load every triangle mesh in ``path`` into world space, with the lights the file places
    (``.lights``: glTF ``KHR_lights_punctual``, moved by ``transform`` too).

    ``transform`` (``[4, 4]``, column vectors) is applied after the file's own node transforms.
    ``material_override`` replaces each mesh's material and drops its base colour,
    metallic-roughness, occlusion and emissive maps, vertex colours, emission and alpha modes (a
    normal map and the sidedness are kept: they are shape, not material). ``variant``: a glTF
    ``KHR_materials_variants`` name whose materials replace the defaults (None: the defaults);
    an unknown name, or a variant for another format, is one InputError.
    """
    path = Path(path)
    if not path.is_file():
        raise InputError("mesh file not found", where=path)
    suffix = path.suffix.lower()
    if suffix in GLTF_SUFFIXES:
        meshes = _guarded(lambda p: _load_gltf(p, variant), path, "glTF")
    elif variant is not None:
        raise InputError(f"material variant {variant!r}: variants are a glTF feature "
                         f"(KHR_materials_variants), not {suffix or 'this format'}'s", where=path)
    elif suffix in TRIMESH_SUFFIXES:
        meshes = _guarded(_load_trimesh, path, suffix[1:].upper())
    else:
        known = ", ".join(GLTF_SUFFIXES + TRIMESH_SUFFIXES)
        raise InputError(f"unsupported mesh format {suffix or '(no extension)'!r} "
                         f"(supported: {known})", where=path)
    lights = getattr(meshes, "lights", ())
    meshes = [m for m in meshes if m.triangle_count > 0]
    if not meshes:
        raise InputError("contains no triangles", where=path)
    if transform is not None:
        t = np.asarray(transform, np.float64)
        if t.shape != (4, 4) or not np.isfinite(t).all():
            raise InputError(f"transform must be a finite 4x4 matrix, got shape {t.shape}",
                             where=path)
        meshes = [m.transformed(t) for m in meshes]
        lights = tuple(li.transformed(t) for li in lights)
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
    return MeshList(out, lights)


def _guarded(loader, path: Path, kind: str) -> list[Mesh]:
    """Run ``loader`` and turn anything but an InputError into a one-line InputError. What the
    parsers warned about a file they then fail on is left out: the error says it."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            meshes = loader(path)
        except InputError:
            raise
        except Exception as exc:  # parsers raise anything: struct.error, KeyError, ValueError...
            detail = " ".join(str(exc).split())[:200]
            raise InputError(f"corrupt or unreadable {kind} file ({type(exc).__name__}"
                             f"{': ' + detail if detail else ''})", where=path) from None
    for w in caught:  # it loaded: every warning stands
        warnings.warn_explicit(w.message, w.category, w.filename, w.lineno)
    return meshes
