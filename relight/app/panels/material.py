"""The panel's Material section: an override for every object, and each object's material."""
from __future__ import annotations

from dataclasses import replace

from viewer.geometry.loaders import material_variants
from viewer.scene.description import SHADOW_ONLY_TYPES
from viewer.scene.material import Material

from ..state import MATERIAL_FIELDS, MaterialOverride, with_object, with_variant

AS_AUTHORED = "as authored"  # the variant picker's first choice: the file's default materials


class MaterialPanel:
    """Material; mixed into :class:`~.ViewerUI`."""

    def _material_widgets(self, label: str, m: Material) -> Material:
        imgui = self.imgui
        key = f"albedo##{label}"
        changed, albedo = imgui.color_edit3(self.fit(key), list(m.albedo))
        self._track(key)
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
            self._record(f"##override {f}", key=f"override {f}")
            imgui.same_line()
            default = getattr(Material(), f)
            value = getattr(ov, f) if on else default
            key = f"{f}##override"
            if f == "albedo":
                edited, v = imgui.color_edit3(self.fit(key), list(value))
                v = tuple(float(c) for c in v)
            else:
                edited, v = imgui.slider_float(self.fit(key), float(value), 0.0, 1.0)
            self._track(key)
            if toggled or (on and edited):
                changes[f] = v if on_new else None
        if changes:
            state.material_override = replace(ov, **changes)
        if state.material_override != MaterialOverride() and self.button("clear override"):
            state.material_override = MaterialOverride()
        imgui.separator()
        materials = list(state.object_materials)
        for i, obj in enumerate(state.scene.objects):
            if not self._tree_node(f"object {i}: {obj.type}", f"obj{i}"):
                continue
            if obj.path:
                imgui.text_disabled(obj.path)  # wrapped at the panel's edge
            if obj.type == "mesh" and obj.path:
                self._variant_picker(state, i, obj)
            if obj.type in SHADOW_ONLY_TYPES and not obj.catcher:  # casts, is not seen
                toggled, on = self._checkbox(f"shadow caster only##so{i}", obj.shadow_only)
                if toggled:
                    state.scene = with_object(state, i, shadow_only=on).scene
            m = materials[i]
            if m is None:
                on, _ = self._checkbox(f"override file materials##obj{i}", False)
                if on:
                    materials[i] = Material()
            else:
                if obj.type == "material_grid":
                    imgui.text_disabled("a grid sweeps roughness and metallic itself")
                materials[i] = self._material_widgets(f"obj{i}", m)
            imgui.tree_pop()
        if tuple(materials) != state.object_materials:
            state.object_materials = tuple(materials)

    def _variant_picker(self, state, i: int, obj) -> None:
        """One radio button per KHR_materials_variants name of the object's glTF file, and
        "as authored" (its default materials); none for a file without variants."""
        names = material_variants(obj.path)
        if not names:
            return
        imgui = self.imgui
        imgui.text("material variant")
        for name in (AS_AUTHORED,) + names:
            label = f"{name}##variant{i}"
            chosen = (obj.variant or AS_AUTHORED) == name
            if imgui.radio_button(label, chosen) and not chosen:
                state.scene = with_variant(state, i, None if name == AS_AUTHORED else name).scene
            self._record(label)
