"""The panel's Shading (one widget per [render] key), Inspect (views, a reference) and Output
(screenshot, save/open scene) sections."""
from __future__ import annotations

from viewer.models import model_info, sample_count
from viewer.passes.debug_view import shadow_views
from viewer.scene.settings import FrameFacts, dormant_keys

from ..state import VIEWS
from .choices import CHOICES, LIMITS, QUICK_FIELDS


class SettingsPanels:
    """Shading, Inspect, Output; mixed into :class:`~.ViewerUI`."""

    def _shading(self, state) -> None:
        imgui = self.imgui
        r = state.render
        changes = {}
        self.dormant = self._dormant(r)
        for key, value in r.flat().items():  # one widget per [render] key
            if key in QUICK_FIELDS:
                continue
            if key in self.dormant:  # greyed, still editable, its tooltip says why
                imgui.push_style_color(imgui.Col_.text,
                                       imgui.get_style().color_(imgui.Col_.text_disabled))
            if key == "samples" and value is None:  # unset: the model's own count, editable
                value = sample_count(r)
            choices = (CHOICES.get(key) or (lambda: None))() if isinstance(value, str) else None
            if isinstance(value, bool):  # its label wraps beside it (and records itself)
                _, new = self._checkbox(key, value)
            elif isinstance(value, int):
                lo, hi = LIMITS.get(key, (0, 1 << 30))
                _, new = imgui.input_int(self.fit(key), value)
                new = max(lo, min(hi, new))
            elif isinstance(value, float):
                _, new = imgui.drag_float(self.fit(key), value, 0.01)
            elif choices:
                new = self._combo(key, value, choices)  # tracks itself
            elif isinstance(value, str):
                _, new = imgui.input_text(self.fit(key), value)
            else:
                imgui.text_disabled(f"{key}: {value!r}")
                new = choices = value  # shown, not a widget: nothing to track
            if key in self.dormant:
                imgui.pop_style_color()
                imgui.set_item_tooltip(f"no effect: tunes {self.dormant[key]}, which this "
                                       f"frame does not run")
            if not choices and not isinstance(value, bool):
                self._track(key)
            if new != value:
                changes[key] = new
        if changes:
            state.render = r.with_flat(**changes)

    def _dormant(self, render) -> dict[str, str]:
        """The knobs of what the last frame did not run (:func:`dormant_keys`, from the frame's
        graph and lighting defines): none before the first frame."""
        viewer = self.viewer
        graph, targets = viewer.renderer.last_graph, getattr(viewer, "_targets", None)
        if graph is None or targets is None:
            return {}
        return dormant_keys(FrameFacts.of(render, model_info(render.model),
                                          targets.variant.defines, graph))

    def _inspect(self, state) -> None:
        imgui, viewer = self.imgui, self.viewer
        targets = getattr(viewer, "_targets", None)  # the last frame's shadow maps are views too
        views = VIEWS + (shadow_views(targets) if targets is not None else ())
        state.view = self._combo("view", state.view, views)
        if state.view == "error":
            state.error_scale = self._slider("error scale", state.error_scale, 0.001, 2.0)
        ref = state.reference_path or ""
        changed, ref = imgui.input_text(self.fit("reference"), ref)
        self._track("reference")
        if changed:
            state.reference_path = ref
        if self.button("load reference") and ref:
            viewer.load_reference(ref)
        if self.button("browse reference...", same_line=True) and self._dialog is None:
            self._open_dialog("reference", "reference render", ["EXR/HDR", "*.exr *.hdr"])

    def _output(self, state) -> None:
        imgui, viewer = self.imgui, self.viewer
        _, state.screenshot_path = imgui.input_text(self.fit("screenshot"),
                                                    state.screenshot_path)
        self._track("screenshot")
        if self.button("save screenshot"):
            try:
                viewer.screenshot(state.screenshot_path)
                state.message = f"saved {state.screenshot_path}"
            except Exception as exc:  # a RelightError, or the image writer's OSError
                state.message = str(exc)
        imgui.text_disabled(".png: the view as shown, without the panel; .exr: linear radiance")
        _, state.scene_path = imgui.input_text(self.fit("scene file"), state.scene_path)
        self._track("scene file")
        if self.button("save scene"):
            viewer.save_scene(state.scene_path)
        if self.button("open scene", same_line=True):
            viewer.open_scene(state.scene_path)
