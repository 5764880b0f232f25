"""glTF ``KHR_lights_punctual``: the lights a file's nodes place, as world-space
:class:`viewer.lighting.lights.Light` (the node's transform applied; the mesh object's transform is applied
after, by :func:`viewer.geometry.loaders.load_mesh`). Intensities are used as they are: candela as
W/sr and lux as W/m^2, the project's radiometric convention (docs/explanation/conventions.md)."""
from __future__ import annotations

import math

from ...lighting.lights import Light

EXTENSION = "KHR_lights_punctual"
_USED = {"type", "color", "intensity", "range", "spot", "name"}  # of a light
_USED_SPOT = {"innerConeAngle", "outerConeAngle"}


def _definitions(gltf) -> list:
    ext = gltf.extensions if isinstance(gltf.extensions, dict) else {}
    lights = (ext.get(EXTENSION) or {}).get("lights", [])
    return lights if isinstance(lights, list) else []


def gltf_lights(reader) -> tuple[tuple[Light, ...], list[str]]:
    """The lights the default scene's nodes place, and what of the extension was not used (one
    short phrase each: lights no node places, unknown types, keys this renderer does not read)."""
    defs = _definitions(reader.gltf)
    ignored: set[str] = set()
    placed: set[int] = set()
    out: list[Light] = []
    for index, world in reader.light_nodes():
        if not isinstance(index, int) or not 0 <= index < len(defs) \
                or not isinstance(defs[index], dict):
            ignored.add(f"{EXTENSION} light {index!r} (no such light)")
            continue
        placed.add(index)
        light = _light(defs[index], index, ignored)
        if light is not None:
            out.append(light.transformed(world))
    for index, d in enumerate(defs):
        if index not in placed:
            ignored.add(f"{EXTENSION} light {index} (no node of the scene places it)")
        if isinstance(d, dict):
            for key in sorted(set(d) - _USED):
                ignored.add(f"{EXTENSION} light key {key!r}")
            spot = d.get("spot")
            if isinstance(spot, dict):
                for key in sorted(set(spot) - _USED_SPOT):
                    ignored.add(f"{EXTENSION} spot key {key!r}")
    return tuple(out), sorted(ignored)


def _light(d: dict, index: int, ignored: set[str]) -> Light | None:
    """One light definition in its node's frame: at the origin, shining down -Z."""
    typ = d.get("type")
    if typ not in ("directional", "point", "spot"):
        ignored.add(f"{EXTENSION} light {index} of unknown type {typ!r}")
        return None
    color = tuple(float(c) for c in d.get("color", (1.0, 1.0, 1.0)))
    intensity = float(d.get("intensity", 1.0))
    if len(color) != 3 or min(color) < 0.0 or not intensity >= 0.0:
        ignored.add(f"{EXTENSION} light {index} (negative or malformed color or intensity)")
        return None
    kw = {"type": typ, "color": color, "intensity": intensity, "direction": (0.0, 0.0, 1.0)}
    rng = d.get("range")
    if rng is not None and typ != "directional":
        if float(rng) > 0.0:
            kw["range"] = float(rng)
        else:
            ignored.add(f"{EXTENSION} light {index} range {rng!r} (must be > 0)")
    if typ == "spot":
        spot = d.get("spot") if isinstance(d.get("spot"), dict) else {}
        kw["inner_cone_deg"] = math.degrees(float(spot.get("innerConeAngle", 0.0)))
        kw["outer_cone_deg"] = math.degrees(float(spot.get("outerConeAngle", math.pi / 4.0)))
    return Light(**kw)
