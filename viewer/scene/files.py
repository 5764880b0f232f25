"""Writing scenes back to TOML: the inverse of :func:`viewer.scene.description.load_scene`.

    save_scene(scene, "edited.toml")
    load_scene("edited.toml") == scene      # up to ``source``: equal dataclasses, equal pixels

Every field is written from the dataclasses themselves (``dataclasses.fields``), so render
settings or environment knobs added later are saved without changes here. Floats are written with
``repr`` precision (tomli-w), paths as the absolute paths the loader resolved, and fields that hold
``None`` or an object type's defaults are left out (the loader rejects keys a type does not take).
A file environment is written without the procedural sky's ``width`` and ``sun_*`` keys: they do
nothing there, and load back as their defaults (so a scene that holds the defaults, as every scene
``relight scene`` makes does, loads back equal; one that holds other values renders the same).
"""
from __future__ import annotations

import dataclasses
import os
from pathlib import Path
from typing import Any

import tomli_w

from ..errors import SceneError
from ..lighting.tables import light_table
from .description import ObjectSpec, Scene
from .material import EXTENSION_FIELDS, Material


def _plain(value: Any) -> Any:
    """Dataclass values -> TOML values: tuples become lists, nested tuples nested lists."""
    if isinstance(value, tuple):
        return [_plain(v) for v in value]
    if dataclasses.is_dataclass(value):
        return {f.name: _plain(getattr(value, f.name)) for f in dataclasses.fields(value)
                if getattr(value, f.name) is not None}
    return value


def _table(obj, skip_defaults: bool = False) -> dict:
    out = {}
    for f in dataclasses.fields(obj):
        value = getattr(obj, f.name)
        if value is None:
            continue
        if skip_defaults and f.default is not dataclasses.MISSING and value == f.default:
            continue
        out[f.name] = _plain(value)
    return out


_OBJECT_DEFAULTS = ObjectSpec(type="sphere")
_MATERIAL_DEFAULTS = Material()


def _object_table(obj: ObjectSpec) -> dict:
    out: dict[str, Any] = {"type": obj.type}
    for f in dataclasses.fields(obj):
        if f.name in ("type", "material"):
            continue
        value = getattr(obj, f.name)
        # a value equal to the default was either written so or left out: both load equal, and
        # leaving it out keeps keys a type does not accept (a sphere's "rows") out of the file
        if value is None or value == getattr(_OBJECT_DEFAULTS, f.name):
            continue
        out[f.name] = _plain(value)
    if obj.material is not None:  # the glTF extensions' fields only where they are set
        defaults = _plain(_MATERIAL_DEFAULTS)  # without the fields whose default is None (ior)
        out["material"] = {k: v for k, v in _plain(obj.material).items()
                           if k not in EXTENSION_FIELDS or v != defaults.get(k)}
    return out


# the procedural environments' own knobs: a file environment (``path``) does not use them
_PROCEDURAL_ONLY = ("width", "sun_elevation_deg", "sun_azimuth_deg", "sun_radiance")


def _environment_table(env) -> dict:
    """``[environment]``: every field, except that a file environment leaves out the procedural
    sky's ``width``, sun position and sun radiance, which mean nothing for a file (they load back
    as their defaults)."""
    out = _table(env)
    if env.path is not None:
        for name in _PROCEDURAL_ONLY:
            out.pop(name, None)
    return out


def scene_to_dict(scene: Scene) -> dict:
    """The TOML document of ``scene`` as plain dicts and lists (what ``scene_from_dict`` reads)."""
    doc = {
        "camera": _table(scene.camera),
        "environment": _environment_table(scene.environment),
        "objects": [_object_table(o) for o in scene.objects],
        "render": {k: _plain(v) for k, v in scene.render.flat().items() if v is not None},
    }
    if scene.lights:  # the scene's own lights as [[lights]] (never the objects' own lights)
        doc["lights"] = [light_table(li) for li in scene.lights]
    return doc


def scene_toml(scene: Scene, comment: str | None = None) -> str:
    """The TOML text of ``scene`` (what :func:`save_scene` writes), after an optional one-line
    ``# comment``."""
    head = f"# {' '.join(comment.split())}\n" if comment else ""
    return head + tomli_w.dumps(scene_to_dict(scene))


def save_scene(scene: Scene, path: str | os.PathLike) -> Path:
    """Write ``scene`` as TOML to ``path`` (parent folder must exist); returns the path.

    ``load_scene(path)`` gives back an equal :class:`Scene` (apart from ``source``), so
    ``relight render path`` renders the same pixels. Raises :class:`SceneError` when the folder
    is missing or the file cannot be written.
    """
    path = Path(path)
    if not path.resolve().parent.is_dir():
        raise SceneError("folder does not exist", where=path.parent)
    text = scene_toml(scene, "saved by relight view")
    try:
        tmp = path.with_name(path.name + ".tmp")
        tmp.write_text(text, encoding="utf-8")
        os.replace(tmp, path)
    except OSError as exc:
        raise SceneError(f"cannot write the scene ({exc.strerror or exc})", where=path) from None
    return path
