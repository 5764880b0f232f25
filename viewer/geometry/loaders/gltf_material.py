"""glTF materials as :class:`~viewer.geometry.mesh.Mesh` fields: factors, textures and each
texture's sampler, texCoord and ``KHR_texture_transform``."""
from __future__ import annotations

import warnings

import numpy as np

from ...errors import InputError
from ...scene.material import Material
from ..mesh import TextureSampling
from .gltf_reader import ImageUnavailable, _GltfReader
from .images import _color_texture

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
    """The :class:`~viewer.geometry.mesh.Mesh` fields of glTF material ``index``: material,
    textures, sampling, normal scale, occlusion strength, double-sidedness, alpha mode, cutoff and
    factor, emission."""
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
        try:
            img = reader.image(info.index, what)
        except ImageUnavailable as exc:
            name = key.replace("_", "-").replace("color", "colour")
            message = f"{exc}; rendered without its {name} map (the material's factors stay)"
            if message not in reader.unavailable_warned:
                reader.unavailable_warned.add(message)
                warnings.warn(message, stacklevel=4)
            continue
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
