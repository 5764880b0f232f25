"""A workbench :class:`~viewer.scene.description.Scene` as a Mitsuba 3 scene: the same environment (texels,
orientation, rotation, intensity), analytic spheres, planes and the
material-ball grid as the rasteriser builds them, glTF/OBJ meshes through the project's own
loader (so the reference sees exactly the triangles, normals, UVs and texture maps the G-buffer
pass does), :class:`~relight.reference.bsdf` for every surface, and every punctual light
(:mod:`relight.reference.lights`). The camera is not converted:
:mod:`relight.reference.render` traces the rasteriser's own per-pixel rays."""
from __future__ import annotations

import json
import struct
import warnings
from pathlib import Path

import numpy as np

from viewer.environment.maps import load_environment
from viewer.errors import RelightError
from viewer.geometry import primitives
from viewer.geometry.cache import GeometryCache
from viewer.lighting.lights import gather_lights
from viewer.scene.bounds import points_bounds
from viewer.scene.description import Scene
from viewer.scene.material import Material

from .bsdf import bsdf_class
from .lights import mitsuba_light

TRACEABLE = ("sphere", "plane", "material_grid", "mesh")
GEOMETRIES = ("mesh", "analytic")
# Mitsuba's ``path`` integrator lets a ``mask`` BSDF block every shadow ray (``ray_test`` sees
# the surface, cut out or not) and spends a bounce on each pass through; ``volpath`` (no media
# here) carries shadow rays through by ``eval_null_transmission`` and counts only real bounces,
# so a scene with alpha coverage is traced with it. Scenes without keep ``path`` (same images).
MASKED_INTEGRATOR = "volpath"
# alphaMode MASK as an opacity texture: (alpha - cutoff) x slope + 1 per texel, which the bitmap
# interpolates (bilinear: linear in alpha) and ``mask`` clamps to [0, 1], so opacity is 1 where
# the *interpolated* alpha >= cutoff (the rasteriser's test) and 0 below cutoff - 1 / slope
# (a band of 1.5e-5 in alpha; float32 texel values up to 6.6e4 keep ~1e-7 of it)
CUTOFF_SLOPE = 65536.0
# how alphaMode is traced, in the key of cached truths (render.config_key) of scenes that have
# one: 1 = MASK / BLEND coverage (before it: traced opaque, unversioned)
ALPHA_TRACING = 1


class ReferenceError(RelightError):
    """A scene the reference renderer cannot path-trace, or Mitsuba missing/failing."""


def check_traceable(scene: Scene) -> None:
    """One-line :class:`ReferenceError` for objects with no path-traceable geometry."""
    for i, obj in enumerate(scene.objects):
        if obj.type not in TRACEABLE:
            raise ReferenceError(
                f"objects[{i}] is {obj.type!r}, which has no path-traceable geometry "
                f"(relight reference renders {', '.join(TRACEABLE)})",
                where=scene.source or "scene")
        if obj.shadow_only:
            raise ReferenceError(
                f"objects[{i}] is a shadow caster only (shadow_only): the path tracer has no "
                "object its camera does not see",
                where=scene.source or "scene")
    if not scene.objects:
        raise ReferenceError("the scene has no objects to path-trace (splats and image-space "
                             "stacks added in memory have no geometry either)",
                             where=scene.source or "scene")


def alpha_modes(scene: Scene) -> list[str]:
    """The alphaMode values other than OPAQUE that the glTF files of ``scene``'s mesh objects
    declare, read from their JSON alone (no geometry, so a cache lookup stays cheap); a file
    that cannot be read adds nothing (loading it reports the problem)."""
    found = set()
    for obj in scene.objects:
        path = Path(obj.path) if obj.type == "mesh" and obj.path else None
        if path is None or path.suffix.lower() not in (".gltf", ".glb"):
            continue
        try:
            with path.open("rb") as f:
                if path.suffix.lower() == ".glb":  # header (12 bytes), then the JSON chunk
                    f.seek(12)
                    length, _ = struct.unpack("<II", f.read(8))
                    doc = json.loads(f.read(length))
                else:
                    doc = json.load(f)
        except (OSError, ValueError, struct.error):
            continue
        found.update(str(m.get("alphaMode", "OPAQUE")) for m in doc.get("materials", ())
                     if isinstance(m, dict))
    found.discard("OPAQUE")
    return sorted(found)


def environment_bitmap(scene: Scene) -> np.ndarray:
    """The scene's environment as a bitmap for Mitsuba's ``envmap`` that reproduces the
    rasteriser's lookup *exactly*.

    The rasteriser reads texel centres bilinearly, u = (j + 0.5) / W (wrapping) and
    v = (i + 0.5) / H (clamped), with u = atan2(x, -z) / 2pi + 0.5. Mitsuba's ``envmap``
    (measured: tests/reference) also puts column j at u = (j + 0.5) / W, but with
    u = atan2(x, -z) / 2pi, so the columns are rolled by half the width; its rows, however, sit
    at v = i / (H - 1), first and last on the poles. Our lookup is piecewise bilinear in v with
    knots on the row-centre lines; sampled at v = i / 2H, a grid that contains every knot line,
    Mitsuba's linear interpolation of the samples gives back the same function. So the bitmap is
    ``[2H + 1, W]``, equal to our lookup wherever it is evaluated, up to float rounding."""
    env = load_environment(scene.environment).astype(np.float64)
    h, w = env.shape[:2]
    env = np.roll(env, -(w // 2), axis=1)
    v = np.arange(2 * h + 1) / (2 * h)
    y = np.clip(v * h - 0.5, 0.0, h - 1.0)
    y0 = np.minimum(np.floor(y).astype(np.int64), h - 2)
    fy = (y - y0)[:, None, None]
    return np.ascontiguousarray(env[y0] * (1 - fy) + env[y0 + 1] * fy, dtype=np.float32)


def to_mitsuba(scene: Scene, mi, dr, max_depth: int, geometry: str = "mesh") -> dict:
    """The ``mi.load_dict`` dictionary of ``scene`` (integrator ``path`` with ``max_depth``,
    Russian roulette off so the standard error is the plain sample variance's). ``geometry``:
    ``"mesh"`` traces the rasteriser's own triangles (tessellated spheres: the reference then
    differs from a render by shading alone, the default); ``"analytic"`` traces Mitsuba's exact
    spheres (what a tessellated silhouette costs, visible at near-mirror roughness)."""
    if geometry not in GEOMETRIES:
        raise ReferenceError(f"geometry {geometry!r} is not one of {', '.join(GEOMETRIES)}",
                             where="--geometry")
    check_traceable(scene)
    bsdf_type = bsdf_class(mi, dr)
    multiscatter = bool(scene.render.multiscatter)
    d: dict = {"type": "scene",
               "integrator": {"type": "path", "max_depth": int(max_depth),
                              "rr_depth": int(max_depth) + 1}}
    env = scene.environment
    if env.intensity > 0.0:  # a dark one is left out: Mitsuba would still pick it for light samples
        d["environment"] = {
            "type": "envmap",
            "bitmap": mi.Bitmap(environment_bitmap(scene)),
            "scale": float(env.intensity),
            "to_world": mi.ScalarTransform4f().rotate([0.0, 1.0, 0.0], float(env.rotation_deg)),
        }
    cache = GeometryCache()
    scene = gather_lights(scene, cache.get)  # + the meshes' own lights (glTF)
    bounds = points_bounds(np.concatenate(
        [m.positions.reshape(-1, 3) for obj in scene.objects for m in cache.get(obj)]))
    for i, light in enumerate(scene.light or ()):
        d[f"light_{i}"] = mitsuba_light(light, mi, bounds, scene.source or "[[lights]]")
    count, masked = 0, []
    for obj in scene.objects:
        for shape in _shapes(obj, mi, dr, bsdf_type, multiscatter, geometry, masked):
            d[f"shape_{count}"] = shape
            count += 1
    if masked:  # alphaMode MASK / BLEND coverage: shadow rays must pass the cut-outs
        d["integrator"]["type"] = MASKED_INTEGRATOR
    return d


def _bsdf(bsdf_type, material: Material, textures: dict, multiscatter: bool,
          normal_scale: float = 1.0):
    return bsdf_type().configure(material, textures, multiscatter, normal_scale)


def _shapes(obj, mi, dr, bsdf_type, multiscatter, geometry, masked: list):
    """The Mitsuba shapes of ``obj``; each mesh given alpha coverage is appended to ``masked``."""
    if geometry == "analytic" and obj.type in ("sphere", "material_grid"):
        balls = ([(obj.center, obj.material)] if obj.type == "sphere" else
                 [(tuple((b.bounds()[0] + b.bounds()[1]) / 2.0), b.material)
                  for b in primitives.material_ball_grid(
                      rows=obj.rows, cols=obj.cols, spacing=obj.spacing, radius=obj.radius,
                      albedo=obj.material.albedo, center=obj.center, segments=4, rings=2)])
        for center, material in balls:
            yield _sphere(mi, center, obj.radius, _bsdf(bsdf_type, material, {}, multiscatter))
        return
    # the rasteriser's own triangles (GeometryCache: tessellated primitives, loaded meshes with
    # the object's material override), so a difference is shading, never geometry
    for mesh in GeometryCache().get(obj):  # (a fresh cache: loads apply materials in place)
        where = obj.path or obj.type
        textures = {}
        for key in ("base_color", "metallic_roughness", "normal", "specular_color", "clearcoat",
                    "clearcoat_roughness", "sheen_color", "anisotropy",
                    "iridescence", "transmission"):
            if key in mesh.textures:
                textures[key] = _texture(mi, mesh.textures[key], mesh.sampling.get(key), where)
        if "specular" in mesh.textures:  # KHR_materials_specular: its factor is the map's A
            textures["specular"] = _texture(mi, mesh.textures["specular"][..., 3:4],
                                            mesh.sampling.get("specular"), where)
        if "sheen_roughness" in mesh.textures:  # KHR_materials_sheen: its roughness is the A
            textures["sheen_roughness"] = _texture(mi, mesh.textures["sheen_roughness"][..., 3:4],
                                                   mesh.sampling.get("sheen_roughness"), where)
        if "iridescence_thickness" in mesh.textures:  # KHR_materials_iridescence: the map's G
            img = mesh.textures["iridescence_thickness"]
            textures["iridescence_thickness"] = _texture(
                mi, img[..., 1:2] if img.shape[-1] >= 2 else img[..., :1],
                mesh.sampling.get("iridescence_thickness"), where)
        ignored = ["occlusion map"] if "occlusion" in mesh.textures else []
        if "clearcoat_normal" in mesh.textures and mesh.material.clearcoat > 0.0:
            ignored.append("the clearcoat normal map (the coat has the vertex normal)")
        if any(sm.texcoord != 0 for sm in mesh.sampling.values()):
            ignored.append("TEXCOORD_1 (read as TEXCOORD_0)")
        if mesh.colors is not None:
            ignored.append("COLOR_0 (nor its alpha in alphaMode coverage)"
                           if mesh.alpha_mode != "OPAQUE" else "COLOR_0")
        if mesh.tangents is not None and mesh.material.has_anisotropy:
            ignored.append("TANGENT (the anisotropy's tangent space is the UVs')")
        if mesh.alpha_mode != "OPAQUE" and mesh.has_emission:
            ignored.append(f"alphaMode {mesh.alpha_mode} on the emission (cut-outs still emit)")
        see_through = mesh.material.transmission > 0.0  # the plugin shades both sides
        if not mesh.double_sided and not see_through:
            ignored.append("single-sided culling (back faces are black, not see-through)")
        if ignored:
            warnings.warn(f"{where}: {mesh.name or 'a mesh'}: the reference does not trace "
                          f"{', '.join(ignored)} (occlusion is baked visibility, which the path "
                          "tracer computes itself)", stacklevel=2)
        bsdf = _bsdf(bsdf_type, mesh.material, textures, multiscatter, mesh.normal_scale)
        if mesh.double_sided and not see_through:  # back faces: the normal flipped (G-buffer)
            bsdf = mi.load_dict({"type": "twosided", "bsdf": bsdf})
        opacity = _opacity(mi, mesh, where)
        if opacity is not None:  # glTF alphaMode: a cut-out / partly covering surface
            bsdf = mi.load_dict({"type": "mask", "opacity": opacity, "bsdf": bsdf})
            masked.append(mesh)
        emitter = _emitter(mi, mesh, where) if mesh.has_emission else None
        yield _mesh(mi, dr, mesh, bsdf, emitter)


def _opacity(mi, mesh, where):
    """glTF 2.0 alpha coverage as the ``opacity`` of Mitsuba's ``mask`` BSDF (None: covered
    everywhere, no mask). The alpha is baseColorFactor's x the base colour map's A, read with
    that map's sampling (transform, wrap, filter). MASK: opacity 1 where alpha >= alphaCutoff,
    0 elsewhere (the ray passes straight through, no refraction; :data:`CUTOFF_SLOPE`); BLEND:
    opacity = alpha, which ``mask`` reads as the probability of a hit (stochastic coverage)."""
    factor = float(mesh.base_alpha)
    image = mesh.textures.get("base_color")
    alpha = (None if image is None or image.shape[-1] < 4 else
             np.asarray(image[..., 3:4], np.float64) * factor)
    if mesh.alpha_mode == "MASK":
        cutoff = float(mesh.alpha_cutoff)
        if alpha is None:
            return None if factor >= cutoff else 0.0
        return _texture(mi, (alpha - cutoff) * CUTOFF_SLOPE + 1.0,
                        mesh.sampling.get("base_color"), where, mono=True)
    if mesh.alpha_mode == "BLEND":
        if alpha is None:
            return None if factor >= 1.0 else factor
        return _texture(mi, alpha, mesh.sampling.get("base_color"), where, mono=True)
    return None


def _emitter(mi, mesh, where):
    """glTF emission (emissiveFactor x strength x emissiveTexture) as an area light: in the
    reference, unlike the rasteriser, emissive surfaces light the rest of the scene."""
    factor = np.asarray(mesh.emissive, np.float32)
    if "emissive" in mesh.textures:
        img = np.asarray(mesh.textures["emissive"][..., :3], np.float32) * factor
        radiance = _texture(mi, img, mesh.sampling.get("emissive"), where)
    else:
        radiance = {"type": "rgb", "value": [float(c) for c in factor]}
    return mi.load_dict({"type": "area", "radiance": radiance})


def _sphere(mi, center, radius, bsdf):
    return {"type": "sphere", "center": [float(c) for c in center], "radius": float(radius),
            "bsdf": bsdf}


_WRAP = {"repeat": "repeat", "clamp": "clamp", "mirror": "mirror"}  # ours -> Mitsuba


def _texture(mi, image: np.ndarray, sampling=None, where: str = "mesh", mono: bool = False):
    """A Mitsuba bitmap texture read as the G-buffer pass reads ``image``: raw (linear) values,
    the ``KHR_texture_transform`` as ``to_uv``, the wrap mode, nearest or bilinear magnification.
    Mitsuba has one wrap mode for both axes (u's is used, with a warning when v's differs) and no
    mip-mapping: at a pixel centre the path tracer sees the texture unfiltered, the rasteriser a
    mip-mapped footprint (a minification blur the reference does not have). ``mono``: one
    channel (``image``'s first), read by ``eval_1`` as it is (an RGB one would be its luminance)."""
    img = np.ascontiguousarray(image[..., :1] if mono else
                               image[..., :3] if image.shape[-1] >= 3 else
                               np.repeat(image[..., :1], 3, axis=-1), dtype=np.float32)
    d = {"type": "bitmap", "bitmap": mi.Bitmap(img), "raw": True,
         "filter_type": "bilinear", "wrap_mode": "repeat"}
    if sampling is not None:
        d["filter_type"] = "nearest" if sampling.mag_filter == "nearest" else "bilinear"
        wrap_u, wrap_v = (_WRAP.get(w, "repeat") for w in sampling.wrap)
        if wrap_u != wrap_v:
            warnings.warn(f"{where}: a texture wraps u ({wrap_u}) and v ({wrap_v}) differently; "
                          f"the reference wraps both as u", stacklevel=3)
        d["wrap_mode"] = wrap_u
        m = sampling.uv_matrix()
        if not np.allclose(m, np.eye(3)):
            d["to_uv"] = mi.ScalarTransform3f(m.astype(np.float64).tolist())
    return mi.load_dict(d)


def _mesh(mi, dr, mesh, bsdf, emitter=None):
    props = mi.Properties()
    props["bsdf"] = bsdf
    if emitter is not None:
        props["emitter"] = emitter
    has_uv = mesh.uvs is not None
    m = mi.Mesh(mesh.name or "mesh", mesh.vertex_count, mesh.triangle_count, props, True, has_uv)
    params = mi.traverse(m)

    def flat(key, a, dtype=np.float32):  # the buffer's own type: llvm and scalar variants
        params[key] = type(params[key])(np.ascontiguousarray(np.asarray(a, dtype).ravel()))

    flat("vertex_positions", mesh.positions)
    flat("vertex_normals", mesh.normals)
    if has_uv:
        flat("vertex_texcoords", mesh.uvs)
    flat("faces", mesh.indices, np.uint32)
    params.update()
    return m
