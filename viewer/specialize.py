"""Model only what a scene requires.

:func:`analyse` reads what a scene actually contains (which object kinds, whether any surface has
a specular lobe or ambient occlusion, whether the environment is constant) from the loaded data —
material factors, texture maps, image-stack channels — not from guesses. :func:`specialise` turns
that, the shading model and the render settings into a :class:`Specialization`: the G-buffer
channels to allocate (the others are neither written nor read and keep their background value) and
the lighting pass's :class:`~viewer.models.ShadeVariant` (``SPECULAR_LOBE 0`` compiles the
environment's specular lookups out). Everything it removes contributes exactly zero on the general path, so the
output is unchanged (``relight bench`` measures both paths and records the difference).
"""
from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from .gbuffer import CHANNEL_NAMES, CHANNELS, GBufferLayout
from .lighting.lights import as_lights, shadowing
from .models import ShadeVariant, model_info, refracts_forward


@dataclass(frozen=True)
class SceneFeatures:
    splats: bool = False
    # meshes, or casters only (shadow_only, splat clouds too): something for the maps and rays
    meshes: bool = False
    stacks: bool = False
    specular: bool = True  # some surface has f0 > 0 (dielectric specular > 0, or metallic > 0)
    ao: bool = True  # some surface has ambient occlusion < 1
    constant_environment: bool = False  # every environment texel is the same colour
    single_object: bool = False  # the scene has exactly one object
    emission: bool = False  # some mesh emits light (glTF emissive): the emission channel
    # some mesh is transparent (glTF alphaMode BLEND): the forward pass depth-tests against the
    # G-buffer's depth channel; blended meshes count for nothing else (they are not in it)
    blend: bool = False
    # some opaque mesh has the glTF dielectric lobe (KHR_materials_ior / _specular): the
    # G-buffer's dielectric channel
    dielectric: bool = False
    clearcoat: bool = False  # some opaque mesh has a KHR_materials_clearcoat coat (factor > 0)
    # some mesh has KHR_materials_transmission (factor > 0): the transmission channel (the path
    # tracer's G-buffer reads it; the forward pass's programs set it), and, under a model that
    # refracts such meshes in the forward pass, the depth channel they depth-test against
    transmission: bool = False
    sheen: bool = False  # some mesh has a KHR_materials_sheen sheen (colour > 0)
    anisotropy: bool = False  # some mesh has KHR_materials_anisotropy (strength > 0)
    iridescence: bool = False  # some mesh has a KHR_materials_iridescence film (factor > 0)
    dispersion: bool = False  # some mesh has a dispersive volume (Material.has_dispersion)


@dataclass(frozen=True)
class Specialization:
    layout: GBufferLayout
    variant: ShadeVariant  # the lighting pass's program: model + prepended defines
    direct_stack: bool = False  # a lone image-space stack is shaded from its own textures

    @property
    def defines(self) -> dict[str, int]:
        return self.variant.defines

    @property
    def key(self) -> tuple:
        return (self.layout, self.variant)


GENERAL = SceneFeatures()  # what the all-features path assumes


def _mesh_features(mesh) -> tuple[bool, bool]:
    m = mesh.material
    tex = mesh.textures
    metal = m.metallic > 0.0
    if metal and "metallic_roughness" in tex:
        metal = float(np.max(tex["metallic_roughness"][..., 2])) > 0.0
    # the glTF lobe (Material.ior) has F90 = specular_factor: a lobe wherever that is > 0
    specular = (m.specular if m.ior is None else m.specular_factor) > 0.0 or metal \
        or m.clearcoat > 0.0 or m.has_sheen or m.has_iridescence  # so are a coat, a sheen, a film
    # (an anisotropic lobe is the specular lobe stretched: specular only where that is)
    ao = m.ao < 1.0 or ("occlusion" in tex and float(np.min(tex["occlusion"][..., 0])) < 1.0
                        and getattr(mesh, "occlusion_strength", 1.0) > 0.0)
    return specular, ao


def analyse(renderer, scene) -> SceneFeatures:
    """The features of ``scene`` as loaded by ``renderer`` (its geometry cache is reused)."""
    splats = meshes = stacks = False
    specular = ao = emission = blend = dielectric = clearcoat = transmission = sheen = False
    anisotropy = False
    iridescence = dispersion = False
    for obj in scene.objects:
        if obj.type == "splats" and obj.shadow_only:
            meshes = True  # drawn by the maps and rays alone, as a mesh is: no colour channel
            continue
        if obj.type == "splats":
            splats = True
            specular = True  # splats carry per-splat materials; never assume them away
            continue
        content = renderer.geometry(obj)
        if obj.type == "gbuffer":
            stacks = True
            ch = content.channels
            fg = ch["alpha"][..., 0] > 0
            if fg.any():
                f0 = np.maximum(ch.get("specular", np.full_like(ch["alpha"], 0.5))[..., 0][fg],
                                ch.get("metallic", np.zeros_like(ch["alpha"]))[..., 0][fg])
                specular = specular or bool(f0.max() > 0.0)
                if "ao" in ch:
                    ao = ao or bool(ch["ao"][..., 0][fg].min() < 1.0)
        else:
            meshes = True  # shadow casters only too: the maps and rays draw them
            if obj.shadow_only:  # not in the G-buffer: their materials are never shaded
                continue
            for mesh in content:
                # the forward pass's programs take the coat's define from the layout
                clearcoat = clearcoat or mesh.material.clearcoat > 0.0
                sheen = sheen or mesh.material.has_sheen
                # the forward pass's programs set the transmission fields too
                transmission = transmission or mesh.material.transmission > 0.0
                anisotropy = anisotropy or mesh.material.has_anisotropy
                iridescence = iridescence or mesh.material.has_iridescence
                dispersion = dispersion or mesh.material.has_dispersion
                if mesh.alpha_mode == "BLEND":  # forward pass: not in the G-buffer
                    blend = True
                    continue
                s, a = _mesh_features(mesh)
                specular, ao = specular or s, ao or a
                emission = emission or mesh.has_emission
                dielectric = dielectric or mesh.material.ior is not None
    constant = False
    spec = scene.environment
    if spec.path is None and spec.procedural == "white":
        constant = True
    return SceneFeatures(splats=splats, meshes=meshes, stacks=stacks, specular=specular, ao=ao,
                         constant_environment=constant, single_object=len(scene.objects) == 1,
                         emission=emission, blend=blend, dielectric=dielectric,
                         clearcoat=clearcoat, transmission=transmission, sheen=sheen,
                         anisotropy=anisotropy, iridescence=iridescence,
                         dispersion=dispersion)


def _all_features_layout(features: SceneFeatures | None, dtype: str) -> GBufferLayout:
    """Every channel, every lobe: GL's guaranteed 8 draw buffers hold all but the anisotropy,
    iridescence and dispersion channels, which a scene with such a material gets in place of the
    optional channels it does not use (a scene using every one of them would need a ninth
    attachment)."""
    if features is None or not (features.anisotropy or features.iridescence
                                or features.dispersion):
        return GBufferLayout(with_color=True, dtype=dtype, with_emission=True,
                             with_dielectric=True, with_clearcoat=True, with_transmission=True,
                             with_sheen=True)
    layout = GBufferLayout(with_color=features.splats, dtype=dtype,
                           with_emission=features.emission, with_dielectric=features.dielectric,
                           with_clearcoat=features.clearcoat,
                           with_transmission=features.transmission, with_sheen=features.sheen,
                           with_anisotropy=features.anisotropy,
                           with_iridescence=features.iridescence,
                           with_dispersion=features.dispersion)
    layout.check_draw_buffers()
    return layout


_SPECULAR_CHANNELS = {"roughness", "metallic", "specular"}
_OPTIONAL = frozenset(c.name for c in CHANNELS if c.optional)  # color, emission, dielectric..


def specialise(features: SceneFeatures | None, settings, aovs=(), enabled: bool = True,
               light=None, sun: int = 0, contact: bool = False) -> Specialization:
    """Layout and lighting-pass variant for ``settings.model`` on a scene with ``features`` and
    ``light`` (``Scene.light``: the lights to shade, or None; LIGHT_COUNT 0 compiles the light
    loop out, LIGHT_POSITIONAL 0 the surface position); ``sun``: how many compact lights the
    environment has (:func:`viewer.environment.sun.extract_lights`, 0 for none) for a model that shades them
    analytically; ``contact``: the lights' screen-space contact shadows
    (:func:`viewer.models.contact_shadows`).

    ``aovs`` are channels the caller will read back (always allocated). ``enabled=False`` gives
    the all-features path (every channel, every lobe), the baseline ``relight bench`` compares to.
    """
    dtype = "f2" if settings.precision == "fp16" else "f4"
    model = model_info(settings.model)
    if enabled and features is not None and not (features.meshes or features.splats) and \
            settings.shadow.enabled:
        # nothing a shadow map could hold (image stacks alone): the lookups compile out (their
        # 1x1 maps of depth 1 would give exactly 1 on the general path)
        settings = replace(settings, shadow=replace(settings.shadow, enabled=False))
    if not enabled or features is None:
        return Specialization(_all_features_layout(features, dtype),
                              model.variant(settings, light, specular=True, sun=sun,
                                            contact=contact))
    # models that do not say what they read get every channel (sampling, neural, future ones)
    needed = set(CHANNEL_NAMES if model.reads is None else model.reads)
    if model.specular_lobe and not features.specular:
        needed -= _SPECULAR_CHANNELS
    if not features.ao or not settings.ao:
        needed.discard("ao")
    if settings.ssao.enabled or settings.ssao.indirect:
        needed |= {"depth", "normal"}
    traceable = features.meshes or features.splats  # splats: their proxies (raytrace)
    if model.ray_light and settings.raytrace.enabled and traceable:
        needed |= {"depth", "normal"}  # rays start at the surface, the filter stops at edges
    if features.stacks and (features.meshes or features.splats):
        needed.add("depth")  # meshes and splats depth-test against the stack's stored depth
    if features.blend:
        needed.add("depth")  # blended meshes depth-test against it (viewer/passes/forward.py)
    if features.transmission and refracts_forward(model.name):
        needed.add("depth")  # so do the transmissive ones it refracts
    if model.lights == "shaded" and (any(li.positional for li in as_lights(light))
                                     or shadowing(light, settings.shadow.enabled)) or \
            (sun and settings.sun and settings.shadow.enabled):
        needed.add("depth")  # point and spot lights, shadow maps: the position from its depth
    if model.env_shadows and settings.shadow.enabled and settings.shadow.environment > 0:
        needed.add("depth")  # the environment's shadows: the position from its depth
    if contact and model.lights == "shaded" and as_lights(light):
        needed |= {"depth", "alpha"}  # contact shadows march through the depth
    needed |= set(aovs) | {"albedo", "alpha"}
    needed -= _OPTIONAL  # allocated by the layout's flags, never omitted
    omit = frozenset(c for c in CHANNEL_NAMES if c not in needed and c not in _OPTIONAL)
    direct = features.stacks and not (features.meshes or features.splats) and \
        features.single_object and dtype == "f4"
    layout = GBufferLayout(with_color=features.splats, dtype=dtype, omit=omit,
                           with_emission=features.emission, with_dielectric=features.dielectric,
                           with_clearcoat=features.clearcoat,
                           with_transmission=features.transmission, with_sheen=features.sheen,
                           with_anisotropy=features.anisotropy,
                           with_iridescence=features.iridescence,
                           with_dispersion=features.dispersion)
    layout.check_draw_buffers()  # a scene using every extension at once: one clear line
    return Specialization(layout,
                          model.variant(settings, light, specular=features.specular,
                                        sun=sun, contact=contact, traceable=traceable),
                          direct_stack=direct)
