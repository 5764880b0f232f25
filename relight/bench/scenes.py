"""The bench's scenes: TOML files in ``assets/scenes/bench/`` (the demo is ``assets/scenes/demo.toml``).

Scenes that need generated content (an image-space stack captured from a scene, a splat cloud)
are TOML files too; the bench adds the generated object (see :mod:`relight.bench.run`).
"""
from __future__ import annotations

import dataclasses

from assets import ASSET_ROOT
from viewer.scene.description import ObjectSpec, Scene, load_scene
from viewer.scene.material import Material

BENCH_SCENES = ASSET_ROOT / "scenes" / "bench"


def bench_scene(name: str) -> Scene:
    """``assets/scenes/bench/<name>.toml``."""
    return load_scene(BENCH_SCENES / f"{name}.toml")


def demo_scene() -> Scene:
    return load_scene(ASSET_ROOT / "scenes" / "demo.toml")


def with_object(scene: Scene, obj: ObjectSpec) -> Scene:
    """``scene`` with ``obj`` added (a generated stack or cloud)."""
    return dataclasses.replace(scene, objects=scene.objects + (obj,))


def with_material(scene: Scene, **changes) -> Scene:
    """``scene`` with every object's material changed (e.g. ``roughness=0.3``)."""
    objects = tuple(dataclasses.replace(o, material=dataclasses.replace(o.material or Material(),
                                                                        **changes))
                    for o in scene.objects)
    return dataclasses.replace(scene, objects=objects)
