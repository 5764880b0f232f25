"""A dataset sample as a scene the viewer draws: from its image-space G-buffer stack
(:func:`sample_scene`, the sample folder as one ``gbuffer`` object) or from the geometry the
generator rasterised it from (:func:`sample_mesh_scene`: the spheres, planes and mesh files that
``meta.json`` records, so that the screen-space passes and the frame are those of a mesh scene).

The generator (:func:`learned.data.generator.write._write_sample`) records each object of the
scene dict in ``meta.json``'s ``objects`` as it was drawn, a mesh by the stem of its file in the
dataset's ``_meshes`` folder (``{"type": "mesh", "mesh": "box", "transform", "material"?}``; a
glTF model without ``material`` keeps its file's). The camera is the stack's own (every generator
scene kind, and the image-stack convention of :mod:`viewer.geometry.imagespace`: the origin,
looking down -Z, +Y up), at ``camera.json``'s ``fov_y`` and the stack's size; the environment is
the sample's ``env.exr`` (rotation and intensity baked in). A sample whose geometry was itself an
image G-buffer (``gbuffer_fraction``), or whose ``meta.json`` or mesh files are missing, has no
mesh scene, nor has a sample whose stack was degraded (``meta.json`` ``degrade``: its meshes
would draw the true G-buffer, not its degraded one): one
:class:`~learned.data.reader.DatasetError` naming the file.

``geometry`` (:data:`GEOMETRIES`) names the two for the callers that draw a sample either way
(:func:`geometry_scene`); :func:`mesh_channels` reads the mesh scene's G-buffer back in the
reader's channel layout (``Sample.channels``).
"""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from viewer.errors import SceneError
from viewer.scene.description import scene_from_dict

from .reader import DatasetError

GEOMETRIES = ("stack", "mesh")  # the sample's image-space G-buffer | the meshes it was drawn from
MESH_FOLDER = "_meshes"  # the generator's mesh cache, beside the splits
MESH_OBJECTS = ("sphere", "plane", "mesh")  # the object types the generator's scenes have
# the G-buffer channels of learned.data.reader.Sample.channels
CHANNELS = ("albedo", "normal", "roughness", "specular", "metallic", "ao", "depth", "alpha")


def sample_scene(sample, **render):
    """``sample`` (:class:`learned.data.reader.Sample`) drawn from its image-space stack, lit by
    its environment, with the render settings ``render`` (tone mapping off)."""
    return scene_from_dict({
        "environment": {"path": str(sample.environment)},
        "objects": [{"type": "gbuffer", "path": str(sample.folder)}],
        "render": {"tonemap": "none", **render}}, file=str(sample.folder / "scene"))


def mesh_folder(folder: Path) -> Path:
    """The ``_meshes`` folder of sample ``folder``: the nearest among its ancestors (``ROOT/
    split/name``, and a degraded copy's ``ROOT/_degraded/<level>/split/name``), else where the
    generator would have written it (``ROOT/_meshes``, missing)."""
    for parent in list(folder.parents)[1:]:
        if (parent / MESH_FOLDER).is_dir():
            return parent / MESH_FOLDER
    return folder.parent.parent / MESH_FOLDER


def _mesh_file(stem: str, meshes: Path, meta: Path) -> Path:
    found = [p for p in meshes.glob(f"{stem}.*") if p.is_file() and p.stem == stem] \
        if meshes.is_dir() else []
    if len(found) != 1:
        what = "no file" if not found else f"{len(found)} files"
        raise DatasetError(f"mesh {stem!r}: {what} {stem}.* in {meshes}", where=meta)
    return found[0]


def mesh_scene_dict(sample, meshes: Path | None = None) -> dict:
    """The scene dict (``scene_from_dict`` format, without environment and render settings) of
    the geometry ``sample`` was drawn from (module doc); ``meshes``: the folder of its mesh files
    (default :func:`mesh_folder`)."""
    meta = Path(sample.folder) / "meta.json"
    if not meta.is_file():
        raise DatasetError("missing: the objects the sample was drawn from (meta.json)",
                           where=meta)
    try:
        info = json.loads(meta.read_text())
        objects, degraded = info.get("objects"), info.get("degrade")
    except (ValueError, AttributeError) as exc:
        raise DatasetError(f"not valid JSON ({exc})", where=meta) from None
    if degraded is not None:  # learned.protocol.degrade, or the generator's `degrade`
        raise DatasetError("the sample's G-buffer is degraded ('degrade'): its meshes would "
                           "draw the true one; draw the clean dataset's meshes", where=meta)
    if not isinstance(objects, list) or not objects:
        raise DatasetError("no 'objects' list: the generator's scene is not recorded", where=meta)
    meshes = Path(meshes) if meshes is not None else mesh_folder(Path(sample.folder))
    out = []
    for obj in objects:
        kind = obj.get("type") if isinstance(obj, dict) else None
        if kind == "gbuffer":
            raise DatasetError("the sample's geometry was an image G-buffer: no mesh scene",
                               where=meta)
        if kind not in MESH_OBJECTS:
            raise DatasetError(f"object type {kind!r} is not one of {', '.join(MESH_OBJECTS)}",
                               where=meta)
        obj = dict(obj)
        if kind == "mesh":
            if "mesh" not in obj:
                raise DatasetError("a mesh object without its file's stem ('mesh')", where=meta)
            obj["path"] = str(_mesh_file(str(obj.pop("mesh")), meshes, meta))
        out.append(obj)
    w, h = sample.size
    return {"camera": {"position": [0.0, 0.0, 0.0], "target": [0.0, 0.0, -1.0],
                       "up": [0.0, 1.0, 0.0], "fov_y": float(sample.fov_y), "size": [w, h]},
            "objects": out}


def sample_mesh_scene(sample, meshes: Path | None = None, **render):
    """``sample`` drawn from the geometry it was generated from (:func:`mesh_scene_dict`), lit by
    its environment, with the render settings ``render`` (tone mapping off), as
    :func:`sample_scene` draws its stack: with the ray-traced tier off unless ``render`` turns it
    on (on by default wherever there are triangles to trace, its rays would take the place of
    the SSAO pass that a stack, which has none, is drawn with)."""
    doc = mesh_scene_dict(sample, meshes) | {
        "environment": {"path": str(sample.environment)},
        "render": {"tonemap": "none", "raytrace": False, **render}}
    try:
        return scene_from_dict(doc, file=str(sample.folder / "scene"))
    except SceneError as exc:  # a recorded object the viewer refuses: name the record
        raise DatasetError(exc.problem, where=Path(sample.folder) / "meta.json") from None


def geometry_scene(sample, geometry: str = "stack", **render):
    """:func:`sample_scene` (``"stack"``) or :func:`sample_mesh_scene` (``"mesh"``)."""
    if geometry == "stack":
        return sample_scene(sample, **render)
    if geometry == "mesh":
        return sample_mesh_scene(sample, **render)
    raise ValueError(f"geometry={geometry!r}: expected one of {GEOMETRIES}")


def mesh_channels(renderer, sample) -> dict[str, np.ndarray]:
    """The G-buffer of ``sample``'s mesh scene read back from ``renderer``: channel ->
    ``[H, W, C]`` float32, row 0 at the top, in ``Sample.channels``' layout (background pixels
    hold the G-buffer's background values, as the reader sets them)."""
    frame = renderer.render(sample_mesh_scene(sample, model="unlit"), aovs=CHANNELS)
    return {k: np.ascontiguousarray(frame.aovs[k], np.float32) for k in CHANNELS}
