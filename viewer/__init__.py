"""The relighting workbench runtime: headless deferred rendering with moderngl (never imports torch).

Public API::

    from viewer import Renderer, load_scene, Scene
    frame = Renderer().render(load_scene("scene.toml"), aovs=("normal",))

See :mod:`viewer.renderer` for :class:`Renderer` and :class:`Frame`, :mod:`viewer.scene` for the
scene dataclasses, and :mod:`viewer.errors` for the one-line errors everything raises.
"""
from .errors import RelightError

__version__ = "0.1.0"
__all__ = ["Renderer", "Frame", "Scene", "load_scene", "scene_from_dict", "RelightError"]


def __getattr__(name):  # lazy: importing viewer must stay cheap and GL-free
    if name in ("Renderer", "Frame"):
        from . import renderer

        return getattr(renderer, name)
    if name in ("Scene", "load_scene", "scene_from_dict"):
        from . import scene

        return getattr(scene, name)
    raise AttributeError(name)
