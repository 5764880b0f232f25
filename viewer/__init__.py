"""The relighting workbench runtime: headless deferred rendering with moderngl (never imports torch).

Public API::

    from viewer import Renderer, load_scene, Scene
    frame = Renderer().render(load_scene("scene.toml"), aovs=("normal",))

The rooms, one domain each (every package's docstring says what it holds and what it imports):
:mod:`.scene` (scene files, their checks and ``[render]`` settings, materials, camera, assets and
framing), :mod:`.environment` (HDR maps, compact-light extraction, IBL, importance sampling, the
disk cache), :mod:`.lighting` (punctual lights, shadow frames, cascades), :mod:`.geometry` (meshes,
primitives, image stacks, their cache), :mod:`.splats` (Gaussian splat files), :mod:`.neural`
(exported neural shaders), :mod:`.gl` (contexts, programs), :mod:`.passes` (one module per GLSL
pass), :mod:`.graph` (the frame graph). At the top: :mod:`.renderer` (:class:`Renderer`),
:mod:`.frame` (what a render produces), :mod:`.models` (the shading-model registry),
:mod:`.specialize` (what a scene requires), :mod:`.gbuffer` (the G-buffer layout),
:mod:`.resources` (the renderer's bounded GPU resources), :mod:`.cache` (bounded caches),
:mod:`.imageio` (image files) and :mod:`.errors` (the one-line errors everything raises).
"""
from .errors import RelightError

__version__ = "0.1.0"
__all__ = ["Renderer", "Frame", "Scene", "load_scene", "scene_from_dict", "RelightError"]


def __getattr__(name):  # lazy: importing viewer must stay cheap and GL-free
    if name in ("Renderer", "Frame"):
        from . import renderer

        return getattr(renderer, name)
    if name in ("Scene", "load_scene", "scene_from_dict"):
        from .scene import description

        return getattr(description, name)
    raise AttributeError(name)
