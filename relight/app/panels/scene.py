"""The panel's top rows (model, exposure, tone mapper) and its Camera and Light sections."""
from __future__ import annotations

from dataclasses import replace

from viewer.environment.maps import PROCEDURAL
from viewer.lighting.lights import unit_direction
from viewer.models import MODELS

from ..state import (
    DEFAULT_LIGHT,
    light_angles,
    light_direction,
    reset_camera,
    with_procedural_environment,
)
from .choices import CHOICES, LIMITS


class ScenePanels:
    """Quick settings, Camera, Light; mixed into :class:`~.ViewerUI`."""

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
        _, state.fit_view = self._checkbox("size follows the window", state.fit_view)
        if not state.fit_view:
            _, self._size = imgui.input_int2(self.fit("render size"), self._size)
            self._track("render size")
            if self.button("apply size"):
                w, h = (max(8, min(8192, int(v))) for v in self._size)
                state.camera = state.camera.with_size(w, h)
        else:
            self._size = list(state.camera.size)
            imgui.text(f"render size {state.camera.size[0]} x {state.camera.size[1]}")
        if self.button("reset camera (R)"):
            self.viewer.state = reset_camera(state)
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
        _, state.environment_path = imgui.input_text(self.fit("env file"),
                                                     state.environment_path)
        self._track("env file")
        if self.button("load environment"):
            viewer.set_environment_file(state.environment_path)
            state = viewer.state
        if self.button("browse...", same_line=True) and self._dialog is None:
            self._open_dialog("environment", "HDR environment", ["HDR/EXR", "*.hdr *.exr"])
        intensity = self._slider("intensity", env.intensity, 0.0, 10.0)
        rotation = self._slider("rotation", env.rotation_deg, -180.0, 180.0, "%.1f deg")
        if (intensity, rotation) != (env.intensity, env.rotation_deg):
            state.environment = env = replace(env, intensity=intensity, rotation_deg=rotation)
        self._sun_strength(state, env)
        imgui.text_disabled("drop an .hdr/.exr on the window to use it")
        imgui.separator()
        self._directional_light(viewer.state)

    def _sun_strength(self, state, env) -> None:
        """The environment's compact sun, 0 (the sky without it) to 4 x: baked into the map, so
        the environment is rebuilt (its IBL, sun and shadow maps) when the slider is let go, not
        while it is dragged."""
        imgui = self.imgui
        pending = getattr(self, "_sun_pending", None)
        value = self._slider("sun strength", env.sun_strength if pending is None else pending,
                             0.0, 4.0, "%.2f x")
        if value != (env.sun_strength if pending is None else pending):
            self._sun_pending = pending = value
        if pending is not None and imgui.is_item_deactivated_after_edit():
            state.environment = replace(env, sun_strength=max(float(pending), 0.0))
            self._sun_pending = None

    def _directional_light(self, state) -> None:
        """The scene's [light]: on/off, azimuth/elevation, colour, intensity. Values are written
        only when a widget reports an edit, so float32 widget rounding never moves the light."""
        imgui = self.imgui
        light = state.light
        toggled, enabled = self._checkbox("directional light", light is not None)
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
        moved_az, az = imgui.slider_float(self.fit("azimuth"), float(az), -180.0, 180.0,
                                          "%.1f deg")
        self._track("azimuth")
        moved_el, el = imgui.slider_float(self.fit("elevation"), float(el), -90.0, 90.0,
                                          "%.1f deg")
        self._track("elevation")
        if moved_az or moved_el:
            changes["direction"] = light_direction(az, el)
        edited, color = imgui.color_edit3(self.fit("light colour"), list(light.color))
        self._track("light colour")
        if edited:
            changes["color"] = tuple(max(0.0, float(c)) for c in color)
        edited, intensity = imgui.slider_float(self.fit("light intensity"),
                                               float(light.intensity), 0.0, 20.0, "%.3f")
        self._track("light intensity")
        if edited:
            changes["intensity"] = max(0.0, float(intensity))
        if changes:
            state.light = replace(light, **changes)
        imgui.text_disabled("irradiance at normal incidence; azimuth 0 = -Z, 90 = +X; casts a "
                            "shadow map (shadows, shadow_* in Shading)")
        self._other_lights(state)

    def _other_lights(self, state) -> None:
        """The scene's other lights ([[lights]], glTF lights are the meshes' own): per light its
        type, colour, intensity and position (point, spot) or direction (directional, spot)."""
        imgui = self.imgui
        lights = list(state.lights)
        for i, light in enumerate(lights):
            imgui.text(f"light {i + 1}: {light.type}")
            changes = {}
            label = f"colour##light{i}"
            edited, color = imgui.color_edit3(self.fit(label), list(light.color))
            self._track(label)
            if edited:
                changes["color"] = tuple(max(0.0, float(c)) for c in color)
            label = f"intensity##light{i}"
            edited, value = imgui.slider_float(self.fit(label), float(light.intensity),
                                               0.0, 100.0, "%.3f")
            self._track(label)
            if edited:
                changes["intensity"] = max(0.0, float(value))
            if light.positional:
                label = f"position##light{i}"
                edited, pos = imgui.slider_float3(self.fit(label), list(light.position),
                                                  -10.0, 10.0, "%.2f")
                self._track(label)
                if edited:
                    changes["position"] = tuple(float(x) for x in pos)
            if light.type != "point":
                label = f"direction##light{i}"
                edited, d = imgui.slider_float3(self.fit(label), list(light.direction),
                                                -1.0, 1.0, "%.2f")
                self._track(label)
                unit = unit_direction(tuple(float(x) for x in d)) if edited else None
                if unit is not None:
                    changes["direction"] = unit
            if changes:
                lights[i] = replace(light, **changes)
        if lights:
            state.lights = tuple(lights)
            imgui.text_disabled("point, spot: W/sr; directional: W/m^2; "
                                "direction towards the light")
