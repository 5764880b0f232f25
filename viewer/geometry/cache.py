"""CPU geometry per scene object, loaded once: meshes (primitives, glTF/OBJ), image-space G-buffer
stacks and splat clouds, cached by shape so material sliders never reload or re-tessellate.

The cache is bounded by bytes (:attr:`viewer.cache.Budgets.geometry_bytes`): the CPU arrays of
each entry plus the GPU copies the passes made of it (their upload caches,
:class:`viewer.passes.uploads.UploadCache`, report each copy to the entry holding the object they
copied: :func:`owners_of`). The least recently used entry is evicted when the budget is
exceeded, and its GPU copies are released with it, in every pass that made one. Loaded content
is loaded again on its next use; content added in memory (:meth:`GeometryCache.add`) cannot be, so
asking for it once it was evicted is an error that names the budget.
"""
from __future__ import annotations

import dataclasses
import weakref
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..cache import BoundedCache, Budgets, CacheStats, mib
from ..errors import InputError, SceneError
from ..scene.description import ObjectSpec
from ..scene.material import Material
from ..splats import load_splats
from ..splats.data import Splats
from . import imagespace, primitives
from .imagespace import ImageGBuffer
from .loaders import load_mesh
from .mesh import Mesh

_CACHES: "weakref.WeakSet[GeometryCache]" = weakref.WeakSet()  # every live cache (owners_of)


@dataclass(eq=False)
class _Entry:
    """One cached content: what it holds (``parts``: meshes and their texture images, a stack, a
    cloud), its CPU bytes and the GPU copies passes made of its parts."""

    key: ObjectSpec
    content: object
    parts: tuple
    cpu_bytes: int
    added: bool  # in memory (GeometryCache.add): cannot be loaded again once evicted
    # (id(upload cache), upload key) -> (weakref to the upload cache, upload key, bytes)
    uploads: dict = field(default_factory=dict)

    @property
    def nbytes(self) -> int:
        return self.cpu_bytes + sum(n for _, _, n in self.uploads.values())


class GeometryCache:
    """Object -> loaded content (a list of meshes, an
    :class:`~viewer.geometry.imagespace.ImageGBuffer` or :class:`~viewer.splats.data.Splats`),
    at most ``max_bytes`` of it with its GPU copies (``None``: unbounded; see the module
    docstring).

    Cached by shape: objects that differ only in their material share the loaded (and uploaded)
    meshes, whose material (a uniform) is set from the object on every lookup."""

    def __init__(self, max_bytes: int | None = Budgets.geometry_bytes):
        self._cache = BoundedCache("geometry", max_bytes=max_bytes, release=self._free)
        self._parts: dict[int, _Entry] = {}  # id(part) -> the entry holding it
        # in-memory content that was evicted: asking for it again is an error, not a load of
        # obj.path (bounded: past this many, such an object loads its path again)
        self._evicted_added = BoundedCache("evicted in-memory geometry", max_items=1024)
        # bumped whenever content is replaced or forgotten (added, removed or evicted): what a
        # cached G-buffer was drawn from may have changed (viewer.renderer.Renderer.reuse_passes).
        # Eviction bumps it too: the content loaded again is the file's as it is then.
        self.version = 0
        _CACHES.add(self)

    def get(self, obj: ObjectSpec):
        key = _cache_key(obj)
        entry = self._cache.get(key)
        if entry is None:
            self._cache.misses += 1
            if key in self._evicted_added:
                raise SceneError(
                    f"the in-memory geometry of this {obj.type} object was evicted from the "
                    f"geometry cache (budget {mib(self._cache.max_bytes)}, "
                    f"Budgets.geometry_bytes); add it again (Renderer.add_geometry) or raise the "
                    f"budget", where=obj.path or obj.type)
            entry = self._store(key, _load_object(obj), added=False)
        else:
            self._cache.hits += 1
        _apply_material(obj, entry.content)
        return entry.content

    def add(self, obj: ObjectSpec, content) -> None:
        """Use ``content`` for ``obj`` instead of loading ``obj.path`` (geometry made in memory:
        tests, benchmarks, generated data). Taken as given: the loaders' validation does not run.
        It counts towards the budget like loaded content (see the module docstring)."""
        key = _cache_key(obj)
        self._store(key, content, added=True)
        self._evicted_added.pop(key)
        self.version += 1

    def remove(self, obj: ObjectSpec) -> None:
        """Forget ``obj``'s content (added or loaded) and release its GPU copies; the next lookup
        loads it again."""
        key = _cache_key(obj)
        self._cache.pop(key)
        self._evicted_added.pop(key)
        self.version += 1

    def clear(self) -> None:
        """Forget every content and release every GPU copy made of it."""
        self._cache.clear()
        self._evicted_added.clear()
        self.version += 1

    def resize(self, max_bytes: int | None) -> None:
        """A new budget (evicting at once what no longer fits)."""
        self._cache.resize(max_bytes=max_bytes)

    @contextmanager
    def frame(self):
        """``with geometry_cache.frame():`` around a frame: nothing looked up inside is evicted
        before it ends (a scene larger than the budget is drawn whole, then trimmed)."""
        with self._cache.frame():
            yield self

    def stats(self) -> CacheStats:
        """Entries and bytes (CPU arrays + GPU copies) against ``max_bytes``."""
        return self._cache.stats()

    @property
    def gpu_bytes(self) -> int:
        """The bytes of the GPU copies the passes made of cached content."""
        return sum(sum(n for _, _, n in e.uploads.values()) for e in self._cache.values())

    def __len__(self) -> int:
        return len(self._cache)

    # ---- GPU copies (viewer.passes.uploads) -----------------------------------------------------
    def adopt(self, entry: _Entry, uploads, upload_key, nbytes: int) -> None:
        """Count the copy ``upload_key`` of ``uploads`` (an upload cache) towards ``entry`` and
        release it with the entry."""
        if self._cache.peek(entry.key) is not entry:
            return
        entry.uploads[(id(uploads), upload_key)] = (weakref.ref(uploads), upload_key, int(nbytes))
        self._cache.set_nbytes(entry.key, entry.nbytes)

    def disown(self, entry: _Entry, uploads, upload_key) -> None:
        """The copy ``upload_key`` of ``uploads`` was released by its cache: stop counting it."""
        if entry.uploads.pop((id(uploads), upload_key), None) is not None \
                and self._cache.peek(entry.key) is entry:
            self._cache.set_nbytes(entry.key, entry.nbytes)

    # ---- internals ------------------------------------------------------------------------------
    def _store(self, key: ObjectSpec, content, added: bool) -> _Entry:
        parts = _parts(content)
        entry = _Entry(key=key, content=content, parts=parts,
                       cpu_bytes=sum(a.nbytes for a in _arrays(content)), added=added)
        self._cache.put(key, entry, entry.nbytes)  # releases an older entry of key first
        for part in parts:
            self._parts[id(part)] = entry
        return entry

    def _free(self, entry: _Entry) -> None:
        """Release callback of the bounded map: ``entry`` was evicted, replaced or removed."""
        for part in entry.parts:
            if self._parts.get(id(part)) is entry:
                del self._parts[id(part)]
        uploads, entry.uploads = entry.uploads, {}
        for ref, upload_key, _ in uploads.values():
            cache = ref()
            if cache is not None:
                cache.discard(upload_key)
        if entry.added:  # add() and remove() forget this again; an eviction keeps it
            self._evicted_added.put(entry.key, True)
        self.version += 1


def owners_of(part) -> list[tuple[GeometryCache, _Entry]]:
    """The geometry caches and entries whose content holds ``part`` (by identity): a mesh, a
    texture image of one, an image stack or a splat cloud."""
    found = []
    for cache in list(_CACHES):
        entry = cache._parts.get(id(part))
        if entry is not None and cache._cache.peek(entry.key) is entry \
                and any(p is part for p in entry.parts):
            found.append((cache, entry))
    return found


def _parts(content) -> tuple:
    """What passes upload of ``content``: each mesh and each texture image of one (once), a
    stack, a cloud."""
    if isinstance(content, (ImageGBuffer, Splats)):
        return (content,)
    parts, seen = [], set()
    for mesh in content:
        for obj in (mesh, *mesh.textures.values()):
            if id(obj) not in seen:
                seen.add(id(obj))
                parts.append(obj)
    return tuple(parts)


def _arrays(content) -> list[np.ndarray]:
    """The distinct numpy arrays ``content`` holds (a texture shared by meshes counts once)."""
    if isinstance(content, ImageGBuffer):
        found = [*content.channels.values(), content.target]
    elif isinstance(content, Splats):
        found = [getattr(content, f.name) for f in dataclasses.fields(content)]
    else:
        found = []
        for mesh in content:
            found.extend(getattr(mesh, f.name) for f in dataclasses.fields(Mesh))
            found.extend(mesh.textures.values())
    out, seen = [], set()
    for a in found:
        if isinstance(a, np.ndarray) and id(a) not in seen:
            seen.add(id(a))
            out.append(a)
    return out


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
        return load_mesh(obj.path, transform=transform, material_override=obj.material,
                         variant=obj.variant)
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


def _cache_key(obj: ObjectSpec) -> tuple:
    """:func:`_shape_key` and the stamp (size, modification time) of the file it names: a file
    rewritten at the same path is loaded again, not drawn from the cache as it was."""
    stamp = None
    if obj.path:
        try:
            st = Path(obj.path).stat()
            stamp = (st.st_size, st.st_mtime_ns) if Path(obj.path).is_file() else None
        except OSError:
            stamp = None  # loading it says what is wrong
    return _shape_key(obj), stamp


def _shape_key(obj: ObjectSpec) -> ObjectSpec:
    """The geometry cache key: ``obj`` without the parts of its material that are uniforms.

    Primitives take their material as uniforms (a grid only its albedo); a mesh's override only
    decides whether its own texture maps are kept, so just its presence is part of the key.
    Whether it is a shadow caster only (``shadow_only``) changes where it is drawn, not what.
    """
    if obj.shadow_only:
        obj = dataclasses.replace(obj, shadow_only=False)
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
