"""CPU geometry per scene object, loaded once: meshes (primitives, glTF/OBJ), image-space G-buffer
stacks and splat clouds, cached by shape so material sliders never reload or re-tessellate."""
from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np

from ..errors import InputError, SceneError
from ..material import Material
from ..scene import ObjectSpec
from ..splats import load_splats
from . import imagespace, primitives
from .loaders import load_mesh


class GeometryCache:
    """Object -> loaded content (a list of meshes, an
    :class:`~viewer.geometry.imagespace.ImageGBuffer` or :class:`~viewer.splats.data.Splats`).

    Cached by shape: objects that differ only in their material share the loaded (and uploaded)
    meshes, whose material (a uniform) is set from the object on every lookup."""

    def __init__(self):
        self._content: dict[ObjectSpec, object] = {}
        # bumped whenever content is replaced or forgotten: what a cached G-buffer was drawn from
        # may have changed (viewer.renderer.Renderer.reuse_passes)
        self.version = 0

    def get(self, obj: ObjectSpec):
        key = _shape_key(obj)
        if key not in self._content:
            self._content[key] = _load_object(obj)
        content = self._content[key]
        _apply_material(obj, content)
        return content

    def add(self, obj: ObjectSpec, content) -> None:
        """Use ``content`` for ``obj`` instead of loading ``obj.path`` (geometry made in memory:
        tests, benchmarks, generated data). Taken as given: the loaders' validation does not run."""
        self._content[_shape_key(obj)] = content
        self.version += 1

    def remove(self, obj: ObjectSpec) -> None:
        """Forget ``obj``'s content (added or loaded); the next lookup loads it again."""
        self._content.pop(_shape_key(obj), None)
        self.version += 1

    def __len__(self) -> int:
        return len(self._content)


def _load_object(obj: ObjectSpec):
    if obj.type == "sphere":
        return [primitives.sphere(center=obj.center, radius=obj.radius, material=obj.material)]
    if obj.type == "plane":
        return [primitives.plane(center=obj.center, size=obj.size, normal=obj.normal,
                                 material=obj.material)]
    if obj.type == "material_grid":
        return primitives.material_ball_grid(rows=obj.rows, cols=obj.cols, spacing=obj.spacing,
                                             radius=obj.radius, albedo=obj.material.albedo,
                                             center=obj.center)
    if obj.type == "mesh":

        transform = None if obj.transform is None else np.asarray(obj.transform, np.float64)
        return load_mesh(obj.path, transform=transform, material_override=obj.material)
    if obj.type == "gbuffer":

        path = Path(obj.path)
        if path.is_dir():
            return imagespace.load_ffhq_pbr(path)
        if path.suffix.lower() == ".exr":
            if obj.fov_y is None:
                return imagespace.load_stack_exr(path, fov_y=None, near=obj.near, far=obj.far)
            return imagespace.load_stack_exr(path, fov_y=obj.fov_y, near=obj.near, far=obj.far)
        raise InputError("an image-space G-buffer is a folder (FFHQ256-PBR layout) or a "
                         "12-channel .exr stack", where=path)
    if obj.type == "splats":

        return load_splats(obj.path, transform=obj.transform, material=obj.material)
    raise SceneError(f"object type {obj.type!r} cannot be rendered")


def _shape_key(obj: ObjectSpec) -> ObjectSpec:
    """The geometry cache key: ``obj`` without the parts of its material that are uniforms.

    Primitives take their material as uniforms (a grid only its albedo); a mesh's override only
    decides whether its own texture maps are kept, so just its presence is part of the key.
    """
    if obj.type in ("sphere", "plane", "material_grid"):
        return dataclasses.replace(obj, material=None)
    if obj.type == "mesh" and obj.material is not None:
        return dataclasses.replace(obj, material=Material())
    return obj


def _apply_material(obj: ObjectSpec, content) -> None:
    """Set the (uniform) material of cached meshes from ``obj``, as :func:`_load_object` would."""
    if obj.material is None or obj.type not in ("sphere", "plane", "material_grid", "mesh"):
        return
    for mesh in content:
        if obj.type == "material_grid":  # the grid sweeps roughness and metallic itself
            if mesh.material.albedo != obj.material.albedo:
                mesh.material = dataclasses.replace(mesh.material, albedo=obj.material.albedo)
        else:
            mesh.material = obj.material
