"""The ImGui panel: they read and write the viewer's :class:`~relight.app.state.ViewerState` and
nothing else (file actions call the :class:`~relight.app.window.Viewer`'s methods).

One side panel docked at the left edge, the full height of the window, :data:`PANEL_FRACTION` of
its width (at least :data:`PANEL_MIN` pixels, at most :data:`PANEL_MAX_FRACTION` of the window);
the user drags its right edge to resize it (the fraction follows, so it keeps its share when the
window is resized) and hides it with H or F1. The image is drawn beside it
(:meth:`~relight.app.window.Viewer.view_area`), so the panel never covers it; sections open below
each other and the panel scrolls within itself.

Built from the registries, so new models and knobs appear without changes here: the model list is
:data:`viewer.models.MODELS`; the "Shading" section has one widget per field of
:class:`~viewer.scene.description.RenderSettings` (bool: checkbox, int: input, float: drag, str: a combo when
the field's choices are known, else a text field); views are :data:`relight.app.state.VIEWS`.
Sections: :mod:`.scene` (top rows, Camera, Light), :mod:`.material`, :mod:`.settings` (Shading,
Inspect, Output); :mod:`.overlay` the overlay; :mod:`.layout` sizes widgets so labels show and
records where each went (``rects``, ``items``: tests click the real widgets and check the labels).
"""
from __future__ import annotations

from .choices import CHOICES, ERROR_COLOUR, LIMITS, QUICK_FIELDS
from .layout import Item, Layout
from .material import MaterialPanel
from .overlay import draw_overlay, frame_lines
from .scene import ScenePanels
from .settings import SettingsPanels

__all__ = ["CHOICES", "LIMITS", "PANEL_FRACTION", "PANEL_MAX_FRACTION", "PANEL_MIN",
           "QUICK_FIELDS", "SECTIONS", "Item", "ViewerUI", "frame_lines", "panel_limits",
           "window_width_for"]

PANEL_FRACTION = 0.3  # of the window's width, until the user drags the panel's edge
PANEL_MIN = 240.0  # pixels (window coordinates), unless the window is narrower than twice that
PANEL_MAX_FRACTION = 0.5
SECTIONS = ("Camera", "Light", "Material", "Shading", "Inspect", "Output")


def panel_limits(window_width: float) -> tuple[float, float]:
    """(min, max) width of the panel in a window ``window_width`` pixels wide."""
    hi = PANEL_MAX_FRACTION * window_width
    return min(PANEL_MIN, hi), hi


def window_width_for(view_width: int) -> int:
    """The narrowest window whose area beside the panel (at :data:`PANEL_FRACTION`) is
    ``view_width`` pixels wide: the window a render of that width is shown 1:1 in."""
    width = int(view_width)
    while width - max(panel_limits(width)[0], min(panel_limits(width)[1],
                                                   PANEL_FRACTION * width)) < view_width:
        width += 1
    return width


class ViewerUI(Layout, ScenePanels, MaterialPanel, SettingsPanels):
    def __init__(self, viewer):
        from imgui_bundle import imgui

        self.viewer = viewer
        self.imgui = imgui
        self.rects: dict[str, tuple[float, float, float, float]] = {}  # label -> x0, y0, x1, y1
        self.items: list[Item] = []
        self.right = self.edge = 0.0
        self._fitted: dict[str, str] = {}
        self._widest: dict[str, float] = {}  # section -> its widest label (layout.py)
        self._section = ""
        self.fraction = PANEL_FRACTION  # the panel's share of the window width
        self.width = 0.0  # the panel's width drawn last (window pixels); 0 while hidden
        self.overlay_lines: list[str] = []  # what the overlay drew last
        self.open_all = False  # open every section and object (tests, screenshots)
        self._dialog = None  # a pending portable-file-dialog: (kind, dialog)
        self._size = list(viewer.state.camera.size)
        self._light_memory = None  # the light as it was when switched off (switching on restores)
        self.dormant: dict[str, str] = {}  # [render] knobs greyed in Shading: key -> what it tunes

    def draw(self) -> None:
        """The panel, docked left; sets :attr:`width` for the view area beside it."""
        imgui, viewer = self.imgui, self.viewer
        io = imgui.get_io()
        ww, wh = io.display_size.x, io.display_size.y
        lo, hi = panel_limits(ww)
        width = max(lo, min(hi, self.fraction * ww))
        imgui.set_next_window_pos((0, 0), imgui.Cond_.always)
        imgui.set_next_window_size((width, wh), imgui.Cond_.always)
        imgui.set_next_window_size_constraints((lo, wh), (hi, wh))
        flags = (imgui.WindowFlags_.no_title_bar | imgui.WindowFlags_.no_move
                 | imgui.WindowFlags_.no_collapse | imgui.WindowFlags_.no_saved_settings)
        imgui.begin("relight", None, flags)
        self.width = imgui.get_window_width()
        if abs(self.width - width) > 0.5 and ww > 0:  # the user dragged the edge
            self.fraction = self.width / ww
        self._begin_layout()
        imgui.push_text_wrap_pos(0.0)  # text wraps at the panel's edge
        state = viewer.state
        if state.message:
            imgui.text_colored(ERROR_COLOUR, state.message)
            if imgui.small_button("dismiss"):
                state.message = None
            self._record("dismiss", "button")
        # a section may replace viewer.state (reset, new environment): each gets the current one
        self.section("")
        self._quick(viewer.state)
        for title in SECTIONS:
            self.section(title)
            if self.open_all:
                imgui.set_next_item_open(True)
            is_open = imgui.collapsing_header(title)
            self._record(title, "header")
            if is_open:
                getattr(self, "_" + title.lower())(viewer.state)
        imgui.pop_text_wrap_pos()
        imgui.end()

    def overlay(self) -> None:
        self.overlay_lines = draw_overlay(self.imgui, self.viewer)

    # ---- file dialogs ----------------------------------------------------------------------------
    def _open_dialog(self, kind: str, title: str, filters: list[str]) -> None:
        try:
            from imgui_bundle import portable_file_dialogs as pfd

            self._dialog = (kind, pfd.open_file(title, "", filters))
        except Exception as exc:  # no dialog backend (zenity/kdialog) on this machine
            self.viewer.state.message = f"file dialog unavailable ({exc}); type the path instead"

    def poll_dialogs(self) -> None:
        if self._dialog is None:
            return
        kind, dialog = self._dialog
        if not dialog.ready(0):
            return
        self._dialog = None
        chosen = dialog.result()
        if not chosen:
            return
        if kind == "environment":
            self.viewer.set_environment_file(chosen[0])
        else:
            self.viewer.load_reference(chosen[0])
