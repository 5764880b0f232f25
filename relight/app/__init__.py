"""``relight view``: the interactive viewer over the renderer's graph.

:mod:`.state` holds all viewer state in one dataclass and maps it to a :class:`~viewer.scene.description.Scene`
(no GL); :mod:`.camera_control` is orbit/pan/zoom math (no GL); :mod:`.panels` the ImGui panel
and overlay; :mod:`.window` the glfw window, main loop and GPU timers; :mod:`.files` its file
actions (open, drop, save, a reference render) and :mod:`.capture` its screenshots. Importing this package is
cheap: the window pulls in imgui-bundle and glfw only when a :class:`~.window.Viewer` is made.
"""
from .state import ViewerState, scene_from_state, state_from_scene

__all__ = ["ViewerState", "scene_from_state", "state_from_scene"]
