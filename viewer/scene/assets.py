"""Assets opened without a scene file: ``relight render model.glb`` builds the scene itself.

:func:`open_assets` turns asset files into a :class:`~viewer.scene.description.Scene`: one object per file,
its kind told from the extension and, for PLY, the header (a mesh, or a Gaussian-splat cloud of
any :mod:`viewer.splats.ply` layout); each rotated so that its up is the scene's +Y
(:mod:`viewer.scene.orientation`); a camera framed on the union of their bounds
(:mod:`viewer.scene.framing`; splat clouds by their robust bounds, :mod:`viewer.scene.bounds`); an
environment (a procedural name or a file) and, on request, a floor plane under them: a shadow
catcher fading into the environment, or a grey slab.

==========================================  =========  =============================================
file                                        object     up
==========================================  =========  =============================================
``.gltf``, ``.glb``                         mesh       +Y (the glTF specification)
``.obj``, ``.off``                          mesh       +Y (assumed, said)
``.stl``                                    mesh       +Z (assumed, said: the CAD convention)
``.ply`` with faces                         mesh       header marker, else its shape, else +Y (said)
``.ply`` with splat properties, ``.splat``  splats     header marker, else its ground, else its
                                                       shape, else -Y (said)
a folder, or a 12-channel ``.exr``          gbuffer    its own camera (image space; not framed)
==========================================  =========  =============================================

Whatever was assumed rather than read is one :class:`AssetNote` warning per file, naming the
file, what was assumed, why, and ``--up``. The scene is an ordinary one: ``save_scene`` writes
it, and the file renders the same pixels (``relight scene``).
"""
from __future__ import annotations

import warnings
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from ..environment.maps import PROCEDURAL, EnvironmentSpec
from ..errors import AssetNote, InputError, SceneError
from .bounds import Bounds, content_bounds, points_bounds
from .camera import Camera
from .description import ObjectSpec, Scene
from .framing import FLOORS, floor_object, frame_camera, object_bounds
from .orientation import (
    UP_AXES,
    detect_cloud_up,
    detect_mesh_up,
    detect_splat_up,
    is_splat_ply,
    marked_up,
    normalize_up,
    ply_header,
    up_matrix,
)

MESH_SUFFIXES = (".gltf", ".glb", ".obj", ".off", ".stl")
SPLAT_SUFFIXES = (".splat", ".spz", ".ksplat")
ASSET_SUFFIXES = MESH_SUFFIXES + (".ply",) + SPLAT_SUFFIXES + (".exr",)
DEFAULT_SIZE = (512, 512)
_CONVENTION = {".obj": ("+Y", "assumed: OBJ has no up axis, +Y is the common one"),
               ".off": ("+Y", "assumed: OFF has no up axis, +Y is the common one"),
               ".ply": ("+Y", "assumed: the PLY header does not say"),
               ".stl": ("+Z", "assumed: STL has no up axis, CAD and 3D-printing files are +Z up")}
_SPLAT_CONVENTION = ("-Y", "assumed: COLMAP / 3DGS captures keep the y-down camera convention, "
                           "and the cloud's shape does not say")

__all__ = ["ASSET_SUFFIXES", "AssetNote", "OpenedAssets", "UP_AXES", "asset_kind",
           "is_scene_file", "open_assets", "scene_from_assets"]


@dataclass(frozen=True)
class OpenedAssets:
    """:func:`open_assets`'s result: the scene, and the content it loaded for each object
    (``(object, content)`` pairs, as :meth:`viewer.renderer.Renderer.add_geometry` takes them:
    a renderer need not read the files again)."""

    scene: Scene
    contents: tuple[tuple[ObjectSpec, object], ...] = ()
    notes: tuple[str, ...] = ()


def is_scene_file(path: str | Path) -> bool:
    """A scene TOML file: ``.toml``, or another extension no asset has whose text reads as
    TOML with a scene's tables."""
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix == ".toml":
        return True
    if suffix in ASSET_SUFFIXES or not path.is_file():
        return False
    try:
        import tomllib
    except ImportError:  # pragma: no cover - Python < 3.11
        import tomli as tomllib  # type: ignore[no-redef]
    try:
        with path.open("rb") as f:
            data = tomllib.loads(f.read(1 << 20).decode("utf-8"))
    except (UnicodeDecodeError, tomllib.TOMLDecodeError, OSError):
        return False
    return bool(data) and set(data) <= {"camera", "environment", "light", "lights", "objects",
                                        "render"}


def asset_kind(path: str | Path) -> str:
    """``"mesh"``, ``"splats"`` or ``"gbuffer"`` for an asset file (module docstring); a missing
    file or an unknown extension is a one-line :class:`InputError`."""
    path = Path(path)
    if path.is_dir():
        return "gbuffer"
    if not path.exists():
        raise InputError("file not found", where=path)
    suffix = path.suffix.lower()
    if suffix in MESH_SUFFIXES:
        return "mesh"
    if suffix in SPLAT_SUFFIXES:
        return "splats"
    if suffix == ".exr":
        return "gbuffer"
    if suffix == ".ply":
        _, elements = ply_header(path)
        return "splats" if is_splat_ply(elements) else "mesh"
    raise InputError(f"unknown asset extension {suffix or '(none)'!r} (open: "
                     f"{', '.join(ASSET_SUFFIXES)}, a G-buffer folder, or a scene .toml)",
                     where=path)


def open_assets(paths, env: str = "studio", up: str | None = None, floor: bool | str = False,
                size: tuple[int, int] | None = None, fov_y: float | None = None) -> OpenedAssets:
    """The scene of the asset files ``paths`` (module docstring).

    ``env``: a procedural name (:data:`viewer.environment.maps.PROCEDURAL`) or an environment file;
    ``up``: one of :data:`UP_AXES` for every asset (wins over markers and detection); ``floor``:
    a plane under the bounds, one of :data:`~viewer.scene.framing.FLOORS` (``True``: the
    catcher; ``False`` / ``None``: none); ``size``: the camera's (W, H); ``fov_y``: degrees
    (default the scene's). Errors are one-line :class:`InputError` / :class:`SceneError` naming the file.
    """
    paths = [Path(p) for p in paths]
    if not paths:
        raise SceneError("no asset given", where="assets")
    forced = None
    if up is not None:
        try:
            forced = normalize_up(up)
        except ValueError as exc:
            raise SceneError(str(exc), where="--up") from None
    if floor is True:
        floor = "catcher"
    if floor and floor not in FLOORS:
        raise SceneError(f"floor must be one of {', '.join(FLOORS)}, got {floor!r}",
                         where="--floor")
    objects, contents, notes = [], [], []
    box: Bounds | None = None
    far_boxes: list[Bounds] = []
    points = []  # what the camera is fitted to: each object's points inside its bounds
    for path in paths:
        kind = asset_kind(path)
        absolute = str(path.resolve())
        if kind == "gbuffer":
            objects.append(ObjectSpec(type="gbuffer", path=absolute))
            continue
        obj, content, note = _load(path, absolute, kind, forced)
        if note:
            notes.append(note)
            warnings.warn(note, AssetNote, stacklevel=2)
        objects.append(obj)
        contents.append((obj, content))
        b = content_bounds(content)
        if b is not None:
            box = b if box is None else box.union(b)
            points.append(_surface_points(content, b))
        if hasattr(content, "means"):  # a cloud's outliers: not framed, but not clipped either
            full = points_bounds(content.means)
            if full is not None:
                far_boxes.append(full)
    camera = Camera(size=tuple(size or DEFAULT_SIZE))
    if fov_y is not None:
        camera = replace(camera, fov_y=float(fov_y))
    if box is not None:
        if floor:
            plane = floor_object(box, floor)
            objects.append(plane)
            far_boxes.append(object_bounds(plane))
        camera = frame_camera(box, camera.fov_y, camera.size, also=tuple(far_boxes),
                              points=np.concatenate(points))
    elif floor:
        warnings.warn("--floor ignored: no asset has world-space geometry (image-space G-buffers "
                      "are drawn from their own camera)", stacklevel=2)
    scene = Scene(camera=camera, environment=environment_spec(env), objects=tuple(objects),
                  source=str(paths[0]))
    return OpenedAssets(scene, tuple(contents), tuple(notes))


def scene_from_assets(paths, **options) -> Scene:
    """:func:`open_assets`'s scene alone (options as there)."""
    return open_assets(paths, **options).scene


def environment_spec(env: str | Path) -> EnvironmentSpec:
    """``--env``: a procedural name or an environment file (made absolute; it must exist)."""
    name = str(env)
    if name.lower() in PROCEDURAL:
        return EnvironmentSpec(procedural=name.lower())
    path = Path(name)
    if not path.is_file():
        raise InputError(f"environment file not found (or use one of {', '.join(PROCEDURAL)})",
                         where=path)
    return EnvironmentSpec(path=str(path.resolve()))


def _load(path: Path, absolute: str, kind: str, forced: str | None):
    """``(object, loaded content, note or None)`` of one mesh or splat file."""
    suffix = path.suffix.lower()
    marker = None
    if forced is None and suffix == ".ply":
        marker = marked_up(ply_header(path)[0])
    if kind == "mesh":
        from ..geometry.loaders import load_mesh

        content = None
        if forced is not None:
            up, why = forced, None
        elif suffix in (".gltf", ".glb"):
            up, why = "+Y", None
        elif marker is None and suffix == ".ply":
            content = load_mesh(absolute)
            up, why = detect_mesh_up(content) or _CONVENTION[suffix]
        else:
            up, why = marker or _CONVENTION[suffix]
        transform = None if up == "+Y" else up_matrix(up)
        obj = ObjectSpec(type="mesh", path=absolute, transform=transform)
        if content is None or transform is not None:
            content = load_mesh(absolute, transform=None if transform is None else
                                _matrix(transform))
    else:
        from ..splats import read_splats, transform_splats

        raw = read_splats(absolute)
        if forced is not None:
            up, why = forced, None
        else:
            up, why = (marker or detect_splat_up(raw) or detect_cloud_up(raw)
                       or _SPLAT_CONVENTION)
        transform = None if up == "+Y" else up_matrix(up)
        obj = ObjectSpec(type="splats", path=absolute, transform=transform)
        content = raw if transform is None else transform_splats(raw, _matrix(transform))
    note = None if why is None else (f"{path}: taken as {up} up ({why}); to change it: "
                                     f"--up {'|'.join(UP_AXES)}")
    return obj, content, note


def _surface_points(content, bounds: Bounds) -> np.ndarray:
    """``[N, 3]`` points of one object's surface inside its ``bounds`` (a mesh's vertices, a
    cloud's centres without its outliers), for :func:`frame_camera`."""
    if hasattr(content, "means"):
        p = np.asarray(content.means, np.float64)
    else:
        p = np.concatenate([np.asarray(m.positions, np.float64).reshape(-1, 3) for m in content])
    inside = ((p >= np.asarray(bounds.lo)) & (p <= np.asarray(bounds.hi))).all(axis=1)
    return p[inside]


def _matrix(rows):
    return np.asarray(rows, np.float64)
