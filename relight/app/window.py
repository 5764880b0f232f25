"""The interactive viewer: a glfw window, Dear ImGui (imgui-bundle's native glfw/OpenGL3
backends) and the renderer's graph drawn with the window's own moderngl context.

    viewer = Viewer(load_scene("demo.toml"), offscreen=True)   # offscreen: glfw Null + EGL
    viewer.state.render = viewer.state.render.with_flat(exposure=1.0)
    viewer.run(frames=2)
    viewer.screenshot("shot.png")          # the view as shown (no UI); .exr: linear radiance
    viewer.screenshot("ui.png", ui=True)   # the whole window, panel and overlay included
    viewer.close()

Each frame: input -> UI (writes :class:`ViewerState`) -> if ``scene_from_state(state)`` changed,
``Renderer.draw`` (the same graph as ``relight render``) -> the view pass into the window ->
ImGui. Nothing is re-rendered, allocated or read back while nothing changes. A change that fails
(a corrupt dropped file, a bad scene, a model without weights) leaves the previous state and image
and shows the one-line message. Python warnings raised while a scene loads or renders (a glTF
feature the loader does not use, a model that ignores the light, ...) go to stderr as always and
to the message line as well. GPU time per pass comes from timer queries read one frame late.

The panel is docked at the left, a share of the window's width (drag its right edge to resize
it); the image is drawn beside it (:meth:`Viewer.view_area`), letterboxed at the render's aspect,
or filling that area when ``state.fit_view`` makes the render size follow it. Mouse over the
image: left drag orbits, right or middle drag (or shift + left) pans, the wheel zooms; R resets
the camera, H or F1 hides the panel. Files dropped on the window (glfw's drop callback,
:meth:`~.files.FileActions.drop`): ``.toml`` opens a scene, an image (``.hdr``, ``.exr``, ...)
becomes the environment, an asset (glTF, GLB, OBJ, PLY, ``.splat``) opens framed in a new scene.

The file actions (open, drop, save, a reference) are :class:`~.files.FileActions`, the output
(screenshots, the framebuffer read back) :class:`~.capture.Capture`: both mixed into
:class:`Viewer`.
"""
from __future__ import annotations

import sys
import time
import warnings
from dataclasses import replace

import numpy as np

from viewer.errors import RelightError, SceneError
from viewer.gbuffer import CHANNEL_NAMES
from viewer.gl.context import ContextOptions, create_window, make_current
from viewer.gl.timing import PassTimer
from viewer.models import SAMPLING_MODELS, sample_count
from viewer.renderer import FrameTargets, Renderer
from viewer.scene.description import Scene

from . import camera_control
from .capture import Capture
from .files import IMAGE_SUFFIXES, SCENE_SUFFIXES, FileActions
from .state import ViewerState, reset_camera, scene_from_state, state_from_scene

__all__ = ["IMAGE_SUFFIXES", "MAX_WINDOW", "PASS_NAMES", "SCENE_SUFFIXES", "Viewer"]

PASS_NAMES = ("gbuffer", "ibl", "shade", "forward", "tonemap", "view", "ui")
MAX_WINDOW = (1600, 1000)


class Viewer(FileActions, Capture):
    """One window on one :class:`ViewerState`; see the module docstring."""

    def __init__(self, scene: Scene, *, window_size: tuple[int, int] | None = None,
                 offscreen: bool = False, options: ContextOptions = ContextOptions(),
                 title: str = "relight view"):
        from imgui_bundle import imgui  # before glfw (create_window checks the order)

        if window_size is None:  # the render 1:1 beside the panel, unless over MAX_WINDOW
            from .panels import window_width_for

            w, h = scene.camera.size
            scale = min(1.0, MAX_WINDOW[1] / h)
            while scale > 0.05 and window_width_for(int(w * scale)) > MAX_WINDOW[0]:
                scale *= 0.98
            h = max(1, int(h * scale))
            window_size = (window_width_for(max(1, int(w * scale))), h)
        self.window = create_window(window_size, title, offscreen=offscreen, options=options)
        import glfw

        from viewer.passes.debug_view import DebugViewPass

        from .panels import ViewerUI

        self._glfw, self._imgui = glfw, imgui
        self.ctx = self.window.ctx
        self.renderer = Renderer(ctx=self.ctx)
        self.timers = PassTimer(self.ctx, deferred=True)
        self.timers.enabled = True
        self.renderer.profiler = self.timers
        self.view_pass = DebugViewPass(self.renderer.programs)
        self.state: ViewerState = state_from_scene(scene)
        self._good: ViewerState = self.state  # the last state that rendered
        self._scene: Scene | None = None  # what the targets hold
        self._aovs: tuple[str, ...] = ()  # G-buffer channels the targets hold for a channel view
        self._targets: FrameTargets | None = None
        self._reference = None  # RGBA32F texture of a loaded reference render
        self._shot: dict[tuple[int, int], tuple] = {}  # size -> (texture, fbo) for screenshots
        self.samples_per_frame = 4  # Monte-Carlo samples added per frame while accumulating
        self.frame_ms = 0.0
        self.frames = 0
        self.renders = 0  # how many times the render graph ran (tests: no work when idle)
        self._last_time = time.perf_counter()
        self._grab: np.ndarray | None = None  # the framebuffer read before the swap (ui shots)
        self._want_grab = False

        self._imgui_ctx = imgui.create_context()
        imgui.set_current_context(self._imgui_ctx)  # create_context does not when one exists
        io = imgui.get_io()
        io.set_ini_filename(None)  # no imgui.ini next to the user's files
        imgui.backends.glfw_init_for_opengl(self.window.address, True)
        imgui.backends.opengl3_init("#version 410 core")
        self.ui = ViewerUI(self)
        glfw.set_drop_callback(self.window.window, self._on_drop)

    def _on_drop(self, _window, paths) -> None:
        """glfw's drop callback (called from ``poll_events``): open what was dropped."""
        self.drop([str(p) for p in paths])

    # ---- the frame ---------------------------------------------------------------------------
    def frame(self) -> None:
        """One frame: events, UI, camera input, render if anything changed, present."""
        imgui, glfw = self._imgui, self._glfw
        make_current(self.ctx)
        imgui.set_current_context(self._imgui_ctx)  # several viewers may live in one process
        glfw.poll_events()
        imgui.backends.opengl3_new_frame()
        imgui.backends.glfw_new_frame()
        imgui.new_frame()
        self.ui.poll_dialogs()
        if self.state.show_ui:
            self.ui.draw()
        else:
            self.ui.width = 0.0
        self._input()
        if self.state.fit_view:
            _, _, w, h = self.view_area()
            if tuple(self.state.camera.size) != (w, h):
                self.state.camera = self.state.camera.with_size(w, h)
        self._render()
        self._present()
        now = time.perf_counter()
        self.frame_ms = (now - self._last_time) * 1e3
        self._last_time = now
        self.frames += 1

    def run(self, frames: int | None = None) -> None:
        """Run frames until the window is closed, or exactly ``frames`` frames."""
        n = 0
        while not self._glfw.window_should_close(self.window.window):
            if frames is not None and n >= frames:
                break
            self.frame()
            n += 1

    def _input(self) -> None:
        imgui = self._imgui
        io = imgui.get_io()
        state = self.state
        if not io.want_capture_keyboard:
            if imgui.is_key_pressed(imgui.Key.r, False):
                self.state = reset_camera(state)
            if imgui.is_key_pressed(imgui.Key.h, False) or imgui.is_key_pressed(imgui.Key.f1,
                                                                                  False):
                state.show_ui = not state.show_ui
        if io.want_capture_mouse:
            return
        dx, dy = io.mouse_delta.x, io.mouse_delta.y
        scale = self._view_rect()[4]
        cam = self.state.camera
        if (dx or dy) and imgui.is_mouse_down(0) and not io.key_shift:
            cam = camera_control.drag_orbit(cam, dx, dy)
        elif (dx or dy) and (imgui.is_mouse_down(1) or imgui.is_mouse_down(2)
                             or (imgui.is_mouse_down(0) and io.key_shift)):
            cam = camera_control.pan(cam, dx / scale, dy / scale)
        if io.mouse_wheel:
            cam = camera_control.zoom(cam, camera_control.wheel_factor(io.mouse_wheel))
        self.state.camera = cam

    def _render(self) -> None:
        """Run the render graph if the scene changed, or add samples while a Monte-Carlo model
        is accumulating (the renderer restarts its running mean on any change)."""
        scene = scene_from_state(self.state)
        # a channel view needs that channel allocated (the layout is specialised to the scene)
        aovs = (self.state.view,) if self.state.view in CHANNEL_NAMES else ()
        accumulating = (scene.render.model in SAMPLING_MODELS and self._targets is not None
                        and self._targets.samples < sample_count(scene.render))
        if scene == self._scene and aovs == self._aovs and not accumulating:
            return  # nothing changed: no GPU work beyond presenting
        try:
            # geometry loads on the first draw of a scene: its warnings reach the message line
            with warnings.catch_warnings(record=True) as caught:
                self._targets = self.renderer.draw(scene, progressive=True,
                                                   samples_per_frame=self.samples_per_frame,
                                                   aovs=aovs)
        except RelightError as exc:
            self.timers.begin(None)
            self.reject(str(exc))
            self.show_warnings(caught, after_message=True)
            # a failed draw may have cleared the targets: draw the last good scene again
            if self._scene is not None:
                self._targets = self.renderer.draw(self._scene, progressive=True,
                                                   samples_per_frame=self.samples_per_frame,
                                                   aovs=self._aovs)
            return
        self.show_warnings(caught)
        self._scene = scene
        self._aovs = aovs
        self._good = self.state.copy()
        self.renders += 1

    def reject(self, message: str) -> None:
        """Keep the last good scene state; show ``message``. Viewer-only settings stay."""
        good, cur = self._good, self.state
        self.state = replace(cur, scene=good.scene, camera=good.camera,
                             environment=good.environment, render=good.render,
                             object_materials=good.object_materials,
                             material_override=good.material_override, light=good.light,
                             lights=good.lights, message=message)

    def show_warnings(self, caught: list, after_message: bool = False) -> None:
        """Warnings recorded while loading or drawing (``warnings.catch_warnings(record=True)``):
        each printed to stderr as Python prints it, and shown in the message line, one line each
        (in place of the last message, or after it with ``after_message``: an error)."""
        lines = []
        for w in caught:  # as warnings.showwarning prints them (whoever replaced it: pytest)
            sys.stderr.write(warnings.formatwarning(w.message, w.category, w.filename, w.lineno))
            lines.append(f"warning: {w.message}")
        if not lines:
            return
        text = "\n".join(dict.fromkeys(lines))  # unique, in order
        message = self.state.message
        self.state.message = f"{message}\n{text}" if after_message and message else text

    def view_area(self) -> tuple[int, int, int, int]:
        """(x, y, w, h) in framebuffer pixels (y up): the window beside the panel."""
        fw, fh = self.window.framebuffer_size()
        sx = self._imgui.get_io().display_framebuffer_scale.x or 1.0
        panel = min(fw - 1, int(round(self.ui.width * sx))) if self.state.show_ui else 0
        return panel, 0, max(1, fw - panel), max(1, fh)

    def _view_rect(self) -> tuple[int, int, int, int, float]:
        """(x, y, w, h, scale): where the render is shown in the window (letterboxed in
        :meth:`view_area`, y up)."""
        ax, ay, aw, ah = self.view_area()
        rw, rh = self.state.camera.size if self._scene is None else self._scene.camera.size
        scale = min(aw / rw, ah / rh) if rw and rh else 1.0
        w, h = max(1, int(round(rw * scale))), max(1, int(round(rh * scale)))
        return ax + (aw - w) // 2, ay + (ah - h) // 2, w, h, max(scale, 1e-6)

    def _draw_view(self) -> None:
        """The chosen view of the current targets into the bound framebuffer's viewport."""
        state = self.state
        try:
            self.view_pass.run(self._targets, state.view, exposure=state.render.display.exposure,
                               reference=self._reference_for_view(),
                               error_scale=state.error_scale, depth_scale=self._depth_scale())
        except RelightError as exc:
            state.view, state.message = "display", str(exc)
            self.view_pass.run(self._targets, "display")

    def _reference_for_view(self):
        ref = self._reference
        if ref is None or self._targets is None:
            return None
        if tuple(ref.size) != tuple(self._targets.radiance.size):
            w, h = self._targets.radiance.size
            raise SceneError(f"the reference is {ref.size[0]}x{ref.size[1]}, the render {w}x{h}",
                             where=self.state.reference_path)
        return ref

    def _depth_scale(self) -> float:
        cam = self.state.camera
        dist = float(np.linalg.norm(np.subtract(cam.position, cam.target)))
        return 1.0 / max(2.0 * dist, 1e-6)

    def _present(self) -> None:
        ctx, imgui = self.ctx, self._imgui
        screen = ctx.screen
        screen.use()
        fw, fh = self.window.framebuffer_size()
        ctx.viewport = (0, 0, fw, fh)
        ctx.clear(0.08, 0.08, 0.09, 1.0)
        if self._targets is not None:
            x, y, w, h, _ = self._view_rect()
            ctx.viewport = (x, y, w, h)
            self.timers.begin("view")
            self._draw_view()
            ctx.viewport = (0, 0, fw, fh)
        if self.state.show_overlay:
            self.ui.overlay()
        imgui.render()
        self.timers.begin("ui")
        imgui.backends.opengl3_render_draw_data(imgui.get_draw_data())
        self.timers.end_frame()
        if self._want_grab:  # the back buffer as drawn: after the swap it is undefined
            self._want_grab, self._grab = False, self.read_framebuffer()
        self._glfw.swap_buffers(self.window.window)

    @property
    def targets(self) -> dict | None:
        """The render targets on screen (what :meth:`Renderer.draw` returned), or None."""
        return self._targets

    def current_scene(self) -> Scene:
        """The scene on screen (the last one that rendered)."""
        return self._scene if self._scene is not None else scene_from_state(self.state)

    def close(self) -> None:
        imgui = self._imgui
        if self._imgui_ctx is None:
            return
        make_current(self.ctx)
        imgui.set_current_context(self._imgui_ctx)
        imgui.backends.opengl3_shutdown()
        imgui.backends.glfw_shutdown()
        imgui.destroy_context(self._imgui_ctx)
        self._imgui_ctx = None
        self.timers.release()
        self.view_pass.release()
        for tex, fbo in self._shot.values():
            fbo.release()
            tex.release()
        if self._reference is not None:
            self._reference.release()
        self.renderer.release()
        self.window.close()

    def __enter__(self) -> "Viewer":
        return self

    def __exit__(self, *exc) -> None:
        self.close()
