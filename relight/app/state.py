"""All viewer state in one dataclass, and the pure functions between it and a :class:`Scene`.

The window's UI reads and writes a :class:`ViewerState`; every frame the window renders
``scene_from_state(state)`` through the same :class:`~viewer.renderer.Renderer` graph that
``relight render`` uses, so what the window shows, what a test asserts and what "save scene" writes
are the same scene. Nothing here touches GL.

    state = state_from_scene(load_scene("demo.toml"))
    state.render = state.render.with_flat(exposure=1.0)     # what a slider does
    scene = scene_from_state(state)                         # what gets rendered and saved

Material edits: ``object_materials[i]`` is object ``i``'s material as edited (``None``: a mesh's own
materials). ``material_override`` overrides chosen fields for every object on top of that.
A ``material_grid`` sweeps roughness and metallic itself; only its albedo follows edits.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, fields, replace

from viewer.environment.maps import EnvironmentSpec
from viewer.passes.debug_view import VIEWS  # noqa: F401  (re-exported)
from viewer.scene.camera import Camera
from viewer.scene.description import DirectionalLight, Light, Scene
from viewer.scene.material import Material
from viewer.scene.settings import RenderSettings

# What the view shows (VIEWS): the tone-mapped image, one G-buffer channel, or the error against a
# reference render ("difference": |render - reference| exposed like the image; "error": relative
# error in false colour).
MATERIAL_FIELDS = ("albedo", "roughness", "metallic", "specular")  # what the UI edits


def light_direction(azimuth_deg: float, elevation_deg: float) -> tuple[float, float, float]:
    """The unit direction towards a light at ``azimuth_deg`` about +Y and ``elevation_deg`` above
    the horizon (the XZ plane), world space. Azimuth follows the environment's longitude (README,
    Conventions): 0 is -Z, +90 is +X, so a light can sit on a sun of an unrotated environment."""
    az, el = math.radians(azimuth_deg), math.radians(elevation_deg)
    return (math.cos(el) * math.sin(az), math.sin(el), -math.cos(el) * math.cos(az))


def light_angles(direction) -> tuple[float, float]:
    """(azimuth, elevation) in degrees of a unit ``direction``: the inverse of
    :func:`light_direction` (azimuth 0 straight up or down)."""
    x, y, z = direction
    el = math.degrees(math.asin(max(-1.0, min(1.0, y))))
    az = math.degrees(math.atan2(x, -z)) if x * x + z * z > 1e-24 else 0.0
    return az, el


# what enabling the light in the viewer starts from: white, from the upper right front, E = pi
# (a white Lambertian surface facing it has radiance 1)
DEFAULT_LIGHT = DirectionalLight(direction=light_direction(150.0, 45.0), intensity=math.pi)


@dataclass(frozen=True)
class MaterialOverride:
    """Fields that override every object's material (``None``: not overridden)."""

    albedo: tuple[float, float, float] | None = None
    roughness: float | None = None
    metallic: float | None = None
    specular: float | None = None

    def changes(self) -> dict:
        return {f.name: getattr(self, f.name) for f in fields(self)
                if getattr(self, f.name) is not None}


@dataclass
class ViewerState:
    """Everything the viewer shows and edits. The UI writes these fields; nothing else does."""

    scene: Scene  # the scene as loaded (objects, source); the edits below apply on top
    camera: Camera
    environment: EnvironmentSpec
    render: RenderSettings
    object_materials: tuple[Material | None, ...]
    material_override: MaterialOverride = MaterialOverride()
    light: DirectionalLight | None = None  # the key directional light (None: off)
    lights: tuple[Light, ...] = ()  # the scene's other lights ([[lights]], in file order)
    view: str = "display"  # one of VIEWS
    error_scale: float = 0.25  # "error": relative error mapped to the top of the colour map
    reference_path: str | None = None  # a linear EXR/HDR render to compare against
    show_ui: bool = True
    fit_view: bool = False  # the render size follows the area beside the panel
    show_overlay: bool = True
    message: str | None = None  # the last problem (bad file, bad scene, missing weights)
    screenshot_path: str = "relight_view.png"
    scene_path: str = "relight_view.toml"
    environment_path: str = ""  # the text field of the environment file chooser

    def copy(self) -> "ViewerState":
        return replace(self)


def state_from_scene(scene: Scene) -> ViewerState:
    """A fresh state showing ``scene`` exactly (``scene_from_state`` gives ``scene`` back)."""
    key, rest = split_lights(scene.lights)
    return ViewerState(scene=scene, camera=scene.camera, environment=scene.environment,
                       render=scene.render, light=key, lights=rest,
                       object_materials=tuple(o.material for o in scene.objects))


def split_lights(lights) -> tuple[Light | None, tuple[Light, ...]]:
    """(the key light the azimuth/elevation widgets move, the others): the first light when it
    is directional, so joining them back keeps the scene's order."""
    if lights and lights[0].type == "directional":
        return lights[0], tuple(lights[1:])
    return None, tuple(lights)


def effective_material(state: ViewerState, index: int) -> Material | None:
    """Object ``index``'s material after its own edit and the global override."""
    material = state.object_materials[index]
    changes = state.material_override.changes()
    if not changes:
        return material
    return replace(material if material is not None else Material(), **changes)


def scene_from_state(state: ViewerState) -> Scene:
    """The scene the state describes: what the window renders, what "save scene" writes."""
    objects = tuple(replace(o, material=effective_material(state, i))
                    for i, o in enumerate(state.scene.objects))
    return replace(state.scene, camera=state.camera, environment=state.environment,
                   render=state.render, objects=objects,
                   lights=((state.light,) if state.light is not None else ()) + state.lights)


def load_into(state: ViewerState, scene: Scene) -> ViewerState:
    """A state for a newly loaded ``scene`` that keeps the viewer's own settings (view, paths,
    panels); camera, environment, render settings and materials come from the scene."""
    fresh = state_from_scene(scene)
    return replace(fresh, view=state.view, error_scale=state.error_scale,
                   reference_path=state.reference_path, show_ui=state.show_ui,
                   fit_view=state.fit_view,
                   show_overlay=state.show_overlay, screenshot_path=state.screenshot_path,
                   scene_path=state.scene_path)


def with_environment_file(state: ViewerState, path: str) -> ViewerState:
    """The state with ``path`` (an equirect HDR/EXR) as the environment; intensity and rotation
    are kept."""
    env = replace(state.environment, path=str(path), procedural=None)
    return replace(state, environment=env)


def with_procedural_environment(state: ViewerState, name: str) -> ViewerState:
    env = replace(state.environment, path=None, procedural=name)
    return replace(state, environment=env)


def with_light_angles(state: ViewerState, azimuth_deg: float, elevation_deg: float
                      ) -> ViewerState:
    """The state with its light (:data:`DEFAULT_LIGHT` when off) moved to the given angles;
    colour and intensity are kept."""
    light = state.light or DEFAULT_LIGHT
    return replace(state, light=replace(light, direction=light_direction(azimuth_deg,
                                                                         elevation_deg)))


def reset_camera(state: ViewerState) -> ViewerState:
    """Back to the loaded scene's camera (the render size stays what the user chose)."""
    cam = state.scene.camera.with_size(*state.camera.size)
    return replace(state, camera=cam)


def with_object(state: ViewerState, index: int, **changes) -> ViewerState:
    """The state with object ``index``'s fields ``changes`` set (the panel's per-object
    switches); a material the user set on that object in the panel stays on top of it."""
    objects = list(state.scene.objects)
    objects[index] = replace(objects[index], **changes)
    return replace(state, scene=replace(state.scene, objects=tuple(objects)))


def with_variant(state: ViewerState, index: int, variant: str | None) -> ViewerState:
    """The state with object ``index`` (a glTF mesh) showing its ``KHR_materials_variants``
    ``variant`` (None: the file's default materials)."""
    return with_object(state, index, variant=variant)
