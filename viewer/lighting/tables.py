"""The scene file's light tables: ``[[lights]]`` entries and the older ``[light]`` parsed into
:class:`viewer.lighting.lights.Light` (one-line :class:`~viewer.errors.SceneError` s naming the key), and
written back (:func:`light_table`)."""
from __future__ import annotations

from typing import Any

from ..errors import SceneError
from ..scene.checks import _check_keys, _num, _str, _vec
from .lights import LIGHT_TYPES, Light, check_count, unit_direction

# keys each type takes in [[lights]] (besides type, color, intensity)
_KEYS = {"directional": {"direction", "angular_diameter_deg", "shadow"},
         "point": {"position", "range", "radius", "shadow"},
         "spot": {"position", "direction", "inner_cone_deg", "outer_cone_deg", "range", "radius",
                  "shadow"}}


def _direction(t: dict, where: str, file: str) -> tuple[float, float, float]:
    if "direction" not in t:
        raise SceneError(f"{where}.direction is required (a vector towards the light)", where=file)
    d = unit_direction(_vec(t["direction"], 3, f"{where}.direction", file))
    if d is None:
        raise SceneError(f"{where}.direction must not be zero, got {t['direction']!r}", where=file)
    return d


def _color_intensity(t: dict, where: str, file: str) -> dict[str, Any]:
    kw: dict[str, Any] = {}
    if "color" in t:
        kw["color"] = _vec(t["color"], 3, f"{where}.color", file)
        if min(kw["color"]) < 0.0:
            raise SceneError(f"{where}.color = {list(kw['color'])} must be >= 0", where=file)
    if "intensity" in t:
        kw["intensity"] = _num(t["intensity"], f"{where}.intensity", file, 0.0)
    return kw


def parse_light(t: dict, file: str) -> Light:
    """The old ``[light]`` table: one directional light (direction, color, intensity)."""
    _check_keys(t, {"direction", "color", "intensity"}, "[light]", file)
    return Light(direction=_direction(t, "light", file), **_color_intensity(t, "light", file))


def parse_lights_entry(t: Any, index: int, file: str) -> Light:
    """One ``[[lights]]`` entry; errors are one-line :class:`SceneError` naming the key."""
    where = f"lights[{index}]"
    if not isinstance(t, dict):
        raise SceneError(f"{where} must be a table", where=file)
    if "type" not in t:
        raise SceneError(f"{where} has no type (one of {', '.join(LIGHT_TYPES)})", where=file)
    typ = _str(t["type"], f"{where}.type", file, LIGHT_TYPES)
    _check_keys(t, {"type", "color", "intensity"} | _KEYS[typ], where, file)
    kw: dict[str, Any] = {"type": typ, **_color_intensity(t, where, file)}
    if "direction" in _KEYS[typ]:
        kw["direction"] = _direction(t, where, file)
    if "position" in _KEYS[typ]:
        if "position" not in t:
            raise SceneError(f"{where}.position is required for a {typ} light", where=file)
        kw["position"] = _vec(t["position"], 3, f"{where}.position", file)
    if "range" in t:
        kw["range"] = _num(t["range"], f"{where}.range", file, 0.0)
        if not kw["range"] > 0.0:
            raise SceneError(f"{where}.range must be > 0, got {t['range']!r}", where=file)
    for k in ("inner_cone_deg", "outer_cone_deg"):
        if k in t:
            kw[k] = _num(t[k], f"{where}.{k}", file, 0.0, 90.0)
    if "angular_diameter_deg" in t:
        kw["angular_diameter_deg"] = _num(t["angular_diameter_deg"],
                                          f"{where}.angular_diameter_deg", file, 0.0, 30.0)
    if "radius" in t:
        kw["radius"] = _num(t["radius"], f"{where}.radius", file, 0.0)
    if "shadow" in t:
        if not isinstance(t["shadow"], bool):
            raise SceneError(f"{where}.shadow must be true or false, got {t['shadow']!r}",
                             where=file)
        kw["shadow"] = t["shadow"]
    light = Light(**kw)
    if typ == "spot" and not light.inner_cone_deg < light.outer_cone_deg:
        raise SceneError(f"{where}.inner_cone_deg ({light.inner_cone_deg}) must be less than "
                         f"outer_cone_deg ({light.outer_cone_deg})", where=file)
    return light


def parse_lights(entries: Any, file: str) -> tuple[Light, ...]:
    """The ``[[lights]]`` array."""
    if not isinstance(entries, list):
        raise SceneError("lights must be an array of tables ([[lights]])", where=file)
    lights = tuple(parse_lights_entry(t, i, file) for i, t in enumerate(entries))
    check_count(lights, file)
    return lights


def light_table(light: Light) -> dict[str, Any]:
    """``light`` as a ``[[lights]]`` table (only its type's keys; range when it has one)."""
    out: dict[str, Any] = {"type": light.type, "color": list(light.color),
                           "intensity": light.intensity}
    for k in sorted(_KEYS[light.type]):
        v = getattr(light, k)
        if k in ("angular_diameter_deg", "shadow", "radius") and v == getattr(Light, k):
            continue  # the defaults: not written
        if v is not None:
            out[k] = list(v) if isinstance(v, tuple) else v
    return out
