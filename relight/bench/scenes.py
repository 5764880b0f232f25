"""The bench's scenes: TOML files in ``assets/scenes/bench/`` (the demo is ``assets/scenes/demo.toml``).

Scenes that need generated content (an image-space stack captured from a scene, a splat cloud)
are TOML files too; the bench adds the generated object (see :mod:`relight.bench.run`).

Every row names its rays: the scenes the bench loads start from the rasterised models alone
(:func:`rasterised`: ``[render] raytrace`` off, where the viewer's default turns it on), and the
rungs of the real-time tier say ``raytrace = true`` (``+rays``).
"""
from __future__ import annotations

import dataclasses

from assets import ASSET_ROOT
from viewer.scene.description import ObjectSpec, Scene, load_scene
from viewer.scene.material import Material

BENCH_SCENES = ASSET_ROOT / "scenes" / "bench"


def rasterised(scene: Scene) -> Scene:
    """``scene`` without the real-time tier's rays (module docstring)."""
    return scene.with_render(raytrace=False)


def bench_scene(name: str) -> Scene:
    """``assets/scenes/bench/<name>.toml``, :func:`rasterised`."""
    return rasterised(load_scene(BENCH_SCENES / f"{name}.toml"))


def demo_scene() -> Scene:
    return rasterised(load_scene(ASSET_ROOT / "scenes" / "demo.toml"))


def with_object(scene: Scene, obj: ObjectSpec) -> Scene:
    """``scene`` with ``obj`` added (a generated stack or cloud)."""
    return dataclasses.replace(scene, objects=scene.objects + (obj,))


def with_material(scene: Scene, **changes) -> Scene:
    """``scene`` with every object's material changed (e.g. ``roughness=0.3``)."""
    objects = tuple(dataclasses.replace(o, material=dataclasses.replace(o.material or Material(),
                                                                        **changes))
                    for o in scene.objects)
    return dataclasses.replace(scene, objects=objects)
