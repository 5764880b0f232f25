"""The scene-file reference page (``reference/scene-file.md``), generated from the scene validator
itself (``viewer.scene_from_dict``): which keys each table accepts, their defaults and the values
it accepts, found by handing the validator probe values and reading its one-line errors; the
descriptions are the comments on the dataclass fields the tables load into. Used by
docs/_hooks/generate.py."""
from __future__ import annotations

import dataclasses
import importlib
import inspect
import io
import math
import re
import sys
import tokenize

from common import _code, _esc

# ---- the scene file -----------------------------------------------------------------------------

def field_comments(cls) -> dict[str, str]:
    """``{field: comment}`` from a dataclass's source: the comment on the field's line and the
    full-line comments right above it."""
    try:
        source = inspect.getsource(cls)
    except (OSError, TypeError):
        return {}
    names = {f.name for f in dataclasses.fields(cls)}
    comments: dict[str, str] = {}
    pending: list[str] = []
    for line in source.splitlines()[1:]:
        stripped = line.strip()
        if stripped.startswith("#"):
            pending.append(stripped.lstrip("#").strip())
            continue
        m = re.match(r"\s+(\w+)\s*:", line)
        if m and m.group(1) in names:
            trailing = ""
            try:
                for tok in tokenize.generate_tokens(io.StringIO(stripped).readline):
                    if tok.type == tokenize.COMMENT:
                        trailing = tok.string.lstrip("#").strip()
            except (tokenize.TokenError, IndentationError, SyntaxError):
                pass
            text = " ".join(pending + ([trailing] if trailing else []))
            if text:
                comments[m.group(1)] = text
        pending = []
    return comments


# What a field means, for fields whose dataclass line carries no comment (the code's comment wins
# when it has one). Keys: "<table>.<key>".
MEANINGS = {
    "camera.position": "eye position, world space",
    "camera.target": "the point looked at, world space",
    "camera.up": "up direction (need not be orthogonal to the view direction)",
    "camera.near": "near clip plane, world units along the view axis",
    "camera.far": "far clip plane",
    "objects.center": "centre, world space (a plane: its centre; a grid: its middle)",
    "objects.radius": "sphere radius (a material grid: each ball's)",
    "objects.path": "mesh: glTF 2.0 (.gltf/.glb) or OBJ; gbuffer: an FFHQ256-PBR folder or a "
                    "12-channel EXR stack; splats: a 3DGS-family PLY or an antimatter15 .splat "
                    "(see Formats)",
    "objects.spacing": "material grid: distance between ball centres",
    "objects.far": "gbuffer depth normalisation: the far plane",
    "material.metallic": "metalness: 0 dielectric, 1 metal (no diffuse lobe, f0 = albedo)",
    "material.ao": "ambient occlusion, applied to diffuse light",
    "render.model": "the shading model (see Shading models)",
}


class Probe:
    """Hands documents to the scene validator and reads its one-line errors."""

    def __init__(self):
        import viewer

        self.scene_from_dict = viewer.scene_from_dict
        self.error = viewer.RelightError

    def message(self, doc: dict) -> str | None:
        try:
            self.scene_from_dict(doc, file="probe.toml")
        except self.error as exc:
            return str(exc).split("probe.toml: ", 1)[-1]
        except Exception as exc:  # noqa: BLE001 - a value the validator does not guard
            return f"{type(exc).__name__}: {exc}"
        return None

    def known(self, doc: dict) -> list[str]:
        """The key list of an 'unknown key' error for ``doc``."""
        msg = self.message(doc) or ""
        m = re.search(r"\(known: ([^)]*)\)", msg)
        return [k.strip() for k in m.group(1).split(",")] if m else []

    def accepts(self, doc: dict) -> bool:
        msg = self.message(doc)
        return msg is None or "unknown key" not in msg

    def values(self, make, default) -> str:
        """What the validator accepts for one key, from its errors on probe values;
        ``make(value)`` builds the document."""
        msgs = [self.message(make(v)) for v in
                ("\u00bfnot-a-value?", 1e300, -1e300, 0.5, [0.0], True, 10**9, -(10**9),
                 [0, 0])]
        msgs = [m for m in msgs if m]
        if any(re.search(r"must be \[W, H\]", m) for m in msgs):
            for m in msgs:
                hit = re.search(r"must be an integer in \[([^,]+), ([^\]]+)\]", m)
                if hit:
                    return f"[W, H]: integers in [{hit.group(1)}, {hit.group(2)}]"
            return "[W, H]"
        for m in msgs:
            if "4x4 list of rows" in m:
                return "4 × 4 list of rows (row-major)"
        for m in msgs:
            hit = re.search(r"is not one of (.*)$", m)
            if hit:
                return "one of " + ", ".join(_code(c.strip()) for c in hit.group(1).split(","))
        for m in msgs:
            hit = re.search(r"must be an integer in \[([^,]+), ([^\]]+)\]", m)
            if hit:
                return f"integer in [{hit.group(1)}, {hit.group(2)}]"
        for m in msgs:
            if "must be true or false" in m:
                return "`true` or `false`"
        for m in msgs:
            hit = re.search(r"must be a list of (\d+) numbers", m)
            if hit:
                return f"list of {hit.group(1)} numbers"
        lo, hi = -math.inf, math.inf
        ranged = False
        for m in msgs:
            hit = re.search(r"is outside \[([^,]+), ([^\]]+)\]", m)
            if hit:
                lo, hi, ranged = float(hit.group(1)), float(hit.group(2)), True
        if ranged:
            return f"number in [{_num(lo)}, {_num(hi)}]"
        for m in msgs:
            if "must be a finite number" in m:
                return "number"
        for m in msgs:
            if "must be a string" in m:
                return "string"
        if isinstance(default, bool):
            return "`true` or `false`"
        return "any (checked where it is used)" if not msgs else _esc(msgs[0])


def _num(x: float) -> str:
    if math.isinf(x):
        return "∞" if x > 0 else "−∞"
    return f"{x:g}"


def _toml(value) -> str:
    if value is None:
        return ""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, (tuple, list)):
        return "[" + ", ".join(_toml(v) for v in value) + "]"
    if isinstance(value, str):
        return f'"{value}"'
    return repr(value)


def _plain(value):
    if isinstance(value, tuple):
        return [_plain(v) for v in value]
    return value


def _render_keys(settings_cls) -> dict:
    """The TOML key -> (group, field) table of ``[render]`` (``RENDER_KEYS``), wherever the
    settings module or the scene package keeps it; else each group's fields by name."""
    for name in (settings_cls.__module__, "viewer.scene.settings", "viewer.scene.description"):
        try:
            module = sys.modules.get(name) or importlib.import_module(name)
        except ImportError:
            continue
        mapping = getattr(module, "RENDER_KEYS", None)
        if mapping:
            return mapping
    found = {}
    for f in dataclasses.fields(settings_cls):
        if dataclasses.is_dataclass(f.default):  # a group: mc, ssao, neural, display
            for g in dataclasses.fields(f.default):
                found.setdefault(g.name, (f.name, g.name))
        else:
            found[f.name] = (None, f.name)
    return found


def scene_markdown() -> str:
    import viewer

    probe = Probe()
    out = ["# Scene files", "",
           "<!-- generated by docs/_hooks/generate.py from the scene validator "
           "(viewer.scene_from_dict) and the dataclasses it fills -->", "",
           "A scene is a TOML file: a camera, an environment, objects, optionally "
           "lights, and render settings. Every table and key below is optional "
           "unless it says otherwise; paths are relative to the scene file. Unknown keys, "
           "wrong types and out-of-range values are errors that name the file and the key. "
           "`relight render`, `relight view`, `relight reference` and the Python API "
           "(`viewer.load_scene`) read the same files; `viewer.scene.files.save_scene` writes "
           "them back.", ""]
    tables = probe.known({"\u00bfprobe": {}})
    out += ["Top-level tables: " + ", ".join(f"`[{t}]`" if t != "objects" else "`[[objects]]`"
                                            for t in tables) + ".", ""]
    base = viewer.Scene()

    def section(title: str, cls, instance, make, keys=None, intro="", where=""):
        comments = {**{k.split(".", 1)[1]: v for k, v in MEANINGS.items()
                       if k.startswith(where + ".")}, **field_comments(cls)}
        rows = []
        for f in dataclasses.fields(cls):
            if keys is not None and f.name not in keys:
                continue
            default = getattr(instance, f.name) if instance is not None else None
            if not probe.accepts(make(f.name, _plain(default) if default is not None else 1.0)):
                continue
            rows.append((f.name, _toml(_plain(default)),
                         probe.values(lambda v, k=f.name: make(k, v), default),
                         comments.get(f.name, "")))
        lines = [f"## {title}", ""] + ([intro, ""] if intro else [])
        lines += ["| key | default | accepts | meaning |", "|---|---|---|---|"]
        lines += [f"| `{k}` | {_code(d)} | {a} | {_esc(c)} |" for k, d, a, c in rows]
        return lines + [""]

    cam = base.camera
    out += section("[camera]", type(cam), cam, lambda k, v: {"camera": {k: v}}, where="camera",
                   intro="A pinhole camera. View space is right-handed, looking down −Z.")
    env = base.environment
    out += section("[environment]", type(env), type(env)(),
                   lambda k, v: {"environment": {k: v}}, where="environment",
                   intro="An equirectangular HDR/EXR file (`path`) or a procedural environment "
                         "(`procedural`); with neither, the procedural studio.")
    from viewer.lighting.lights import Light

    spot = {"type": "spot", "position": [0.0, 2.0, 0.0], "direction": [0.0, 1.0, 0.0]}
    out += section("[[lights]]", Light, Light(),
                   lambda k, v: {"lights": [{**spot, k: v}]}, where="lights",
                   intro="Optional, repeatable (at most 8): punctual lights in glTF's units and "
                         "falloff, used directly as radiometric values (a directional light's "
                         "`intensity` is the irradiance on a surface facing it, a point or spot "
                         "light's the radiant intensity; no 683 lm/W factor). `type` is "
                         "`directional` (keys `direction`), `point` (`position`, `range`) or "
                         "`spot` (`position`, `direction`, `inner_cone_deg`, `outer_cone_deg`, "
                         "`range`). `direction` points *towards* the light (for a spot: from what "
                         "it lights back to it) and is normalised on load; `range` is glTF's "
                         "window clamp(1 - (d/range)^4, 0, 1)^2 / d^2. glTF files bring their "
                         "`KHR_lights_punctual` lights with their node transforms. The older "
                         "single `[light]` table (`direction`, `color`, `intensity`) still reads "
                         "as one directional light.")

    # objects: which keys each type takes, from the validator
    types_msg = probe.message({"objects": [{"type": "\u00bfprobe"}]}) or ""
    hit = re.search(r"is not one of (.*)$", types_msg)
    types = [t.strip() for t in hit.group(1).split(",")] if hit else []
    sample = probe.scene_from_dict({"objects": [{"type": "sphere"}]}).objects[0]
    obj_cls = type(sample)
    defaults = obj_cls(type="sphere")
    comments = {**{k.split(".", 1)[1]: v for k, v in MEANINGS.items()
                   if k.startswith("objects.")}, **field_comments(obj_cls)}
    per_type: dict[str, list[str]] = {}
    for t in types:
        need_path = "needs a path" in (probe.message({"objects": [{"type": t}]}) or "")
        for f in dataclasses.fields(obj_cls):
            if f.name in ("type", "material"):
                continue
            value = _plain(getattr(defaults, f.name))
            if value is None:
                value = [[1.0, 0, 0, 0], [0, 1.0, 0, 0], [0, 0, 1.0, 0], [0, 0, 0, 1.0]] \
                    if f.name == "transform" else ("x" if f.name == "path" else 30.0)
            doc = {"type": t, f.name: value}
            if need_path and f.name != "path":
                doc["path"] = "x"
            if probe.accepts({"objects": [doc]}):
                per_type.setdefault(f.name, []).append(t)
    out += ["## [[objects]]", "",
            "An array of tables, one per object; `type` is required, one of "
            + ", ".join(_code(t) for t in types) + ". Each type takes the keys marked for it; "
            "`mesh`, `gbuffer` and `splats` need a `path`. Any object may carry an "
            "`[objects.material]` table (below): for meshes and splats it replaces every "
            "material of the file.", "",
            "| key | types | default | accepts | meaning |", "|---|---|---|---|---|"]
    for f in dataclasses.fields(obj_cls):
        if f.name not in per_type:
            continue
        t0 = per_type[f.name][0]

        def make(v, k=f.name, t=t0):
            doc = {"type": t, k: v}
            if k != "path" and t in ("mesh", "gbuffer", "splats"):
                doc["path"] = "x"
            return {"objects": [doc]}

        default = getattr(defaults, f.name)
        accepts = probe.values(make, default)
        if f.name == "path":
            accepts = "path (relative to the scene file)"
        out.append(f"| `{f.name}` | {', '.join(per_type[f.name])} | "
                   f"{_code(_toml(_plain(default)))} | {accepts} | "
                   f"{_esc(comments.get(f.name, ''))} |")
    out.append("")
    mat = sample.material
    out += section("[objects.material]", type(mat), type(mat)(),
                   lambda k, v: {"objects": [{"type": "sphere", "material": {k: v}}]},
                   where="material",
                   intro="Metallic-roughness parameters (Filament conventions); linear values.")

    # [render]: flat TOML keys mapped onto grouped dataclasses
    from viewer.scene.settings import TUNING_KEYS

    render = base.render
    flat = render.flat()
    mapping = _render_keys(type(render))
    out += ["## [render]", "",
            "How to shade and display. The keys are flat in the file; in Python they are grouped "
            "by the part of the renderer they steer (`scene.render.mc`, `.ssao`, `.neural`, "
            "`.display`; the column *Python*), and `scene.with_render(key=value)` takes the "
            "file's keys, checked as a file's are.", "",
            "A key that only tunes one part of the frame says so when the frame does not run "
            "that part: set away from its default, it has no effect and gives one warning "
            "(`viewer.scene.settings.dormant_settings`). The keys and what they tune:", "",
            *(f"- {', '.join(f'`{k}`' for k in keys)}: {what}" for keys, what, _ in TUNING_KEYS),
            "",
            "| key | Python | default | accepts | meaning |", "|---|---|---|---|---|"]
    for key, default in flat.items():
        group, field = mapping.get(key, (None, key))
        holder = type(render) if group is None else type(getattr(render, group))
        comment = field_comments(holder).get(field, "") or MEANINGS.get(f"render.{key}", "")
        path = f"render.{field}" if group is None else f"render.{group}.{field}"
        accepts = probe.values(lambda v, k=key: {"render": {k: v}}, default)
        if key in ("weights", "teacher_weights", "shadow_net"):
            accepts = "path (relative to the scene file)"
        out.append(f"| `{key}` | `{path}` | {_code(_toml(default))} | {accepts} | "
                   f"{_esc(comment)} |")
    out.append("")
    from assets import ASSET_ROOT

    demo = (ASSET_ROOT / "scenes" / "demo.toml").read_text()
    gallery = (ASSET_ROOT / "scenes" / "gallery.toml").read_text()
    out += ["## Examples", "", "The built-in demo (`assets/scenes/demo.toml`, what `relight render` "
            "draws without a scene):", "", "```toml", demo.rstrip(), "```", "",
            "A glTF asset on a floor under an HDRI (`assets/scenes/gallery.toml`, the gallery's "
            "scene):", "", "```toml", gallery.rstrip(), "```", ""]
    return "\n".join(out) + "\n"
