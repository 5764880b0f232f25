"""Scene descriptions: TOML files <-> frozen dataclasses.

A scene is a camera, an environment, objects and render settings. Everything is immutable; change
a parameter with :func:`dataclasses.replace` (``scene.with_render(exposure=1.0)``), so a render
cache can key on values. Unknown keys, wrong types and out-of-range values are
:class:`~viewer.errors.SceneError` naming the file and the key.

Example::

    [camera]
    position = [0, 0.3, 3.2]
    target = [0, 0, 0]
    fov_y = 35                       # degrees, vertical
    size = [512, 512]                # [W, H]

    [environment]
    procedural = "sky"               # "sky" | "studio" | "white", or path = "studio.exr"
    intensity = 1.0
    rotation_deg = 0                 # about +Y, counter-clockwise seen from above
    # sun_strength = 1.0             # the compact sun's light times this (0: the sky without it)

    [[objects]]
    type = "sphere"                  # sphere | plane | material_grid | mesh | gbuffer | splats
    center = [0, 0, 0]
    radius = 1.0
    # shadow_only = true             # casts shadows (maps, rays) but the camera does not see it
    [objects.material]
    albedo = [0.8, 0.2, 0.2]
    roughness = 0.3
    metallic = 0.0
    specular = 0.5

    [[lights]]                       # optional, up to 8 (viewer.lighting.lights); absent: none
    type = "directional"             # directional | point | spot
    direction = [0.3, 1.0, 0.5]      # towards the light, world space; normalised on load
    color = [1.0, 0.95, 0.9]         # linear RGB
    intensity = 3.0                  # W/m^2 facing it (point, spot: W/sr)
    # point, spot: position = [x, y, z], range = 10 (optional, glTF's window)
    # spot: direction = its axis reversed (towards the light), inner_cone_deg, outer_cone_deg

    # the old [light] table (direction, color, intensity) still reads as one directional light

    [render]
    model = "ggx_split_sum"          # see viewer.models.MODELS
    multiscatter = true
    tonemap = "pbr_neutral"          # pbr_neutral | aces | agx | reinhard | none
    exposure = 0.0                   # EV stops, applied before tone mapping
    aa = "fxaa"                      # fxaa (FXAA 3.11 on the display image) | none
    ssaa = 1                         # supersampling: render at N x the size, box-average radiance
    splat_depth = "expected"         # splat depth: expected (eq. 6.10) | median (robust to floaters)

The typed readers of one value and the ``[render]`` table's validation (:func:`validate_render`)
are in :mod:`viewer.scene.checks`; writing scenes back to TOML is :mod:`viewer.scene.files`.
"""
from __future__ import annotations

import math
import os
from dataclasses import dataclass, fields, replace
from pathlib import Path
from typing import Any

from ..environment.maps import EnvironmentSpec
from ..errors import SceneError
from ..lighting.lights import DirectionalLight, Light, check_count, unit_direction
from ..lighting.tables import parse_light, parse_lights
from .camera import Camera
from .checks import (
    BACKGROUNDS,
    MIS_HEURISTICS,
    PRECISIONS,
    TONEMAPS,
    _check_keys,
    _int,
    _num,
    _path,
    _str,
    _vec,
    validate_render,
)
from .material import Material
from .settings import RenderSettings

try:
    import tomllib
except ImportError:  # pragma: no cover - Python < 3.11
    import tomli as tomllib  # type: ignore[no-redef]

# BACKGROUNDS, MIS_HEURISTICS, PRECISIONS, TONEMAPS and validate_render live in viewer.scene.checks
__all__ = ["BACKGROUNDS", "MIS_HEURISTICS", "OBJECT_TYPES", "PRECISIONS", "TONEMAPS",
           "DirectionalLight", "Light", "ObjectSpec", "Scene", "load_scene", "parse_camera",
           "parse_environment", "parse_light", "parse_lights", "parse_material", "parse_object", "parse_render",
           "scene_from_dict", "unit_direction", "validate_render"]


OBJECT_TYPES = ("sphere", "plane", "material_grid", "mesh", "gbuffer", "splats")
# the types that can be shadow casters only (``shadow_only``): what the maps and rays draw
SHADOW_ONLY_TYPES = ("sphere", "plane", "material_grid", "mesh", "splats")


@dataclass(frozen=True)
class ObjectSpec:
    """One ``[[objects]]`` entry. Paths are absolute (resolved against the scene file)."""

    type: str
    center: tuple[float, float, float] = (0.0, 0.0, 0.0)
    radius: float = 1.0
    size: tuple[float, float] = (4.0, 4.0)  # plane extent (x, z)
    normal: tuple[float, float, float] = (0.0, 1.0, 0.0)  # plane normal
    catcher: bool = False  # plane: a shadow catcher, what --floor makes (viewer.passes.ground)
    transform: tuple[tuple[float, ...], ...] | None = None  # 4x4 row-major, for meshes
    path: str | None = None
    material: Material | None = None  # None: the file's own materials (meshes)
    rows: int = 3  # material_grid: metallic 0..1 down the rows
    cols: int = 5  # material_grid: roughness 0..1 across the columns
    spacing: float = 2.2
    fov_y: float | None = None  # gbuffer stacks without their own field of view
    near: float = 1.0  # gbuffer depth normalisation (thesis appendix B.2)
    far: float = 800.0
    variant: str | None = None  # mesh: a glTF KHR_materials_variants name (None: the defaults)
    # a shadow caster only: drawn into the shadow maps and traced by the rays, not drawn into the
    # G-buffer, so the camera does not see it (a proxy of the geometry an image stack shows)
    shadow_only: bool = False


@dataclass(frozen=True)
class Scene:
    camera: Camera = Camera()
    environment: EnvironmentSpec = EnvironmentSpec(procedural="studio")
    objects: tuple[ObjectSpec, ...] = ()
    render: RenderSettings = RenderSettings()
    source: str | None = None  # the TOML file it came from
    lights: tuple[Light, ...] = ()  # ``[light]`` then ``[[lights]]`` (viewer.lighting.lights), world space
    # the mesh objects' own lights (glTF KHR_lights_punctual, world space): None until the
    # renderer gathers them (viewer.lighting.lights.gather_lights), never written to a scene file
    object_lights: tuple[Light, ...] | None = None

    @property
    def light(self) -> tuple[Light, ...] | None:
        """Every light the lighting passes shade (the scene's, then the objects' own once
        gathered), as one hashable value; ``None`` when there is none. The passes' ``light``
        argument and the frame graph's input (its name from when a scene had one light)."""
        lights = self.lights + (self.object_lights or ())
        return lights or None

    def with_render(self, **changes) -> "Scene":
        """A copy with ``[render]`` settings changed by their TOML keys (``samples=64``), checked
        as a scene file's are: a bad value is a one-line :class:`SceneError`."""
        return replace(self, render=self.render.with_flat(
            **validate_render(changes, self.source or "<render settings>")))

    def with_camera(self, **changes) -> "Scene":
        return replace(self, camera=replace(self.camera, **changes))

    def with_environment(self, **changes) -> "Scene":
        return replace(self, environment=replace(self.environment, **changes))


# ---- parsing ----------------------------------------------------------------------------------

def parse_material(t: dict, where: str, file: str) -> Material:
    _check_keys(t, {f.name for f in fields(Material)}, where, file)
    kw: dict[str, Any] = {}
    if "albedo" in t:
        kw["albedo"] = _vec(t["albedo"], 3, f"{where}.albedo", file)
    for k in ("roughness", "metallic", "specular", "ao", "specular_factor", "clearcoat",
              "clearcoat_roughness", "transmission", "sheen_roughness", "anisotropy_strength",
              "iridescence"):
        if k in t:
            kw[k] = _num(t[k], f"{where}.{k}", file, 0.0, 1.0)
    if "ior" in t:  # KHR_materials_ior's lobe (Material.ior)
        kw["ior"] = _num(t["ior"], f"{where}.ior", file, 0.0, 1e30)
    if "specular_color" in t:
        kw["specular_color"] = _vec(t["specular_color"], 3, f"{where}.specular_color", file)
    if "thickness" in t:  # KHR_materials_volume (Material.thickness: 0 = thin-walled)
        kw["thickness"] = _num(t["thickness"], f"{where}.thickness", file, 0.0, 1e30)
    if "attenuation_color" in t:
        kw["attenuation_color"] = _vec(t["attenuation_color"], 3, f"{where}.attenuation_color",
                                       file)
    if "dispersion" in t:  # KHR_materials_dispersion (20 / V_d; a volume's only)
        kw["dispersion"] = _num(t["dispersion"], f"{where}.dispersion", file, 0.0, 1e30)
    if "attenuation_distance" in t:
        kw["attenuation_distance"] = _num(t["attenuation_distance"],
                                          f"{where}.attenuation_distance", file, 1e-30, math.inf)
    for k in ("iridescence_ior", "iridescence_thickness_min", "iridescence_thickness_max"):
        if k in t:  # KHR_materials_iridescence's film (IOR >= 1, thicknesses in nm)
            kw[k] = _num(t[k], f"{where}.{k}", file, 1.0 if k == "iridescence_ior" else 0.0,
                         1e30)
    if "sheen_color" in t:  # KHR_materials_sheen (Material.sheen_color)
        kw["sheen_color"] = _vec(t["sheen_color"], 3, f"{where}.sheen_color", file)
    if "anisotropy_rotation" in t:  # KHR_materials_anisotropy (radians)
        kw["anisotropy_rotation"] = _num(t["anisotropy_rotation"], f"{where}.anisotropy_rotation",
                                         file, -1e30, 1e30)
    m = Material(**kw)
    try:
        m.validated(where)
    except SceneError as exc:
        raise SceneError(f"{where}: {exc.problem}", where=file) from None
    if not all(0.0 <= c <= 1.0 for c in m.albedo):
        raise SceneError(f"{where}.albedo = {list(m.albedo)} must be in [0, 1]", where=file)
    return m


def parse_camera(t: dict, file: str) -> Camera:
    _check_keys(t, {f.name for f in fields(Camera)}, "[camera]", file)
    kw: dict[str, Any] = {}
    for k in ("position", "target", "up"):
        if k in t:
            kw[k] = _vec(t[k], 3, f"camera.{k}", file)
    if "fov_y" in t:
        kw["fov_y"] = _num(t["fov_y"], "camera.fov_y", file, 0.01, 179.0)
    if "size" in t:
        s = t["size"]
        if not isinstance(s, (list, tuple)) or len(s) != 2:
            raise SceneError(f"camera.size must be [W, H], got {s!r}", where=file)
        kw["size"] = (_int(s[0], "camera.size[0]", file, 1, 16384),
                      _int(s[1], "camera.size[1]", file, 1, 16384))
    for k in ("near", "far"):
        if k in t:
            kw[k] = _num(t[k], f"camera.{k}", file, 1e-6, 1e9)
    cam = Camera(**kw)
    if cam.near >= cam.far:
        raise SceneError(f"camera.near ({cam.near}) must be less than camera.far ({cam.far})",
                         where=file)
    try:
        cam.basis()
    except ValueError as exc:
        raise SceneError(f"camera: {exc}", where=file) from None
    return cam


def parse_environment(t: dict, file: str, base: Path) -> EnvironmentSpec:
    allowed = {f.name for f in fields(EnvironmentSpec)}
    _check_keys(t, allowed, "[environment]", file)
    kw: dict[str, Any] = {}
    for k, v in t.items():
        if k == "path":
            kw[k] = _path(v, "environment.path", file, base)
        elif k == "procedural":
            kw[k] = _str(v, "environment.procedural", file)
        elif k in ("intensity", "sun_strength"):
            kw[k] = _num(v, f"environment.{k}", file, 0.0)
        elif isinstance(v, int) and not isinstance(v, bool) and k in ("width",):
            kw[k] = _int(v, f"environment.{k}", file, 8, 8192)
        else:
            kw[k] = _num(v, f"environment.{k}", file) if not isinstance(v, str) else v
    if "path" in kw and "procedural" in kw:
        raise SceneError("environment has both path and procedural; choose one", where=file)
    if "path" not in kw and "procedural" not in kw:
        kw["procedural"] = "studio"
    try:
        return EnvironmentSpec(**kw)
    except (TypeError, ValueError) as exc:
        raise SceneError(f"environment: {exc}", where=file) from None


def parse_object(t: dict, index: int, file: str, base: Path) -> ObjectSpec:
    where = f"objects[{index}]"
    if "type" not in t:
        raise SceneError(f"{where} has no type (one of {', '.join(OBJECT_TYPES)})", where=file)
    typ = _str(t["type"], f"{where}.type", file, OBJECT_TYPES)
    common = {"type", "material"} | ({"shadow_only"} if typ in SHADOW_ONLY_TYPES else set())
    allowed = {
        "sphere": {"center", "radius"},
        "plane": {"center", "size", "normal", "catcher"},
        "material_grid": {"center", "rows", "cols", "spacing", "radius"},
        "mesh": {"path", "transform", "variant"},
        "gbuffer": {"path", "fov_y", "near", "far"},
        "splats": {"path", "transform"},
    }[typ] | common
    _check_keys(t, allowed, where, file)
    kw: dict[str, Any] = {"type": typ}
    if "center" in t:
        kw["center"] = _vec(t["center"], 3, f"{where}.center", file)
    if "radius" in t:
        kw["radius"] = _num(t["radius"], f"{where}.radius", file, 1e-6)
    if "size" in t:
        kw["size"] = _vec(t["size"], 2, f"{where}.size", file)
    if "normal" in t:
        kw["normal"] = _vec(t["normal"], 3, f"{where}.normal", file)
        if math.hypot(*kw["normal"]) < 1e-9:
            raise SceneError(f"{where}.normal must not be zero", where=file)
    if "catcher" in t:
        if not isinstance(t["catcher"], bool):
            raise SceneError(f"{where}.catcher must be true or false, got {t['catcher']!r}",
                             where=file)
        kw["catcher"] = t["catcher"]
    if "shadow_only" in t:
        if not isinstance(t["shadow_only"], bool):
            raise SceneError(f"{where}.shadow_only must be true or false, got "
                             f"{t['shadow_only']!r}", where=file)
        if t["shadow_only"] and kw.get("catcher"):
            raise SceneError(f"{where} cannot be both a shadow catcher and shadow_only (a "
                             "catcher is seen; shadow_only is not)", where=file)
        kw["shadow_only"] = t["shadow_only"]
    for k in ("rows", "cols"):
        if k in t:
            kw[k] = _int(t[k], f"{where}.{k}", file, 1, 64)
    if "spacing" in t:
        kw["spacing"] = _num(t["spacing"], f"{where}.spacing", file, 1e-6)
    if "fov_y" in t:
        kw["fov_y"] = _num(t["fov_y"], f"{where}.fov_y", file, 0.01, 179.0)
    for k in ("near", "far"):
        if k in t:
            kw[k] = _num(t[k], f"{where}.{k}", file, 1e-6)
    if "transform" in t:
        m = t["transform"]
        if (not isinstance(m, list) or len(m) != 4
                or not all(isinstance(r, list) and len(r) == 4 for r in m)):
            raise SceneError(f"{where}.transform must be a 4x4 list of rows", where=file)
        kw["transform"] = tuple(_vec(r, 4, f"{where}.transform", file) for r in m)
    if typ in ("mesh", "gbuffer", "splats"):
        if "path" not in t:
            raise SceneError(f"{where} ({typ}) needs a path", where=file)
        kw["path"] = _path(t["path"], f"{where}.path", file, base)
    if "variant" in t:
        if not isinstance(t["variant"], str) or not t["variant"]:
            raise SceneError(f"{where}.variant must be a variant's name, got {t['variant']!r}",
                             where=file)
        kw["variant"] = t["variant"]
    if "material" in t:
        if not isinstance(t["material"], dict):
            raise SceneError(f"{where}.material must be a table", where=file)
        kw["material"] = parse_material(t["material"], f"{where}.material", file)
    elif typ in ("sphere", "plane", "material_grid"):
        kw["material"] = Material()
    return ObjectSpec(**kw)


def parse_render(t: dict, file: str) -> RenderSettings:
    return RenderSettings().with_flat(**validate_render(t, file))


def scene_from_dict(data: dict, file: str = "<scene>", base: Path | None = None) -> Scene:
    """Build a :class:`Scene` from parsed TOML. ``base`` resolves relative paths."""
    base = base or Path.cwd()
    _check_keys(data, {"camera", "environment", "light", "lights", "objects", "render"},
                "the scene", file)
    for k in ("camera", "environment", "light", "render"):
        if k in data and not isinstance(data[k], dict):
            raise SceneError(f"[{k}] must be a table", where=file)
    objs = data.get("objects", [])
    if not isinstance(objs, list) or not all(isinstance(o, dict) for o in objs):
        raise SceneError("objects must be an array of tables ([[objects]])", where=file)
    lights = ((parse_light(data["light"], file),) if "light" in data else ()) + \
        parse_lights(data.get("lights", []), file)
    check_count(lights, file)
    return Scene(
        camera=parse_camera(data.get("camera", {}), file),
        environment=parse_environment(data.get("environment", {}), file, base),
        objects=tuple(parse_object(o, i, file, base) for i, o in enumerate(objs)),
        render=parse_render(data.get("render", {}), file),
        source=file,
        lights=lights,
    )


def load_scene(path: str | os.PathLike) -> Scene:
    """Read a scene TOML file. Errors are one-line :class:`SceneError` naming the file."""
    path = Path(path)
    if not path.is_file():
        raise SceneError("scene file not found", where=path)
    try:
        data = tomllib.loads(path.read_text(encoding="utf-8"))
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as exc:
        raise SceneError(f"not valid TOML ({exc})", where=path) from None
    return scene_from_dict(data, str(path), path.resolve().parent)
