"""The keys of cached truths (:func:`config_key`) and whether a written reference is finished
(:func:`finished_reference`): what :func:`relight.reference.render.render_reference`'s
checkpoints, ``relight reference`` and the gallery's cache (:func:`relight.gallery.panels.
cached_truth`) compare before they trace again."""
from __future__ import annotations

import hashlib
import json
import os
from dataclasses import asdict, fields
from pathlib import Path

from viewer.scene.description import Scene

from .scene import ALPHA_TRACING, alpha_modes

# the [render] settings the tracer reads (the rest are the rasteriser's: a new one of those, or
# a change of one, keeps every cached truth)
TRACED_RENDER = {"background": lambda r: r.display.background,
                 "multiscatter": lambda r: bool(r.multiscatter)}


def config_key(scene: Scene, options) -> str:
    """A digest of everything a checkpoint's samples depend on (``options``: the
    :class:`~relight.reference.render.ReferenceOptions`): the scene but the render
    settings the tracer does not read (:data:`TRACED_RENDER`), and the options (with glTF
    alphaMode MASK or BLEND: how it is traced, :data:`~relight.reference.scene.ALPHA_TRACING`;
    scenes without keep their keys; so do those at the default ``sun_strength``)."""
    data = {"scene": repr(scene.__class__) + repr([(f.name, getattr(scene, f.name))
                                                   for f in fields(scene)
                                                   if f.name not in ("source", "render")]),
            "render": {k: read(scene.render) for k, read in TRACED_RENDER.items()},
            "options": {k: v for k, v in asdict(options).items()
                        if k not in ("spp", "batch_spp")}}
    modes = alpha_modes(scene)
    if modes:
        data["alpha"] = [ALPHA_TRACING, modes]
    if scene.environment.sun_strength != 1.0:  # not in the repr at its default (maps.py)
        data["sun_strength"] = float(scene.environment.sun_strength)
    text = json.dumps(data, sort_keys=True)
    return hashlib.sha256(text.encode()).hexdigest()[:16]


def finished_reference(out: str | os.PathLike, scene: Scene, options,
                       spp: int) -> dict | None:
    """The metadata of a reference already written to ``out`` (its ``.json`` beside it) for this
    scene and options with at least ``spp`` samples, or None: then it must be (re)traced. An
    unreadable ``.json`` counts as none."""
    meta = Path(out).with_suffix(".json")
    if not meta.is_file():
        return None
    try:
        done = json.loads(meta.read_text())
    except ValueError:
        return None
    if done.get("key") == config_key(scene, options) and done.get("spp", 0) >= spp:
        return done
    return None
