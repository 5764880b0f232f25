"""A workbench :class:`~viewer.scene.Scene` as a Mitsuba 3 scene: the same environment (texels,
orientation, rotation, intensity), the same directional light, analytic spheres, planes and the
material-ball grid as the rasteriser builds them, glTF/OBJ meshes through the project's own
loader (so the reference sees exactly the triangles, normals, UVs and texture maps the G-buffer
pass does), and :class:`~relight.reference.bsdf` for every surface. The camera is not converted:
:mod:`relight.reference.render` traces the rasteriser's own per-pixel rays."""
from __future__ import annotations

import warnings

import numpy as np

from viewer.environment import load_environment
from viewer.errors import RelightError
from viewer.geometry import primitives
from viewer.geometry.loaders import load_mesh
from viewer.material import Material
from viewer.scene import Scene

from .bsdf import bsdf_class

TRACEABLE = ("sphere", "plane", "material_grid", "mesh")


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
    if not scene.objects:
        raise ReferenceError("the scene has no objects to path-trace", where=scene.source or "scene")


def environment_bitmap(scene: Scene) -> np.ndarray:
    """The scene's environment texels in Mitsuba's ``envmap`` convention: Mitsuba looks up
    u = atan2(x, -z) / 2pi (wrapped to [0, 1)), ours u = that + 0.5 (``equirect.glsl``); both have
    v = acos(y) / pi with row 0 at the zenith. So the columns are rolled by half the width."""
    env = load_environment(scene.environment)
    return np.ascontiguousarray(np.roll(env, -env.shape[1] // 2, axis=1))


def to_mitsuba(scene: Scene, mi, dr, max_depth: int) -> dict:
    """The ``mi.load_dict`` dictionary of ``scene`` (integrator ``path`` with ``max_depth``,
    Russian roulette off so the standard error is the plain sample variance's)."""
    check_traceable(scene)
    bsdf_type = bsdf_class(mi, dr)
    multiscatter = bool(scene.render.multiscatter)
    d: dict = {"type": "scene",
               "integrator": {"type": "path", "max_depth": int(max_depth),
                              "rr_depth": int(max_depth) + 1}}
    env = scene.environment
    d["environment"] = {
        "type": "envmap",
        "bitmap": mi.Bitmap(environment_bitmap(scene)),
        "scale": float(env.intensity),
        "to_world": mi.ScalarTransform4f().rotate([0.0, 1.0, 0.0], float(env.rotation_deg)),
    }
    if scene.light is not None:
        irr = scene.light.irradiance
        d["light"] = {"type": "directional",
                      "direction": [-c for c in scene.light.direction],
                      "irradiance": {"type": "rgb", "value": [float(c) for c in irr]}}
    count = 0
    for obj in scene.objects:
        for shape in _shapes(obj, mi, dr, bsdf_type, multiscatter):
            d[f"shape_{count}"] = shape
            count += 1
    return d


def _bsdf(bsdf_type, material: Material, textures: dict, multiscatter: bool):
    return bsdf_type().configure(material, textures, multiscatter)


def _shapes(obj, mi, dr, bsdf_type, multiscatter):
    if obj.type == "sphere":
        yield _sphere(mi, obj.center, obj.radius, _bsdf(bsdf_type, obj.material, {}, multiscatter))
    elif obj.type == "material_grid":
        for ball in primitives.material_ball_grid(rows=obj.rows, cols=obj.cols,
                                                  spacing=obj.spacing, radius=obj.radius,
                                                  albedo=obj.material.albedo, center=obj.center,
                                                  segments=4, rings=2):
            lo, hi = ball.bounds()
            yield _sphere(mi, tuple((lo + hi) / 2.0), obj.radius,
                          _bsdf(bsdf_type, ball.material, {}, multiscatter))
    elif obj.type == "plane":
        mesh = primitives.plane(center=obj.center, size=obj.size, normal=obj.normal,
                                material=obj.material)
        yield _mesh(mi, dr, mesh, _bsdf(bsdf_type, obj.material, {}, multiscatter))
    elif obj.type == "mesh":
        transform = None if obj.transform is None else np.asarray(obj.transform, np.float64)
        for mesh in load_mesh(obj.path, transform=transform, material_override=obj.material):
            textures = {}
            for key in ("base_color", "metallic_roughness"):
                if key in mesh.textures:
                    textures[key] = _texture(mi, mesh.textures[key])
            ignored = [k for k in ("normal", "occlusion") if k in mesh.textures]
            if ignored:
                warnings.warn(f"{obj.path}: {mesh.name or 'a mesh'}: the reference does not use "
                              f"its {' and '.join(ignored)} map"
                              f"{'s' if len(ignored) > 1 else ''} (occlusion is baked visibility, "
                              "which the path tracer computes; normal maps are not traced)",
                              stacklevel=2)
            yield _mesh(mi, dr, mesh, _bsdf(bsdf_type, mesh.material, textures, multiscatter))


def _sphere(mi, center, radius, bsdf):
    return {"type": "sphere", "center": [float(c) for c in center], "radius": float(radius),
            "bsdf": bsdf}


def _texture(mi, image: np.ndarray):
    img = np.ascontiguousarray(image[..., :3] if image.shape[-1] >= 3 else
                               np.repeat(image[..., :1], 3, axis=-1), dtype=np.float32)
    return mi.load_dict({"type": "bitmap", "bitmap": mi.Bitmap(img), "raw": True,
                         "filter_type": "bilinear", "wrap_mode": "repeat"})


def _mesh(mi, dr, mesh, bsdf):
    props = mi.Properties()
    props["bsdf"] = bsdf
    has_uv = mesh.uvs is not None
    m = mi.Mesh(mesh.name or "mesh", mesh.vertex_count, mesh.triangle_count, props, True, has_uv)
    params = mi.traverse(m)

    def cols(a, dtype=np.float32):
        return np.ascontiguousarray(np.asarray(a, dtype).T)

    params["vertex_positions"] = dr.ravel(mi.Point3f(cols(mesh.positions)))
    params["vertex_normals"] = dr.ravel(mi.Vector3f(cols(mesh.normals)))
    if has_uv:
        params["vertex_texcoords"] = dr.ravel(mi.Point2f(cols(mesh.uvs)))
    params["faces"] = dr.ravel(mi.Vector3u(cols(mesh.indices, np.uint32)))
    params.update()
    return m
