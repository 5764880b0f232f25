"""glTF materials as :class:`~viewer.geometry.mesh.Mesh` fields: factors, textures and each
texture's sampler, texCoord and ``KHR_texture_transform``."""
from __future__ import annotations

import dataclasses
import math
import warnings
from types import SimpleNamespace

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
    ext = gm.extensions or {}
    material, ext_slots = _dielectric(reader, index, material, ext)
    material, coat_slots, coat_normal_scale = _clearcoat(reader, index, material, ext)
    ext_slots += coat_slots
    material, transmission_slots = _transmission(reader, index, material, ext)
    ext_slots += transmission_slots
    material, sheen_slots = _sheen(reader, index, material, ext)
    ext_slots += sheen_slots
    material, anisotropy_slots = _anisotropy(reader, index, material, ext)
    ext_slots += anisotropy_slots
    material, film_slots = _iridescence(reader, index, material, ext)
    ext_slots += film_slots
    slots = [("base_color", pbr.baseColorTexture if pbr else None),
             ("metallic_roughness", pbr.metallicRoughnessTexture if pbr else None),
             ("normal", gm.normalTexture), ("occlusion", gm.occlusionTexture),
             ("emissive", gm.emissiveTexture)] + ext_slots
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
        if key in ("base_color", "emissive", "specular_color", "sheen_color"):
            img = _color_texture(img)
        elif key in ("specular", "sheen_roughness") and img.shape[2] < 4:  # glTF: no alpha channel reads as A = 1
            img = np.concatenate([img, np.ones_like(img[:, :, :1])], axis=2)
        textures[key] = img
        sampling[key] = _texture_sampling(reader, info, what)
    nt = gm.normalTexture
    normal_scale = 1.0 if nt is None or getattr(nt, "scale", None) is None else float(nt.scale)
    occ = gm.occlusionTexture
    strength = getattr(occ, "strength", None) if occ is not None else None
    emissive = np.asarray(gm.emissiveFactor if gm.emissiveFactor else [0, 0, 0], np.float64)
    if "KHR_materials_emissive_strength" in ext:
        emissive = emissive * _number(reader, index, ext["KHR_materials_emissive_strength"],
                                      "emissiveStrength", 1.0, 0.0, math.inf)
    if emissive.shape != (3,) or not np.isfinite(emissive).all() or emissive.min() < 0:
        raise InputError(f"material {index}: emissive {emissive.tolist()} must be 3 finite "
                         f"numbers >= 0", where=reader.path)
    cutoff = 0.5 if gm.alphaCutoff is None else float(gm.alphaCutoff)
    unlit = "KHR_materials_unlit" in ext
    if unlit:
        material, emissive = _unlit(material, base, textures, sampling)
    return {"unlit": unlit, "clearcoat_normal_scale": coat_normal_scale, "material": material, "textures": textures, "sampling": sampling,
            "normal_scale": normal_scale,
            "occlusion_strength": 1.0 if strength is None else float(strength),
            "double_sided": bool(gm.doubleSided), "alpha_mode": gm.alphaMode or "OPAQUE",
            "alpha_cutoff": cutoff, "base_alpha": float(np.clip(base[3], 0.0, 1.0)),
            "emissive": tuple(float(c) for c in emissive)}


def _unlit(material: Material, base, textures: dict, sampling: dict):
    """``KHR_materials_unlit``: the base colour shown as is, as every lighting model shows it:
    a black material (no diffuse, no specular lobe) emitting the base colour (factor times map;
    the base-colour map stays for its alpha). Every other property is the extension's to ignore
    (normal, occlusion, metallic-roughness and emissive maps are dropped)."""
    for key in ("metallic_roughness", "normal", "occlusion", "emissive", "specular",
                "specular_color", "clearcoat", "clearcoat_roughness", "clearcoat_normal",
                "sheen_color", "sheen_roughness", "anisotropy", "iridescence",
                "iridescence_thickness", "transmission", "thickness"):
        textures.pop(key, None)
        sampling.pop(key, None)
    if "base_color" in textures:
        textures["emissive"] = np.ascontiguousarray(textures["base_color"][..., :3])
        sampling["emissive"] = sampling["base_color"]
    black = Material(albedo=(0.0, 0.0, 0.0), roughness=1.0, metallic=0.0, specular=0.0)
    return black, np.asarray([float(np.clip(c, 0.0, 1.0)) for c in base[:3]], np.float64)


def _number(reader: _GltfReader, index: int, table, key: str, default: float, lo: float,
            hi: float) -> float:
    """Extension property ``key`` of material ``index`` (``default`` when absent), a finite
    number in [lo, hi]; anything else is one InputError naming the file."""
    value = table.get(key, default) if isinstance(table, dict) else None
    try:
        x = float(value)
    except (TypeError, ValueError):
        x = math.nan
    if isinstance(value, bool) or not (lo <= x <= hi) or not math.isfinite(x):
        raise InputError(f"material {index}: {key} = {value!r} must be a number in "
                         f"[{lo:g}, {hi:g}]", where=reader.path)
    return x


def _color(reader: _GltfReader, index: int, table, key: str, default: float, hi: float
           ) -> tuple[float, float, float]:
    """Extension property ``key`` of material ``index``: 3 numbers in [0, hi] (each ``default``
    when absent); anything else is one InputError naming the file."""
    color = table.get(key, [default] * 3) if isinstance(table, dict) else None
    if not isinstance(color, list) or len(color) != 3:
        bound = ">= 0" if hi == math.inf else f"in [0, {hi:g}]"
        raise InputError(f"material {index}: {key} {color!r} must be 3 numbers {bound}",
                         where=reader.path)
    return tuple(_number(reader, index, {key: c}, key, default, 0.0, hi) for c in color)


def _texture_info(reader: _GltfReader, index: int, info, what: str):
    """An extension's textureInfo (a JSON object) as the attribute access of pygltflib's."""
    if info is None:
        return None
    if not isinstance(info, dict) or not isinstance(info.get("index"), int) or \
            not 0 <= info["index"] < len(reader.gltf.textures or ()):
        raise InputError(f"material {index}: {what} {info!r} is not a textureInfo with a valid "
                         f"index", where=reader.path)
    return SimpleNamespace(index=info["index"], texCoord=info.get("texCoord", 0),
                           extensions=info.get("extensions"))


def _dielectric(reader: _GltfReader, index: int, material: Material, ext: dict):
    """``KHR_materials_ior`` and ``KHR_materials_specular`` of material ``index``: the material
    with its glTF dielectric lobe (``ior``, ``specular_color``, ``specular_factor``) and the
    texture slots of the specular extension. Unchanged without either extension."""
    if "KHR_materials_ior" not in ext and "KHR_materials_specular" not in ext:
        return material, []
    ior = _number(reader, index, ext.get("KHR_materials_ior", {}), "ior", 1.5, 0.0, math.inf)
    if 0.0 < ior < 1.0:
        raise InputError(f"material {index}: KHR_materials_ior ior = {ior:g} must be 0 "
                         f"(infinite) or >= 1", where=reader.path)
    spec = ext.get("KHR_materials_specular", {})
    factor = _number(reader, index, spec, "specularFactor", 1.0, 0.0, 1.0)
    color = _color(reader, index, spec, "specularColorFactor", 1.0, math.inf)
    slots = [("specular", _texture_info(reader, index, spec.get("specularTexture"),
                                        "specularTexture")),
             ("specular_color", _texture_info(reader, index, spec.get("specularColorTexture"),
                                              "specularColorTexture"))]
    material = Material(albedo=material.albedo, roughness=material.roughness,
                        metallic=material.metallic, ior=ior, specular_color=color,
                        specular_factor=factor)
    return material, slots


def _clearcoat(reader: _GltfReader, index: int, material: Material, ext: dict):
    """``KHR_materials_clearcoat`` of material ``index``: the material with its coat factor and
    roughness, the coat's texture slots and its normal map's scale."""
    coat = ext.get("KHR_materials_clearcoat")
    if coat is None:
        return material, [], 1.0
    factor = _number(reader, index, coat, "clearcoatFactor", 0.0, 0.0, 1.0)
    rough = _number(reader, index, coat, "clearcoatRoughnessFactor", 0.0, 0.0, 1.0)
    normal = coat.get("clearcoatNormalTexture")
    scale = 1.0 if not isinstance(normal, dict) else _number(reader, index, normal, "scale", 1.0,
                                                             -math.inf, math.inf)
    slots = [(key, _texture_info(reader, index, coat.get(name), name))
             for key, name in (("clearcoat", "clearcoatTexture"),
                               ("clearcoat_roughness", "clearcoatRoughnessTexture"),
                               ("clearcoat_normal", "clearcoatNormalTexture"))]
    return dataclasses.replace(material, clearcoat=factor, clearcoat_roughness=rough), slots, scale


def _transmission(reader: _GltfReader, index: int, material: Material, ext: dict):
    """``KHR_materials_transmission``, ``KHR_materials_volume`` and ``KHR_materials_dispersion``
    of material ``index``: the material with its transmission factor, thickness (0:
    thin-walled), attenuation and dispersion, and the texture slots (transmissionTexture: R x
    the factor; thicknessTexture: G x thicknessFactor)."""
    trans = ext.get("KHR_materials_transmission")
    volume = ext.get("KHR_materials_volume")
    disp = _number(reader, index, ext.get("KHR_materials_dispersion", {}), "dispersion", 0.0,
                   0.0, math.inf)  # 20 / V_d; without a volume it has no effect (the spec)
    if trans is None and volume is None:
        return material, []
    factor = _number(reader, index, trans or {}, "transmissionFactor", 0.0, 0.0, 1.0)
    volume = volume if volume is not None else {}
    thickness = _number(reader, index, volume, "thicknessFactor", 0.0, 0.0, math.inf)
    distance = volume.get("attenuationDistance", math.inf) if isinstance(volume, dict) else None
    if distance != math.inf:
        distance = _number(reader, index, volume, "attenuationDistance", 1.0, 1e-30, math.inf)
    color = _color(reader, index, volume, "attenuationColor", 1.0, 1.0)
    slots = [(key, _texture_info(reader, index, table.get(name), name))
             for key, table, name in (("transmission", trans or {}, "transmissionTexture"),
                                      ("thickness", volume, "thicknessTexture"))]
    return dataclasses.replace(material, transmission=factor, thickness=thickness,
                               attenuation_color=color, attenuation_distance=float(distance),
                               dispersion=disp), slots


def _sheen(reader: _GltfReader, index: int, material: Material, ext: dict):
    """``KHR_materials_sheen`` of material ``index``: the material with its sheen colour and
    roughness, and the sheen's texture slots (colour: RGB, sRGB-encoded; roughness: A)."""
    sheen = ext.get("KHR_materials_sheen")
    if sheen is None:
        return material, []
    color = _color(reader, index, sheen, "sheenColorFactor", 0.0, 1.0)
    rough = _number(reader, index, sheen, "sheenRoughnessFactor", 0.0, 0.0, 1.0)
    slots = [(key, _texture_info(reader, index, sheen.get(name), name))
             for key, name in (("sheen_color", "sheenColorTexture"),
                               ("sheen_roughness", "sheenRoughnessTexture"))]
    return dataclasses.replace(material, sheen_color=color, sheen_roughness=rough), slots


def _anisotropy(reader: _GltfReader, index: int, material: Material, ext: dict):
    """``KHR_materials_anisotropy`` of material ``index``: the material with its strength and
    rotation (radians), and the texture slot (direction in RG as [0, 1] -> [-1, 1], strength
    in B; linear)."""
    aniso = ext.get("KHR_materials_anisotropy")
    if aniso is None:
        return material, []
    strength = _number(reader, index, aniso, "anisotropyStrength", 0.0, 0.0, 1.0)
    rotation = _number(reader, index, aniso, "anisotropyRotation", 0.0, -math.inf, math.inf)
    slots = [("anisotropy", _texture_info(reader, index, aniso.get("anisotropyTexture"),
                                          "anisotropyTexture"))]
    return dataclasses.replace(material, anisotropy_strength=strength,
                               anisotropy_rotation=rotation), slots


def _iridescence(reader: _GltfReader, index: int, material: Material, ext: dict):
    """``KHR_materials_iridescence`` of material ``index``: the material with its film (factor,
    IOR, thickness range in nm) and the film's texture slots (factor: R; thickness: G, linear)."""
    film = ext.get("KHR_materials_iridescence")
    if film is None:
        return material, []
    if not isinstance(film, dict):
        raise InputError(f"material {index}: KHR_materials_iridescence {film!r} is not an "
                         f"object", where=reader.path)
    factor = _number(reader, index, film, "iridescenceFactor", 0.0, 0.0, 1.0)
    # the ratified name; early drafts (and some exporters) spelled it iridescenceIOR
    key = "iridescenceIOR" if "iridescenceIOR" in film and "iridescenceIor" not in film \
        else "iridescenceIor"
    ior = _number(reader, index, film, key, 1.3, 1.0, math.inf)
    lo = _number(reader, index, film, "iridescenceThicknessMinimum", 100.0, 0.0, math.inf)
    hi = _number(reader, index, film, "iridescenceThicknessMaximum", 400.0, 0.0, math.inf)
    slots = [(key, _texture_info(reader, index, film.get(name), name))
             for key, name in (("iridescence", "iridescenceTexture"),
                               ("iridescence_thickness", "iridescenceThicknessTexture"))]
    return dataclasses.replace(material, iridescence=factor, iridescence_ior=ior,
                               iridescence_thickness_min=lo,
                               iridescence_thickness_max=hi), slots
