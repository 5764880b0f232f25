"""The ImGui panels: they read and write the viewer's :class:`~relight.app.state.ViewerState` and
nothing else (file actions call the :class:`~relight.app.window.Viewer`'s methods).

Built from the registries, so new models and knobs appear without changes here: the model list is
:data:`viewer.models.MODELS`; the "Shading" panel has one widget per field of
:class:`~viewer.scene.RenderSettings` (bool: checkbox, int: input, float: drag, str: a combo when
the field's choices are known, else a text field); views are :data:`relight.app.state.VIEWS`.

``rects`` records every widget's screen rectangle by label, so tests can click and drag the real
widgets through the glfw backend's input callbacks.
"""
from __future__ import annotations

from dataclasses import replace

from viewer.environment import PROCEDURAL
from viewer.material import Material
from viewer.models import MODELS, SAMPLING_MODELS, SAMPLINGS
from viewer import scene as scene_module
from viewer.lights import unit_direction
from viewer.scene import BACKGROUNDS, TONEMAPS
from viewer.settings import AA_MODES, SSAA_MAX, SSAO_SCALE_MAX
from .state import DEFAULT_LIGHT, MATERIAL_FIELDS, VIEWS, MaterialOverride, light_angles, \
    light_direction, reset_camera, with_procedural_environment

# RenderSettings fields with a fixed set of values (others get a text field)
CHOICES = {"model": lambda: tuple(MODELS), "sampling": lambda: SAMPLINGS,
           "tonemap": lambda: TONEMAPS, "background": lambda: BACKGROUNDS, "aa": lambda: AA_MODES,
           "precision": lambda: getattr(scene_module, "PRECISIONS", None),
           "mis_heuristic": lambda: getattr(scene_module, "MIS_HEURISTICS", None)}
QUICK_FIELDS = ("model", "exposure", "tonemap")  # shown at the top, not again under Shading
LIMITS = {"exposure": (-10.0, 10.0), "samples": (1, 1 << 16), "seed": (0, (1 << 31) - 1),
          # the ranges viewer.scene_checks.validate_render accepts
          "ssao_rays": (1, 1024), "ssao_steps": (1, 256), "ssao_scale": (1, SSAO_SCALE_MAX),
          "ssaa": (1, SSAA_MAX)}
ERROR_COLOUR = (1.0, 0.45, 0.4, 1.0)


class ViewerUI:
    def __init__(self, viewer):
        from imgui_bundle import imgui

        self.viewer = viewer
        self.imgui = imgui
        self.rects: dict[str, tuple[float, float, float, float]] = {}  # label -> x0, y0, x1, y1
        self._dialog = None  # a pending portable-file-dialog: (kind, dialog)
        self._size = list(viewer.state.camera.size)
        self._light_memory = None  # the light as it was when switched off (switching on restores)

    # ---- helpers ---------------------------------------------------------------------------------
    def _track(self, label: str) -> None:
        a, b = self.imgui.get_item_rect_min(), self.imgui.get_item_rect_max()
        self.rects[label] = (a.x, a.y, b.x, b.y)

    def _combo(self, label: str, current: str, items) -> str:
        items = list(items)
        index = items.index(current) if current in items else 0
        changed, index = self.imgui.combo(label, index, items)
        self._track(label)
        return items[index] if changed else current

    def _slider(self, label: str, value: float, lo: float, hi: float, fmt: str = "%.3f") -> float:
        _, value = self.imgui.slider_float(label, float(value), lo, hi, fmt)
        self._track(label)
        return value

    # ---- panels ----------------------------------------------------------------------------------
    def draw(self) -> None:
        imgui, viewer = self.imgui, self.viewer
        state = viewer.state
        imgui.set_next_window_pos((0, 0), imgui.Cond_.first_use_ever)
        width = min(340.0, imgui.get_io().display_size.x)
        imgui.set_next_window_size((width, 0), imgui.Cond_.first_use_ever)
        imgui.begin("relight")
        if state.message:
            imgui.push_text_wrap_pos(0.0)
            imgui.text_colored(ERROR_COLOUR, state.message)
            imgui.pop_text_wrap_pos()
            if imgui.small_button("dismiss"):
                state.message = None
        # a panel may replace viewer.state (reset, new environment): each gets the current one
        self._quick(viewer.state)
        for title, panel in (("Camera", self._camera), ("Light", self._light),
                             ("Material", self._material), ("Shading", self._shading),
                             ("Inspect", self._inspect), ("Output", self._output)):
            is_open = imgui.collapsing_header(title)
            self._track(title)
            if is_open:
                panel(viewer.state)
        imgui.end()

    def _quick(self, state) -> None:
        r = state.render
        model = self._combo("model", r.model, CHOICES["model"]())
        exposure = self._slider("exposure", r.display.exposure, *LIMITS["exposure"], "%.2f EV")
        tonemap = self._combo("tonemap", r.display.tonemap, CHOICES["tonemap"]())
        if (model, exposure, tonemap) != (r.model, r.display.exposure, r.display.tonemap):
            state.render = r.with_flat(model=model, exposure=exposure, tonemap=tonemap)

    def _camera(self, state) -> None:
        imgui = self.imgui
        cam = state.camera
        fov = self._slider("field of view", cam.fov_y, 5.0, 120.0, "%.1f deg")
        if fov != cam.fov_y:
            state.camera = replace(cam, fov_y=fov)
        _, self._size = imgui.input_int2("render size", self._size)
        self._track("render size")
        imgui.same_line()
        if imgui.button("apply"):
            w, h = (max(8, min(8192, int(v))) for v in self._size)
            state.camera = state.camera.with_size(w, h)
        if imgui.button("reset camera (R)"):
            self.viewer.state = reset_camera(state)
        self._track("reset camera (R)")
        imgui.text_disabled("drag: orbit, right/shift-drag: pan, wheel: zoom")

    def _light(self, state) -> None:
        imgui, viewer = self.imgui, self.viewer
        env = state.environment
        current = env.procedural if env.path is None else "file"
        choice = self._combo("environment", current, list(PROCEDURAL) + ["file"])
        if choice != current and choice != "file":
            viewer.state = state = with_procedural_environment(state, choice)
            env = state.environment
        if env.path is not None:
            imgui.text_wrapped(env.path)
        _, state.environment_path = imgui.input_text("env file", state.environment_path)
        self._track("env file")
        if imgui.button("load environment"):
            viewer.set_environment_file(state.environment_path)
            state = viewer.state
        imgui.same_line()
        if imgui.button("browse...") and self._dialog is None:
            self._open_dialog("environment", "HDR environment", ["HDR/EXR", "*.hdr *.exr"])
        intensity = self._slider("intensity", env.intensity, 0.0, 10.0)
        rotation = self._slider("rotation", env.rotation_deg, -180.0, 180.0, "%.1f deg")
        if (intensity, rotation) != (env.intensity, env.rotation_deg):
            state.environment = replace(env, intensity=intensity, rotation_deg=rotation)
        imgui.text_disabled("drop an .hdr/.exr on the window to use it")
        imgui.separator()
        self._directional_light(viewer.state)

    def _directional_light(self, state) -> None:
        """The scene's [light]: on/off, azimuth/elevation, colour, intensity. Values are written
        only when a widget reports an edit, so float32 widget rounding never moves the light."""
        imgui = self.imgui
        light = state.light
        toggled, enabled = imgui.checkbox("directional light", light is not None)
        self._track("directional light")
        if toggled:
            if not enabled:
                self._light_memory = light
            state.light = (self._light_memory or DEFAULT_LIGHT) if enabled else None
            light = state.light
        if light is None:
            return
        handling = MODELS[state.render.model].lights if state.render.model in MODELS \
            else "shaded"
        if handling != "shaded":
            imgui.text_disabled(f"{state.render.model} ignores the light"
                                + (" (trained under environment light only)"
                                   if handling == "ignored" else ""))
        az, el = light_angles(light.direction)
        changes = {}
        moved_az, az = imgui.slider_float("azimuth", float(az), -180.0, 180.0, "%.1f deg")
        self._track("azimuth")
        moved_el, el = imgui.slider_float("elevation", float(el), -90.0, 90.0, "%.1f deg")
        self._track("elevation")
        if moved_az or moved_el:
            changes["direction"] = light_direction(az, el)
        edited, color = imgui.color_edit3("light colour", list(light.color))
        self._track("light colour")
        if edited:
            changes["color"] = tuple(max(0.0, float(c)) for c in color)
        edited, intensity = imgui.slider_float("light intensity", float(light.intensity), 0.0,
                                               20.0, "%.3f")
        self._track("light intensity")
        if edited:
            changes["intensity"] = max(0.0, float(intensity))
        if changes:
            state.light = replace(light, **changes)
        imgui.text_disabled("irradiance at normal incidence; azimuth 0 = -Z, 90 = +X; no shadows")
        self._other_lights(state)

    def _other_lights(self, state) -> None:
        """The scene's other lights ([[lights]], glTF lights are the meshes' own): per light its
        type, colour, intensity and position (point, spot) or direction (directional, spot)."""
        imgui = self.imgui
        lights = list(state.lights)
        for i, light in enumerate(lights):
            imgui.text(f"light {i + 1}: {light.type}")
            changes = {}
            edited, color = imgui.color_edit3(f"colour##light{i}", list(light.color))
            if edited:
                changes["color"] = tuple(max(0.0, float(c)) for c in color)
            edited, value = imgui.slider_float(f"intensity##light{i}", float(light.intensity),
                                               0.0, 100.0, "%.3f")
            if edited:
                changes["intensity"] = max(0.0, float(value))
            if light.positional:
                edited, pos = imgui.slider_float3(f"position##light{i}", *light.position,
                                                  -10.0, 10.0, "%.2f")
                if edited:
                    changes["position"] = tuple(float(x) for x in pos)
            if light.type != "point":
                edited, d = imgui.slider_float3(f"direction##light{i}", *light.direction,
                                                -1.0, 1.0, "%.2f")
                unit = unit_direction(tuple(float(x) for x in d)) if edited else None
                if unit is not None:
                    changes["direction"] = unit
            if changes:
                lights[i] = replace(light, **changes)
        if lights:
            state.lights = tuple(lights)
            imgui.text_disabled("point, spot: W/sr; directional: W/m^2; direction towards the light")

    def _material_widgets(self, label: str, m: Material) -> Material:
        imgui = self.imgui
        changed, albedo = imgui.color_edit3(f"albedo##{label}", list(m.albedo))
        self._track(f"albedo##{label}")
        new = {"albedo": tuple(float(c) for c in albedo)} if changed else {}
        for f in ("roughness", "metallic", "specular"):
            v = self._slider(f"{f}##{label}", getattr(m, f), 0.0, 1.0)
            if v != getattr(m, f):
                new[f] = v
        return replace(m, **new) if new else m

    def _material(self, state) -> None:
        imgui = self.imgui
        imgui.text("override for every object")
        ov = state.material_override
        changes = {}
        for f in MATERIAL_FIELDS:
            on = getattr(ov, f) is not None
            toggled, on_new = imgui.checkbox(f"##override {f}", on)
            self._track(f"override {f}")
            imgui.same_line()
            default = getattr(Material(), f)
            value = getattr(ov, f) if on else default
            if f == "albedo":
                edited, v = imgui.color_edit3(f"{f}##override", list(value))
                v = tuple(float(c) for c in v)
            else:
                edited, v = imgui.slider_float(f"{f}##override", float(value), 0.0, 1.0)
            self._track(f"{f}##override")
            if toggled or (on and edited):
                changes[f] = v if on_new else None
        if changes:
            state.material_override = replace(ov, **changes)
        if state.material_override != MaterialOverride() and imgui.button("clear override"):
            state.material_override = MaterialOverride()
        imgui.separator()
        materials = list(state.object_materials)
        for i, obj in enumerate(state.scene.objects):
            label = f"{i}: {obj.type}" + (f" ({obj.path.rsplit('/', 1)[-1]})" if obj.path else "")
            if not imgui.tree_node(f"{label}##obj{i}"):
                continue
            m = materials[i]
            if m is None:
                on, _ = imgui.checkbox(f"override file materials##obj{i}", False)
                if on:
                    materials[i] = Material()
            else:
                if obj.type == "material_grid":
                    imgui.text_disabled("a grid sweeps roughness and metallic itself")
                materials[i] = self._material_widgets(f"obj{i}", m)
            imgui.tree_pop()
        if tuple(materials) != state.object_materials:
            state.object_materials = tuple(materials)

    def _shading(self, state) -> None:
        imgui = self.imgui
        r = state.render
        changes = {}
        for key, value in r.flat().items():  # one widget per [render] key
            if key in QUICK_FIELDS:
                continue
            if isinstance(value, bool):
                _, new = imgui.checkbox(key, value)
            elif isinstance(value, int):
                lo, hi = LIMITS.get(key, (0, 1 << 30))
                _, new = imgui.input_int(key, value)
                new = max(lo, min(hi, new))
            elif isinstance(value, float):
                _, new = imgui.drag_float(key, value, 0.01)
            elif isinstance(value, str) and (CHOICES.get(key) or (lambda: None))():
                new = self._combo(key, value, CHOICES[key]())
            elif isinstance(value, str):
                _, new = imgui.input_text(key, value)
            else:
                imgui.text_disabled(f"{key}: {value!r}")
                continue
            self._track(key)
            if new != value:
                changes[key] = new
        if changes:
            state.render = r.with_flat(**changes)

    def _inspect(self, state) -> None:
        imgui, viewer = self.imgui, self.viewer
        state.view = self._combo("view", state.view, VIEWS)
        if state.view == "error":
            state.error_scale = self._slider("error scale", state.error_scale, 0.001, 2.0)
        ref = state.reference_path or ""
        changed, ref = imgui.input_text("reference", ref)
        self._track("reference")
        if changed:
            state.reference_path = ref
        if imgui.button("load reference") and ref:
            viewer.load_reference(ref)
        imgui.same_line()
        if imgui.button("browse reference...") and self._dialog is None:
            self._open_dialog("reference", "reference render", ["EXR/HDR", "*.exr *.hdr"])

    def _output(self, state) -> None:
        imgui, viewer = self.imgui, self.viewer
        _, state.screenshot_path = imgui.input_text("screenshot", state.screenshot_path)
        if imgui.button("save screenshot (.png view / .exr linear)"):
            try:
                viewer.screenshot(state.screenshot_path)
                state.message = f"saved {state.screenshot_path}"
            except Exception as exc:  # a RelightError, or the image writer's OSError
                state.message = str(exc)
        _, state.scene_path = imgui.input_text("scene file", state.scene_path)
        if imgui.button("save scene"):
            viewer.save_scene(state.scene_path)
        imgui.same_line()
        if imgui.button("open scene"):
            viewer.open_scene(state.scene_path)

    def overlay(self) -> None:
        """Frame time, per-pass GPU time (timer queries) and what is shown, top right."""
        imgui, viewer = self.imgui, self.viewer
        io = imgui.get_io()
        imgui.set_next_window_pos((io.display_size.x - 8, 8), imgui.Cond_.always, (1.0, 0.0))
        imgui.set_next_window_bg_alpha(0.55)
        flags = (imgui.WindowFlags_.no_decoration | imgui.WindowFlags_.always_auto_resize
                 | imgui.WindowFlags_.no_inputs | imgui.WindowFlags_.no_focus_on_appearing
                 | imgui.WindowFlags_.no_nav)
        imgui.begin("##overlay", None, flags)
        scene = viewer.current_scene()
        w, h = scene.camera.size
        imgui.text(f"{viewer.frame_ms:6.2f} ms frame  {scene.render.model}  {w}x{h}")
        targets = viewer.targets
        if targets is not None and scene.render.model in SAMPLING_MODELS:
            imgui.text(f"samples {targets.samples}/{scene.render.mc.samples}")
        for name, ms in viewer.timers.ms.items():
            imgui.text(f"{name:>8}: {ms:7.3f} ms GPU")
        for line in frame_lines(viewer.renderer):
            imgui.text(line)
        imgui.end()

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


def frame_lines(renderer) -> list[str]:
    """The overlay's lines on the last frame's graph (the passes it reused) and the renderer's
    memory: bytes and entries per cache, against each budget (:meth:`Renderer.memory`)."""
    from viewer.cache import mib

    lines = []
    graph = renderer.last_graph
    if graph is not None:
        reused = [p.name for p in graph.passes if p.reused and not p.culled]
        lines.append("reused: " + (", ".join(reused) if reused else "nothing"))
    for name, s in renderer.memory().items():
        budget = (f" / {mib(s.max_bytes)}" if s.max_bytes is not None
                  else f" / {s.max_items}" if s.max_items is not None else "")
        lines.append(f"{name:>12}: {mib(s.bytes):>10}{budget}  ({s.items})")
    return lines

