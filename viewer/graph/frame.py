"""The renderer's frame as a frame graph: every pass of a frame declared in the order it runs.

    gbuffer -> splats -> ssao -> ssao_upsample -> ssao_blur -> shadow<i> -> shade
            -> indirect_gather -> indirect_blur -> indirect -> shadow_net -> transmission_copy
            -> forward -> ssaa_resolve -> tonemap -> fxaa

``transmission_copy`` (only in a scene with a KHR_materials_transmission surface under a model
that refracts it in the forward pass, :func:`viewer.models.refracts_forward`) keeps a mip-mapped
copy of the opaque frame, ``transmission_frame``, which those surfaces, drawn by ``forward``
instead of the G-buffer, read refracted (as three.js's transmission render target).

With ``[render] ssaa`` = N > 1 every pass up to ``forward`` runs at N times the camera's size and
``ssaa_resolve`` box-averages the radiance into ``resolved`` (the output size); with ``[render] aa
= "fxaa"`` the tone-mapped image goes through FXAA into ``display``.

Each pass names what it reads and writes and the scene/settings values its output depends on;
the graph (:mod:`viewer.graph.graph`) culls, decides reuse from those declarations and allocates
targets from the renderer's pool. Only the passes the scene's specialisation needs are declared
(no splats pass without splats, no SSAO without SSAO, ...). The draw calls themselves live in
:mod:`viewer.passes`.
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass

from ..models import ShadingModel, model_info, sample_count
from ..neural import learns_indirect, needs_env_visibility
from ..passes.forward import (forward_meshes, forward_model, forward_variant,
                               warn_unshadowed)
from ..passes.ground import scene_catcher
from ..passes.ssao import denoised, hit_targets, low_resolution, staged
from ..scene.camera import Camera
from ..scene.description import Scene
from ..specialize import Specialization
from .display import display_passes, ssaa_factor
from .gbuffer import gbuffer_passes
from .graph import FrameGraph
from .raytrace import raytrace_passes
from .resources import MipTextureDesc, TextureDesc
from .shadow_net import RADIANCE as SN_RADIANCE
from .shadow_net import VISIBILITY as SN_VISIBILITY
from .shadow_net import shadow_net_passes, visibility_route
from .shadows import cascade_variant, env_to_world, light_shadow_frame, shadow_passes  # noqa: F401

MC_BATCH = 16  # Monte-Carlo samples per lighting draw (keeps each draw short)
TRANSMISSION_FRAME = "transmission_frame"  # the opaque frame's mip-mapped copy


@dataclass
class FrameRequest:
    """What one frame is asked for: the scene (its settings already completed by
    ``viewer.neural.required_settings``), the shading model, the specialisation and camera, and
    Monte-Carlo progression."""

    scene: Scene
    model: ShadingModel
    spec: Specialization
    camera: Camera
    progressive: bool = False
    samples_per_frame: int = 1


def build_frame(renderer, req: FrameRequest, reuse: bool = True) -> FrameGraph:
    """The frame graph of ``req`` over ``renderer``'s passes and pool (not yet compiled)."""
    n = ssaa_factor(req.scene)
    out_size = tuple(req.camera.size)
    if n > 1:  # every pass up to the resolve at n x the size
        req = dataclasses.replace(req, camera=req.camera.with_size(out_size[0] * n,
                                                                   out_size[1] * n))
    scene, spec, camera = req.scene, req.spec, req.camera
    settings = scene.render
    res = renderer.resources
    g = FrameGraph(res.pool, scope="frame", reuse=reuse)
    size = tuple(camera.size)
    g.create("radiance", TextureDesc(size, 4, "f4"), kept=True)
    g.create("display", TextureDesc(out_size, 4, "f1"), kept=True)

    gbuffer_passes(g, renderer, scene, spec, camera)
    rt = bool(spec.variant.defines.get("RT_LIGHT"))  # rays stand in for SSAO and its bounce
    ssao = _ssao_passes(g, renderer, scene, spec, camera,
                        visibility=needs_env_visibility(settings),
                        record_hits=settings.ssao.indirect,
                        blur=settings.ssao.blur) if settings.ssao.enabled and not rt else None
    blended = [] if spec.direct_stack else forward_meshes(renderer, scene)
    refracting = any(m.material.transmission > 0.0 for m in blended)
    fvariant = None
    if blended:  # its program reads the maps too: the sun's where only it shades the sun
        # the forward model shades the environment's sun itself when it can (SUN_LIGHT)
        sun = settings.sun and model_info(forward_model(settings.model)).analytic_sun
        fvariant = forward_variant(settings, scene.light,
                                   sun=len(res.ibl(scene.environment, sun=sun).lights))
    shadows = shadow_passes(g, renderer, scene, spec, camera, also=fvariant)
    rt_light = raytrace_passes(g, renderer, scene, spec, camera, req.progressive,
                               _lighting_settings(settings)) if rt else ()
    lit_ssao = ssao
    if visibility_route(settings):  # the estimator's V in place of SSAO (graph/shadow_net.py)
        g.create(SN_RADIANCE, TextureDesc(size, 4, "f4"))
        _lighting_passes(g, renderer, req, ssao, shadows, out=SN_RADIANCE)
        shadow_net_passes(g, renderer, scene, spec, camera, ssao.occlusion if ssao else None,
                          radiance=SN_RADIANCE, visibility=SN_VISIBILITY)
        lit_ssao = SSAOOutputs(SN_VISIBILITY, ssao.hits)
    _lighting_passes(g, renderer, req, lit_ssao, shadows, rt_light)
    if lit_ssao is ssao:  # the product form, or no estimator (no pass)
        shadow_net_passes(g, renderer, scene, spec, camera, ssao.occlusion if ssao else None)
    if refracting:  # what transmissive surfaces refract: the opaque frame, blurred by level
        g.create(TRANSMISSION_FRAME, MipTextureDesc(size, 4, "f4"))

        def transmission_copy(f):
            copy = f[TRANSMISSION_FRAME]
            renderer.ctx.copy_framebuffer(dst=copy.fbo, src=f["radiance"].fbo)
            copy.texture.build_mipmaps()
        g.add_pass("transmission_copy", transmission_copy, reads=("radiance",),
                   writes=(TRANSMISSION_FRAME,))
    if blended:  # transparent surfaces over the shaded radiance (viewer/passes/forward.py)

        def forward(f):  # receives the frame's shadow maps (viewer/passes/forward.py)
            ibl = res.ibl(scene.environment, sun=sun)
            variant = cascade_variant(fvariant, shadows)
            warn_unshadowed(variant, shadows, scene.light)
            res.layout_pass("forward", spec.layout).run(
                blended, f["gbuffer"].textures, f["radiance"].fbo, camera, ibl,
                scene.environment, settings, light=scene.light, variant=variant,
                shadows={i: (f[name].texture, frame, size, offset)
                         for i, (name, frame, size, offset) in shadows.items() if i != "sun"},
                sun_shadow=((f[shadows["sun"][0]].texture,) + shadows["sun"][1:]
                            if "sun" in shadows else None),
                transmission_frame=f[TRANSMISSION_FRAME].texture if refracting else None)
        g.add_pass("forward", forward,
                   reads=("gbuffer", "radiance") + tuple(v[0] for v in shadows.values())
                   + ((TRANSMISSION_FRAME,) if refracting else ()),
                   writes=("radiance",),
                   inputs={"objects": scene.objects, "render": _lighting_settings(settings),
                           "environment": scene.environment, "light": scene.light})

    display_passes(g, renderer, settings, n, out_size)
    return g


# ---- SSAO -------------------------------------------------------------------------------------
@dataclass
class SSAOOutputs:
    occlusion: str          # the full-resolution O(x) / S(x) resource
    hits: tuple[str, ...]   # the rays' hit targets (empty without record_hits)


def _ssao_passes(g: FrameGraph, renderer, scene: Scene, spec: Specialization, camera: Camera,
                 visibility: bool, record_hits: bool, blur: bool) -> SSAOOutputs:
    """SSAO's occlusion O(x) (``ssao``); with ``visibility`` also S(x) towards the environment's
    equal-power directions; with ``record_hits`` each ray's hit pixel for the indirect pass. At
    ``ssao.scale`` k > 1 the rays run at low resolution and ``ssao_upsample`` brings them to full
    resolution; with ``blur`` that result (``ssao/raw``) goes through ``ssao_blur`` into
    ``ssao``."""
    res = renderer.resources
    settings = scene.render
    k = int(settings.ssao.scale)
    low_size = low_resolution(camera.size, k)
    full = "ssao/raw" if blur else "ssao"  # O(x) at full resolution before the blur
    occ = full if k == 1 else f"ssao/{k}"
    g.create(occ, TextureDesc(low_size, 4, "f4"), kept=True)
    hits = tuple(f"{'ssao' if k == 1 else occ}_hits{i}"
                 for i in range(hit_targets(settings.ssao.rays))) if record_hits else ()
    for h in hits:
        g.create(h, TextureDesc(low_size, 4, "u4"), kept=True)
    env = scene.environment
    sspass = res.layout_pass("ssao", spec.layout)

    def occlusion(f):
        vis_dirs = res.power_directions(env) if visibility else None
        sspass.occlusion(f["gbuffer"].textures, f.fbo(occ, *hits), camera, settings,
                         vis_dirs=vis_dirs, env_rotation_deg=env.rotation_deg,
                         record_hits=record_hits)
    # the environment enters only through the visibility's directions (not its intensity)
    g.add_pass("ssao", occlusion, reads=("gbuffer",), writes=(occ,) + hits,
               inputs={"ssao": dataclasses.replace(settings.ssao, blur=True),
                       "seed": settings.mc.seed, "visibility": visibility,
                       "environment": (dataclasses.replace(env, intensity=1.0)
                                       if visibility else None)})
    if k > 1:
        g.create(full, TextureDesc(tuple(camera.size), 4, "f4"), kept=True)

        def upsample(f):
            sspass.upsample(f["gbuffer"].textures, f[occ].texture, f[full].fbo, camera, settings)
        g.add_pass("ssao_upsample", upsample, reads=("gbuffer", occ), writes=(full,),
                   inputs={"scale": k})
    if blur:
        g.create("ssao", TextureDesc(tuple(camera.size), 4, "f4"), kept=True)

        def blurred(f):
            sspass.blur(f["gbuffer"].textures, f[full].texture, f["ssao"].fbo, camera,
                        env_vis=visibility)
        g.add_pass("ssao_blur", blurred, reads=("gbuffer", full), writes=("ssao",),
                   inputs={"blur": True})
    return SSAOOutputs("ssao", hits)


# ---- lighting ---------------------------------------------------------------------------------
def _lighting_settings(settings):
    """The settings the lighting passes depend on: all but exposure, tone mapping and FXAA."""
    return dataclasses.replace(settings, display=dataclasses.replace(
        settings.display, exposure=0.0, tonemap="none", aa="none"))


def _lighting_passes(g: FrameGraph, renderer, req: FrameRequest, ssao: SSAOOutputs | None,
                     shadows: dict, rt_light: tuple[str, ...] = (), out: str = "radiance"):
    """``shade`` (accumulated for Monte-Carlo models) into ``radiance``, or, with the indirect
    light, into ``direct`` (and a student's learned ``indirect_factor``), then ``indirect``;
    ``rt_light``: the real-time tier's filtered targets (RT_LIGHT), which replace the
    screen-space indirect light. ``ssao.occlusion`` names the map read as SSAO's: the shadow
    estimator's visibility (:data:`SN_VISIBILITY`) compiles ``SSAO_SHADOW_NET`` in. ``out``
    other than ``radiance``: only the lighting pass, ``<out's folder>:shade``, into ``out`` (the
    estimator's unshadowed input, :mod:`viewer.graph.shadow_net`)."""
    scene, model, spec, camera = req.scene, req.model, req.spec, req.camera
    settings = scene.render
    res = renderer.resources
    size = tuple(camera.size)
    side = out != "radiance"
    indirect = settings.ssao.indirect and not rt_light and not side
    factor = indirect and learns_indirect(settings)
    target = "direct" if indirect else out
    outs = (target,)
    if indirect:
        g.create("direct", TextureDesc(size, 4, "f4"), kept=True)
        if factor:  # the student's 2nd output: its indirect factor (R32F)
            g.create("indirect_factor", TextureDesc(size, 1, "f4"), kept=True)
            outs = ("direct", "indirect_factor")
    reads = (("gbuffer",) + ((ssao.occlusion,) if ssao else ())
             + tuple(name for name, _, _, _ in shadows.values()) + tuple(rt_light))
    variant = cascade_variant(spec.variant, shadows)
    if ssao is not None and ssao.occlusion == SN_VISIBILITY:
        variant = variant.with_defines({"SSAO_SHADOW_NET": 1})
    env_sampling = renderer.env_sampling(scene) if "cdf" in model.needs else None
    # the IBL without the sun a SUN_LIGHT pass shades itself
    ibl = res.ibl(scene.environment, sun=bool(spec.variant.defines.get("SUN_LIGHT")))
    spass = res.layout_pass("shade", spec.layout)
    traced = ([(obj, renderer.geometry(obj)) for obj in scene.objects] if model.traced
              else None)
    ground = scene_catcher(scene.objects)  # the shadow-catcher plane, or None

    def traced_scene():  # looked up once a frame (its materials re-uploaded if they changed)
        return (res.trace.get(traced, renderer.geometry_cache.version) if traced is not None
                else None)

    def shade_into(f, fbo, sample_range=(0, 1), trace=None):
        spass.run(f["gbuffer"].textures, fbo, camera, ibl, scene.environment, settings,
                  env_sampling=env_sampling, ssao=f[ssao.occlusion].texture if ssao else None,
                  sample_range=sample_range, variant=variant, light=scene.light,
                  shadows={i: (f[name].texture, frame, angle, offset)
                           for i, (name, frame, angle, offset) in shadows.items() if i != "sun"},
                  sun_shadow=((f[shadows["sun"][0]].texture,) + shadows["sun"][1:]
                              if "sun" in shadows else None), trace=trace,
                  rt_light=[f[n].texture for n in rt_light], ground=ground)

    inputs = {"model": settings.model, "render": _lighting_settings(settings),
              "environment": scene.environment, "light": scene.light, "variant": variant,
              "ground": ground}
    writes = outs
    if model.accumulates:
        g.create("mc_batch", TextureDesc(size, 4, "f4"))
        g.create("mc_history", TextureDesc(size, 4, "f4"), kept=True)
        writes = outs + ("mc_batch", "mc_history")

        def shade(f):
            trace = traced_scene()
            _accumulate(f, renderer, req,
                        lambda f, fbo, sample_range: shade_into(f, fbo, sample_range, trace),
                        f.fbo(*outs))
    else:
        def shade(f):
            shade_into(f, f.fbo(*outs), trace=traced_scene())
    name = f"{out.split('/')[0]}:shade" if side else "shade"
    g.add_pass(name, shade, reads=reads, writes=writes, inputs=inputs,
               volatile=model.accumulates)

    if not indirect:
        return
    sspass = res.layout_pass("ssao", spec.layout)
    k = int(settings.ssao.scale)
    hits = ssao.hits if ssao else ()
    ind_reads = ("gbuffer", "direct") + hits + (("indirect_factor",) if factor else ())
    ind_inputs = {"ssao": settings.ssao, "seed": settings.mc.seed}
    two_step = staged(settings)
    if two_step:  # gathered (at low resolution, or denoised), composited at full resolution
        raw = g.create(f"gathered/{k}", TextureDesc(low_resolution(size, k), 4, "f4"), True)

        def gather(f):
            sspass.gather(f["gbuffer"].textures, f["direct"].texture, f[raw].fbo, camera,
                          settings, hits=[f[h].texture for h in hits])
        g.add_pass("indirect_gather", gather, reads=("gbuffer", "direct") + hits,
                   writes=(raw,), inputs=ind_inputs)
        # denoised: the gathered E through SSAO's bilateral blur (scale 1)
        gathered = g.create("gathered/blur", TextureDesc(size, 4, "f4"), kept=True) \
            if denoised(settings) else raw
        if gathered != raw:
            def blur_gathered(f):
                sspass.blur(f["gbuffer"].textures, f[raw].texture, f[gathered].fbo, camera, False)
            g.add_pass("indirect_blur", blur_gathered, reads=("gbuffer", raw),
                       writes=(gathered,), inputs={"blur": True})
        ind_reads += (gathered,)

    def indirect_light(f):
        fac = f["indirect_factor"].texture if factor else None
        if two_step:
            sspass.composite(f["gbuffer"].textures, f["direct"].texture, f["radiance"].fbo,
                             camera, settings, f[gathered].texture, factor=fac,
                             ground=ground)
        else:  # reads the occlusion pass's hits; marches the rays itself without that pass
            sspass.indirect(f["gbuffer"].textures, f["direct"].texture, f["radiance"].fbo,
                            camera, settings, factor=fac, hits=[f[h].texture for h in hits],
                            ground=ground)
    g.add_pass("indirect", indirect_light, reads=ind_reads, writes=("radiance",),
               inputs=ind_inputs)


def _accumulate(f, renderer, req: FrameRequest, shade_into, out_fbo) -> None:
    """Monte-Carlo batches into the running mean kept in ``mc_history`` (its state: the sample
    count and what they were rendered for); any change to the scene but exposure and tone mapping,
    or a non-progressive frame, restarts it."""
    scene, camera = req.scene, req.camera
    settings = scene.render
    acc = renderer.resources.accumulate_pass()
    state = f.state("mc_history")
    key = (dataclasses.replace(scene, render=_lighting_settings(settings)), camera)
    if not req.progressive or state.get("key") != key:
        state.update(key=key, count=0)
    if req.progressive:
        todo = min(max(int(req.samples_per_frame), 1),
                   max(sample_count(settings) - state["count"], 0))
    else:
        todo = sample_count(settings)
    batch, history = f["mc_batch"], f["mc_history"]
    if todo == 0:  # converged: the history holds the mean
        renderer.ctx.copy_framebuffer(dst=out_fbo, src=history.fbo)
    while todo > 0:
        n = min(todo, MC_BATCH)
        shade_into(f, batch.fbo, (state["count"], n))
        state["count"] = acc.add(batch.texture, history, state["count"], n, out_fbo)
        todo -= n
    f.samples = state["count"]


def visibility_graph(renderer, scene: Scene, spec: Specialization, frame) -> FrameGraph:
    """SSAO with the environment's visibility S(x) on the G-buffer a frame left (``frame``: its
    :class:`~viewer.frame.FrameTargets`), in a scope of its own so it never overwrites (nor is
    mistaken for) the frame's SSAO target."""
    g = FrameGraph(renderer.resources.pool, scope="visibility", reuse=False)
    g.import_resource("gbuffer", frame.gbuffer, signature=("frame", id(frame.gbuffer)))
    # unblurred: the students' inputs as they are trained (relight data reads this pass)
    _ssao_passes(g, renderer, scene, spec, frame.camera, visibility=True, record_hits=False,
                 blur=False)
    return g
