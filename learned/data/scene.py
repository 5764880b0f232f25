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
mesh scene: one :class:`~learned.data.reader.DatasetError` naming the file. A sample whose
stack was degraded (``meta.json`` ``degrade``: an estimated G-buffer of a known geometry) has
one of its own: its degraded stack seen, its meshes as shadow casters only (``shadow_only``: in
the shadow maps and rays, not in the G-buffer), since its meshes seen would draw the true
G-buffer.

A third way (:func:`sample_splat_scene`): the same geometry tiled with Gaussian splats that carry
its true materials (:func:`learned.data.splat_tiling.scene_splats`: what a perfect capture and
decomposition would give), drawn by the viewer's splat G-buffer path; the same refusals as the
mesh scene, a degraded sample's included. The cloud is written once per content to the user's cache
(``cache_root() / "splat_samples"``, :func:`viewer.environment.disk_cache.cache_root`: a
``RELIGHT_CACHE_DIR`` moves it; the oldest files beyond :data:`SPLAT_CACHE_BYTES` are removed),
for the scene's ``splats`` object names a file.

``geometry`` (:data:`GEOMETRIES`) names the three for the callers that draw a sample any way
(:func:`geometry_scene`); :func:`geometry_channels` reads a scene's G-buffer back in the
reader's channel layout (``Sample.channels``).
"""
from __future__ import annotations

import hashlib
import json
import os
from pathlib import Path

import numpy as np

from viewer.errors import SceneError
from viewer.scene.description import scene_from_dict

from .reader import DatasetError

# the sample's image-space G-buffer | the meshes it was drawn from | those tiled with splats
GEOMETRIES = ("stack", "mesh", "splat")
SPLAT_FOLDER = "splat_samples"  # under the user's relight cache
SPLAT_CACHE_BYTES = 2 << 30  # the oldest clouds beyond this are removed
SPLAT_FORMAT = 1  # bump when the tiling changes: older cached clouds are then not reused
MESH_FOLDER = "_meshes"  # the generator's mesh cache, beside the splits
MESH_OBJECTS = ("sphere", "plane", "mesh")  # the object types the generator's scenes have
# a degraded sample's mesh scene: the normal offset of its stack's pixels in the shadow maps
# (RenderSettings.shadow.bias), since an estimated depth puts a receiver off the true casters
# (relative errors of 1-5 %: learned.protocol.degrade); chosen on the protocol's val split at
# degradation 0.5 among 1, 4, 8, 16, 32, 64 (frame PSNR 19.33, 20.27, 20.40, 20.68, 20.64, 20.48;
# without shadow maps 20.25; docs/measurements/students.md). Clean mesh scenes keep 1, their
# val optimum (24.31 against 24.16 at 16).
DEGRADED_SHADOW_BIAS = 16.0
# and without the viewer's snap of a stack's depth to its proxies' (shadow_proxy_snap, which
# reaches the same frame at bias 1: 20.71 dB): the recipe the shipped estimators were scored on
DEGRADED_PROXY_SNAP = 0.0
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


def mesh_scene_dict(sample, meshes: Path | None = None, casters: bool = False) -> dict:
    """The scene dict (``scene_from_dict`` format, without environment and render settings) of
    the geometry ``sample`` was drawn from (module doc); ``meshes``: the folder of its mesh files
    (default :func:`mesh_folder`); ``casters``: every object a shadow caster only
    (``shadow_only``: in the shadow maps and rays, not in the G-buffer), which a degraded sample
    allows (:func:`sample_mesh_scene`)."""
    meta = Path(sample.folder) / "meta.json"
    if not meta.is_file():
        raise DatasetError("missing: the objects the sample was drawn from (meta.json)",
                           where=meta)
    try:
        info = json.loads(meta.read_text())
        objects, degraded = info.get("objects"), info.get("degrade")
    except (ValueError, AttributeError) as exc:
        raise DatasetError(f"not valid JSON ({exc})", where=meta) from None
    if degraded is not None and not casters:  # learned.protocol.degrade, or the generator's
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
        if casters:
            obj["shadow_only"] = True
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
    the SSAO pass that a stack, which has none, is drawn with).

    A degraded sample (``meta.json`` ``degrade``: an estimated G-buffer of a known geometry) is
    drawn from its degraded stack, with its meshes as shadow casters only: the camera sees the
    estimated G-buffer, and the shadow maps and rays hold the true meshes; its shadow bias is
    :data:`DEGRADED_SHADOW_BIAS` and its proxy snap :data:`DEGRADED_PROXY_SNAP` unless
    ``render`` sets them."""
    if _degraded(sample):
        doc = mesh_scene_dict(sample, meshes, casters=True)
        doc["objects"] = [{"type": "gbuffer", "path": str(sample.folder)}, *doc["objects"]]
        render = {"shadow_bias": DEGRADED_SHADOW_BIAS,
                  "shadow_proxy_snap": DEGRADED_PROXY_SNAP} | render
    else:
        doc = mesh_scene_dict(sample, meshes)
    doc |= {
        "environment": {"path": str(sample.environment)},
        "render": {"tonemap": "none", "raytrace": False, **render}}
    try:
        return scene_from_dict(doc, file=str(sample.folder / "scene"))
    except SceneError as exc:  # a recorded object the viewer refuses: name the record
        raise DatasetError(exc.problem, where=Path(sample.folder) / "meta.json") from None


def _degraded(sample) -> bool:
    """Whether ``sample``'s ``meta.json`` records a degradation (``degrade``); False where it
    cannot be read (:func:`mesh_scene_dict` names the problem)."""
    try:
        info = json.loads((Path(sample.folder) / "meta.json").read_text())
    except (OSError, ValueError):
        return False
    return isinstance(info, dict) and info.get("degrade") is not None


def splat_file(sample, meshes: Path | None = None, spacing: float | None = None,
               cache: Path | None = None) -> Path:
    """The cached ``.ply`` of the splats tiling ``sample``'s mesh scene (module doc), made if
    missing; ``spacing``: px between splats (default :data:`learned.data.splat_tiling.SPACING`);
    ``cache``: the folder (default the user's cache)."""
    from viewer.environment.disk_cache import cache_root, file_digest
    from viewer.splats.ply import write_ply

    from .splat_tiling import SPACING, scene_splats

    spacing = SPACING if spacing is None else float(spacing)
    doc = mesh_scene_dict(sample, meshes)
    files = sorted({o["path"] for o in doc["objects"] if o["type"] == "mesh"})
    key = hashlib.sha256(json.dumps(
        [SPLAT_FORMAT, spacing, doc, [file_digest(f) for f in files]],
        sort_keys=True).encode()).hexdigest()[:24]
    folder = Path(cache) if cache is not None else cache_root() / SPLAT_FOLDER
    path = folder / f"{Path(sample.folder).name}_{key}.ply"
    if path.is_file():
        return path
    where = Path(sample.folder) / "meta.json"
    try:
        scene = scene_from_dict(doc, file=str(sample.folder / "scene"))
        splats = scene_splats(scene, spacing)
    except (SceneError, ValueError) as exc:  # a recorded object the tiler or viewer refuses
        raise DatasetError(getattr(exc, "problem", str(exc)), where=where) from None
    folder.mkdir(parents=True, exist_ok=True)
    tmp = path.with_suffix(f".{os.getpid()}.tmp")
    write_ply(tmp, splats, comments=[f"tiled from {where}"])
    os.replace(tmp, path)
    _trim(folder, keep=path)
    return path


def _trim(folder: Path, keep: Path, max_bytes: int = SPLAT_CACHE_BYTES) -> None:
    files = sorted(folder.glob("*.ply"), key=lambda p: p.stat().st_mtime)
    total = sum(p.stat().st_size for p in files)
    for p in files:
        if total <= max_bytes:
            break
        if p != keep:
            total -= p.stat().st_size
            p.unlink(missing_ok=True)


def sample_splat_scene(sample, meshes: Path | None = None, spacing: float | None = None,
                       cache: Path | None = None, **render):
    """``sample`` drawn from its mesh scene tiled with splats of the true materials
    (:func:`splat_file`), lit by its environment, with the render settings ``render`` (tone
    mapping off) as :func:`sample_scene` draws its stack."""
    path = splat_file(sample, meshes, spacing, cache)
    w, h = sample.size
    return scene_from_dict({
        "camera": {"position": [0.0, 0.0, 0.0], "target": [0.0, 0.0, -1.0],
                   "up": [0.0, 1.0, 0.0], "fov_y": float(sample.fov_y), "size": [w, h]},
        "environment": {"path": str(sample.environment)},
        "objects": [{"type": "splats", "path": str(path)}],
        "render": {"tonemap": "none", **render}}, file=str(sample.folder / "scene"))


def geometry_scene(sample, geometry: str = "stack", **render):
    """:func:`sample_scene` (``"stack"``), :func:`sample_mesh_scene` (``"mesh"``) or
    :func:`sample_splat_scene` (``"splat"``)."""
    if geometry == "stack":
        return sample_scene(sample, **render)
    if geometry == "mesh":
        return sample_mesh_scene(sample, **render)
    if geometry == "splat":
        return sample_splat_scene(sample, **render)
    raise ValueError(f"geometry={geometry!r}: expected one of {GEOMETRIES}")


def geometry_channels(renderer, sample, geometry: str = "mesh") -> dict[str, np.ndarray]:
    """The G-buffer of ``sample``'s ``geometry`` scene read back from ``renderer``: channel ->
    ``[H, W, C]`` float32, row 0 at the top, in ``Sample.channels``' layout (background pixels
    hold the G-buffer's background values, as the reader sets them)."""
    frame = renderer.render(geometry_scene(sample, geometry, model="unlit"), aovs=CHANNELS)
    return {k: np.ascontiguousarray(frame.aovs[k], np.float32) for k in CHANNELS}


def mesh_channels(renderer, sample) -> dict[str, np.ndarray]:
    """:func:`geometry_channels` of the mesh scene."""
    return geometry_channels(renderer, sample, "mesh")
