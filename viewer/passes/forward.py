"""The forward pass: transparent surfaces (glTF ``alphaMode: BLEND``) over the shaded radiance,
and, under the rasterising models, transmissive ones (KHR_materials_transmission / _volume)
refracting a copy of it.

A deferred renderer's standard answer to transparency. The G-buffer holds one surface per pixel, so
blended meshes are left out of it (:meth:`viewer.renderer.Renderer.draw`) and drawn after the
lighting (and screen-space indirect) passes, straight into the radiance target:

- **Shading**: each blended mesh is drawn with the model's *own* lighting pass
  (``shaders/passes/shade_<model>.frag``, unchanged) as its fragment stage, compiled with
  ``passes/forward_surface.glsl`` in place of the generated ``gbuffer_load``: the surface comes
  from the mesh at this fragment (``passes/mesh_surface.glsl``, the code the G-buffer fill uses)
  instead of the G-buffer, so blended surfaces are shaded by the same code as opaque ones,
  including the punctual lights and emission. Models whose lighting pass is not one evaluation
  per fragment - the Monte-Carlo ones that accumulate samples over batches (``ggx_mc``,
  ``neural_teacher``) and the network ones (``neural``) - shade blended surfaces with
  :data:`FALLBACK_MODEL` (``ggx_split_sum``, the split-sum of the same GGX BRDF), with one
  warning per model; the fallback shades the scene's lights unless the model ignores them.
- **Blending**: a fragment writes premultiplied ``(c alpha, alpha)`` (the pass's
  ``write_radiance`` with ``BACKGROUND_ENVIRONMENT 0``) and the blend state (ONE,
  ONE_MINUS_SRC_ALPHA) puts it "over" what is there: ``dst = src + (1 - alpha) dst``, so the
  radiance's alpha becomes the coverage ``alpha + (1 - alpha) coverage``. alpha = glTF
  baseColorFactor.a x base colour texture alpha x COLOR_0 alpha, clamped to [0, 1]; emission is
  weighted by it like the reflected light (as the Khronos sample viewer does).
- **Order**: meshes (glTF primitives) back to front by the view depth of their bounding-box
  centres (:func:`forward_order`, a stable sort: equal depths keep file order). Not per
  triangle: meshes that intersect, or a mesh that overlaps itself on screen, blend in whatever
  order their triangles come - there is no order-independent transparency. A double-sided mesh
  is drawn twice, back faces first, so a closed convex one composites correctly.
- **Depth**: tested in the fragment shader against the opaque G-buffer's depth channel (meshes,
  image stacks and splats alike) and never written: blended surfaces never hide one another or
  anything drawn later, and SSAO, screen-space indirect light, the G-buffer AOVs and a
  Monte-Carlo model's samples see only the opaque surfaces. SSAO does not darken blended
  surfaces (``USE_SSAO 0``); their own ambient occlusion (``u_ao``, occlusion maps) does.
- **Transmission** (:func:`forward_meshes`): under a model that does not trace it
  (:func:`viewer.models.refracts_forward`), a mesh with a transmission factor > 0 is left out of
  the G-buffer and drawn here, sorted with the blended ones, reading ``transmission_frame``, the
  mip-mapped copy of the opaque frame the frame graph makes before this pass
  (``transmission_copy``): the lighting pass, compiled with ``FORWARD_TRANSMISSION``
  (``passes/forward_surface.glsl``), gives the base's share T the opaque frame refracted through
  the surface in place of its irradiance (the approximation three.js makes; the path tracer
  follows the BTDFs exactly). An OPAQUE or MASK transmissive surface covers its pixel (alpha 1);
  a BLEND one blends as well. What it refracts is the opaque frame only: other transmissive or
  blended surfaces behind it are not seen through it.
- **Shadows**: blended surfaces receive the shadows of the frame's maps (the same lookups as
  the lighting pass, bound by :class:`~viewer.passes.shadow_bindings.ShadowBindings`) and cast
  none (a glass pane does not darken the floor; ``viewer/passes/shadow.py``). Contact shadows
  are left out: they march through the opaque G-buffer's depth, which is behind a blended
  surface. The frame draws every map this pass reads, also one the lighting pass does not (the
  environment's sun under ``ggx_mc``, which samples the sun with the sky while the forward
  split-sum shades it analytically: ``also`` of :func:`viewer.graph.shadows.shadow_passes`);
  should one still be missing, that light is unshadowed on blended surfaces and the frame says
  so once (:func:`warn_unshadowed`).
"""
from __future__ import annotations

import dataclasses
import warnings

import numpy as np

from ..gbuffer import GBufferLayout
from ..geometry.mesh import Mesh
from ..lighting.lights import Light
from ..models import ShadeVariant, model_info, refracts_forward
from ..scene.camera import Camera
from ..scene.settings import RenderSettings
from . import bind_gbuffer, set_uniform
from .gbuffer import MeshUploads
from .shade import set_view_and_lighting
from .shadow_bindings import ShadowBindings

FALLBACK_MODEL = "ggx_split_sum"  # shades blended surfaces for models that cannot run forward


def forward_meshes(renderer, scene) -> list[Mesh]:
    """The meshes the forward pass draws, in file order: the transparent ones (glTF ``alphaMode:
    BLEND``) and, under a model that refracts them here (:func:`viewer.models.refracts_forward`),
    the transmissive ones (KHR_materials_transmission factor > 0); the G-buffer holds the rest.
    A shadow caster only (``shadow_only``) is drawn by neither."""
    through = refracts_forward(scene.render.model)
    return [m for obj in scene.objects
            if obj.type not in ("gbuffer", "splats") and not obj.shadow_only
            for m in renderer.geometry(obj)
            if m.alpha_mode == "BLEND" or (through and m.material.transmission > 0.0)]


def forward_model(model: str) -> str:
    """The model whose lighting pass shades blended surfaces when ``model`` renders the scene:
    itself when its pass is one evaluation per fragment (no accumulated samples, no network),
    else :data:`FALLBACK_MODEL`."""
    info = model_info(model)
    return model if not info.accumulates and info.network is None else FALLBACK_MODEL


def forward_variant(settings: RenderSettings, light: Light | tuple[Light, ...] | None,
                    sun: int = 0) -> ShadeVariant:
    """The lighting-pass variant that shades blended surfaces for ``settings.model``: the forward
    model's own variant (every lobe: blended surfaces are not specialised), without SSAO and
    without the background (the destination already holds it), without the real-time tier's
    rays (RT_LIGHT: they start from the G-buffer), and without the light when the
    scene's model ignores it; ``sun``: how many lights the IBL bound leaves out to shade
    (SUN_LIGHT, ENV_LIGHTS)."""
    info = model_info(settings.model)
    shaded = light if info.lights == "shaded" else None
    # shadow maps as the lighting pass reads them; no contact shadows (module doc)
    no_contact = dataclasses.replace(settings, shadow=dataclasses.replace(
        settings.shadow, contact="off"))
    # blended surfaces are not in the G-buffer the rays start from: no RT_LIGHT (their sun keeps
    # its shadow map)
    defines = model_info(forward_model(settings.model)).variant(no_contact, shaded, specular=True,
                                                                sun=sun, traceable=False).defines
    defines["BACKGROUND_ENVIRONMENT"] = 0
    if "USE_SSAO" in defines:
        defines["USE_SSAO"] = 0
    return ShadeVariant(forward_model(settings.model), tuple(sorted(defines.items())))


def forward_order(meshes: list[Mesh], camera: Camera) -> list[int]:
    """Indices of ``meshes`` back to front: by the view depth (-z_vs) of each bounding-box centre,
    farthest first; a stable sort, so equal depths keep their order."""
    view = camera.view_matrix()
    depths = []
    for mesh in meshes:
        lo, hi = mesh.bounds()
        centre = (lo + hi) * 0.5
        depths.append(-(view[2, :3] @ centre + view[2, 3]))
    return [int(i) for i in np.argsort(-np.asarray(depths, np.float64), kind="stable")]


class ForwardPass:
    """Draws blended meshes over the radiance target, depth-tested against one G-buffer layout."""

    def __init__(self, programs, layout: GBufferLayout):
        self.programs = programs
        self.ctx = programs.ctx
        self.layout = layout
        self.uploads = MeshUploads(self.ctx, self._program)
        self.shadow_maps = ShadowBindings(self.ctx)
        # the layout's loader renamed, then forward_surface.glsl's gbuffer_load in its place
        self._virtual = {"generated/gbuffer.glsl": layout.glsl(load_name="gbuffer_load_opaque")
                         + '#include "passes/forward_surface.glsl"\n'}

    def _program(self, mesh_defines: dict[str, int], variant: ShadeVariant):
        defines = {**variant.defines, **mesh_defines, "FORWARD": 1}
        return self.programs.graphics("passes/gbuffer_mesh.vert", model_info(variant.model).pass_file,
                                      defines=defines, virtual=self._virtual)

    def run(self, meshes: list[Mesh], gbuffer_textures: dict, out_fbo, camera: Camera, ibl,
            environment, settings: RenderSettings, light: Light | tuple[Light, ...] | None = None,
            shadows: dict | None = None, sun_shadow: tuple | None = None,
            variant: ShadeVariant | None = None, transmission_frame=None) -> None:
        """Blend ``meshes`` over ``out_fbo`` (the RGBA32F radiance target of the camera's size),
        sorted back to front, depth-tested against ``gbuffer_textures`` (this layout's
        attachments: the opaque G-buffer, which must hold the depth channel). ``shadows`` and
        ``sun_shadow``: the frame's maps (:meth:`viewer.passes.shade.ShadePass.run`'s);
        ``variant``: the program (default: :func:`forward_variant`); ``transmission_frame``: the
        mip-mapped copy of the opaque frame that transmissive meshes refract (needed when one
        is among ``meshes``)."""
        if not meshes:
            return
        if "depth" in self.layout.omit:
            raise ValueError("the forward pass depth-tests against the G-buffer's depth channel, "
                             "which this layout omits")
        if transmission_frame is None and any(m.material.transmission > 0.0 for m in meshes):
            raise ValueError("transmissive meshes in the forward pass refract a copy of the "
                             "opaque frame: transmission_frame is required")
        if any(m.alpha_mode == "BLEND" for m in meshes):
            _warn_fallback(settings.model)
        if variant is None:
            variant = forward_variant(settings, light, sun=len(ibl.lights))
        ctx = self.ctx
        out_fbo.use()
        ctx.viewport = (0, 0, camera.width, camera.height)
        ctx.disable(ctx.DEPTH_TEST)
        ctx.enable(ctx.BLEND)
        ctx.blend_func = (ctx.ONE, ctx.ONE_MINUS_SRC_ALPHA)
        ctx.blend_equation = ctx.FUNC_ADD
        ctx.front_face = "ccw"
        try:
            for index in forward_order(meshes, camera):
                mesh = meshes[index]
                entry = self.uploads.upload(mesh, variant)
                prog = entry.vao.program
                unit = bind_gbuffer(prog, gbuffer_textures)
                unit = ibl.bind(prog, unit)
                unit = self.shadow_maps.bind(prog, light, shadows or {}, sun_shadow, unit)
                set_view_and_lighting(prog, camera, environment, light)
                self.uploads.set_camera(prog, camera)
                if mesh.material.transmission > 0.0:
                    unit = _bind_transmission(prog, mesh, transmission_frame, unit)
                units = self.uploads.bind_material(prog, entry, unit)
                ctx.enable(ctx.CULL_FACE)
                if mesh.double_sided:  # back faces first: a closed convex mesh composites right
                    ctx.cull_face = "front"
                    entry.vao.render(ctx.TRIANGLES)
                ctx.cull_face = "back"
                entry.vao.render(ctx.TRIANGLES)
                self.uploads.unbind(entry, units)
        finally:
            ctx.disable(ctx.BLEND | ctx.CULL_FACE)
            ctx.cull_face = "back"
            ctx.blend_func = ctx.DEFAULT_BLENDING

    def release(self) -> None:
        self.uploads.release()
        self.shadow_maps.release()


def _bind_transmission(prog, mesh: Mesh, frame, unit: int) -> int:
    """The uniforms of ``forward_surface.glsl``'s refracted_radiance for ``mesh``: the opaque
    frame's copy ``frame`` (mip-mapped) on texture unit ``unit``, the volume's thickness and
    attenuation; returns the next free unit."""
    frame.use(unit)
    set_uniform(prog, "u_transmission_frame", unit)
    set_uniform(prog, "u_transmission_log2_width", float(np.log2(max(frame.size[0], 1))))
    m = mesh.material
    set_uniform(prog, "u_thickness", float(m.thickness) if m.volume else 0.0)
    set_uniform(prog, "u_attenuation_sigma", tuple(float(c) for c in m.attenuation_coefficient()))
    return unit + 1


_FALLBACK_WARNED: set[str] = set()
_UNSHADOWED_WARNED: list[bool] = []


def warn_unshadowed(variant: ShadeVariant, shadows: dict, light) -> None:
    """Once per process, where the forward ``variant`` reads a map the frame did not draw
    (``shadows``: its maps by light index, ``"sun"``, ``"env<k>"``): the environment's sun, or a
    shadowing light of ``light``, is then unshadowed on transparent surfaces."""
    from ..lighting.lights import as_lights, shadowing

    defines = dict(variant.defines)
    missing = []
    if defines.get("SUN_SHADOW") and "sun" not in shadows:
        missing.append("the environment's sun")
    if defines.get("LIGHT_SHADOWS"):
        missing += [f"light {i}" for i in shadowing(as_lights(light), True) if i not in shadows]
    if missing and not _UNSHADOWED_WARNED:
        _UNSHADOWED_WARNED.append(True)
        warnings.warn(f"transparent (blended) surfaces receive no shadow from {', '.join(missing)}"
                      f": the frame draws no map for it under model {variant.model!r}'s lighting "
                      "pass", stacklevel=4)


def _warn_fallback(model: str) -> None:
    """Once per model and process: blended surfaces are shaded by :data:`FALLBACK_MODEL`."""
    if forward_model(model) != model and model not in _FALLBACK_WARNED:
        _FALLBACK_WARNED.add(model)
        warnings.warn(f"model {model!r} cannot shade transparent (alphaMode BLEND) surfaces in a "
                      f"forward pass; they are shaded with {FALLBACK_MODEL}", stacklevel=4)
