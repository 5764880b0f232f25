"""The headless deferred renderer: scene -> G-buffer -> lighting -> forward (transparent
surfaces) -> tone mapping.

    from viewer import Renderer, load_scene
    renderer = Renderer()                       # headless EGL (llvmpipe without a GPU)
    scene = load_scene("assets/scenes/demo.toml")
    frame = renderer.render(scene, aovs=("normal", "depth"))
    frame.radiance   # [H, W, 4] float32: linear RGB before exposure/tone mapping, alpha = coverage
    frame.display    # [H, W, 4] uint8: exposed, tone-mapped, sRGB-encoded
    frame.aovs["normal"]
    frame2 = renderer.render(scene.with_render(exposure=1.0))   # cached: only the last passes rerun

GPU resources are cached by value: geometry per object description, IBL precomputation per
environment (intensity and rotation are uniforms, so light sliders never recompute), render targets
per size and layout, programs per variant. Arrays are row 0 at the top.

Passes whose inputs did not change since the last frame at the same size and layout are not drawn
again (``Renderer.reuse_passes``, on by default): the G-buffer when the objects (materials
included), camera, layout and splat depth are unchanged, and the SSAO occlusion / visibility pass
(and its hits and upsampling) when, in addition, the SSAO settings, seed and the environment's
file, procedural parameters and rotation are unchanged (its intensity does not enter them). A
light, exposure or environment-intensity slider then re-runs only the lighting passes. ``reuse_passes = False`` draws every pass every frame (the benchmarks' full frames).
"""
from __future__ import annotations

import dataclasses
import warnings
from contextlib import contextmanager

from .camera import Camera
from .errors import SceneError
from .frame import Frame, FrameTargets, read_texture
from .gbuffer import CHANNEL_NAMES, GBufferLayout
from .geometry.cache import GeometryCache
from .gl import ContextOptions, Programs, create_context, make_current
from .models import ShadingModel, model_info
from .neural import learns_indirect, reads_visibility, required_settings, shades_sun
from .passes.forward import forward_model
from .passes.ssao import hit_targets, low_resolution
from .resources import GPUResources, TargetSet
from .scene import ObjectSpec, Scene
from .specialize import Specialization, analyse, specialise

__all__ = ["AOV_NAMES", "Frame", "FrameTargets", "Renderer", "check_aovs", "read_texture"]

AOV_NAMES = CHANNEL_NAMES  # albedo, alpha, normal, roughness, metallic, specular, ao, depth, color


class Renderer:
    """Owns one GL context and every GPU resource derived from scenes rendered with it."""

    MC_BATCH = 16  # Monte-Carlo samples per lighting draw (keeps each draw short)

    def __init__(self, ctx=None, options: ContextOptions = ContextOptions()):
        self._owns_context = ctx is None
        self.ctx = ctx if ctx is not None else create_context(options)
        self.programs = Programs(self.ctx)
        self.geometry_cache = GeometryCache()  # CPU geometry per object shape
        self.resources = GPUResources(self.programs)  # targets, passes, IBL, accumulators
        self._features: dict[tuple, object] = {}  # (objects, environment) -> SceneFeatures
        # optional per-pass profiler (viewer.gl.timing.PassTimer): .begin(name) between passes
        self.profiler = None
        # reuse the G-buffer and SSAO targets of the last frame whose inputs were the same (the
        # module docstring); False: every pass every frame
        self.reuse_passes = True

    @contextmanager
    def every_pass(self):
        """``with renderer.every_pass(): ...`` draws every pass of every frame inside (no reuse of
        the last frame's G-buffer or SSAO targets): what a benchmark times as a whole frame."""
        saved, self.reuse_passes = self.reuse_passes, False
        try:
            yield self
        finally:
            self.reuse_passes = saved

    # ---- scene content ------------------------------------------------------------------------
    def geometry(self, obj: ObjectSpec):
        """CPU geometry for an object: a list of meshes, an image-space G-buffer or a splat cloud
        (:class:`~viewer.geometry.cache.GeometryCache`: loaded once, shared across materials)."""
        return self.geometry_cache.get(obj)

    def add_geometry(self, obj: ObjectSpec, content) -> None:
        """Use ``content`` (as the loaders return it) for ``obj`` instead of loading ``obj.path``:
        geometry made in memory (tests, benchmarks, generated data), taken as given."""
        self.geometry_cache.add(obj, content)

    def resolve_camera(self, scene: Scene, size: tuple[int, int] | None = None) -> Camera:
        """The scene's camera, or the camera of its image-space G-buffer stack."""
        stacks = [self.geometry(o) for o in scene.objects if o.type == "gbuffer"]
        camera = scene.camera
        if stacks:
            sizes = {s.size for s in stacks}
            if len(sizes) > 1:
                raise SceneError(f"image-space G-buffers of different sizes {sorted(sizes)} in one "
                                 f"scene", where=scene.source)
            stack = stacks[0]
            camera = Camera(position=(0.0, 0.0, 0.0), target=(0.0, 0.0, -1.0), up=(0.0, 1.0, 0.0),
                            fov_y=stack.fov_y, size=stack.size, near=scene.camera.near,
                            far=max(scene.camera.far, 1e4))
            if size is not None and tuple(size) != tuple(stack.size):
                raise SceneError(f"an image-space G-buffer renders at its own size "
                                 f"{stack.size[0]}x{stack.size[1]}, not {size[0]}x{size[1]}",
                                 where=scene.source)
        elif size is not None:
            camera = camera.with_size(*size)
        return camera

    def specialization(self, scene: Scene, aovs=()):
        """The G-buffer layout and lighting-pass defines this scene needs (see
        :mod:`viewer.specialize`; ``render.specialize = false`` gives the all-features path).
        ``aovs``: channels the caller reads back, always allocated."""
        # a sun to shade analytically (SUN_LIGHT): only looked for where the model can use it
        # (a classical model that does, or a student whose base does: viewer.neural.shades_sun)
        sun = ((model_info(scene.render.model).analytic_sun or shades_sun(scene.render))
               and scene.render.sun and self.resources.sun(scene.environment) is not None)
        if not scene.render.specialize:
            return specialise(None, scene.render, aovs, enabled=False, light=scene.light,
                              sun=sun)
        # the analysis scans materials and texture maps: once per scene content, not per frame
        key = (scene.objects, scene.environment.path, scene.environment.procedural)
        if key not in self._features:
            self._features[key] = analyse(self, scene)
        return specialise(self._features[key], scene.render, aovs, light=scene.light, sun=sun)

    def layout_for(self, scene: Scene, aovs=()) -> GBufferLayout:
        return self.specialization(scene, aovs).layout

    def ibl(self, scene: Scene):
        """The environment's IBL precomputation (prefiltered chain, SH, DFG LUT), cached."""
        return self.resources.ibl(scene.environment)

    def env_sampling(self, scene: Scene):
        """The environment's importance-sampling distribution, cached like the IBL."""
        return self.resources.env_sampling(scene.environment)

    def environment_visibility(self, scene: Scene, frame: FrameTargets):
        """The SSAO pass with the environment's screen-space visibility (``SSAO_ENV_VIS``) on the
        G-buffer of ``frame`` (what :meth:`draw` left for ``scene``, drawn with SSAO so depth and
        normals are allocated), into the frame's SSAO target: r = O(x), g = S(x), as a student
        with ``vis`` inputs reads them. For training data, tests and parity checks."""
        make_current(self.ctx)
        layout = self.specialization(scene).layout
        targets = self.resources.targets(layout, frame.camera.size)
        targets.keys.pop("ssao", None)  # it overwrites what a frame may reuse
        tex, _ = self._occlusion(self.resources.layout_pass("ssao", layout), scene, targets,
                                 frame.gbuffer.textures, frame.camera, True)
        return tex

    def _occlusion(self, sspass, scene: Scene, targets: TargetSet, gbuffer_textures,
                   camera: Camera, visibility: bool, record_hits: bool = False
                   ) -> tuple[object, list | None]:
        """SSAO's occlusion O(x) into the frame's ``ssao`` target; with ``visibility`` also S(x)
        towards the environment's equal-power directions (``viewer.envsampling.
        power_directions``); with ``record_hits`` each ray's hit pixel into the hit targets
        (:func:`_ssao_hit_targets`). At ``ssao.scale`` k > 1 the rays run at low resolution and
        the upsampling pass (timed as ``ssao_upsample``) fills the full-resolution target.
        Returns (the ``ssao`` texture, the hit textures or None)."""
        settings = scene.render
        k = int(settings.ssao.scale)
        vis_dirs = self.resources.power_directions(scene.environment) if visibility else None
        low_name = _occlusion_target(k)
        low, fbo = targets.extra(self.ctx, low_name, size=low_resolution(camera.size, k))
        hits = None
        if record_hits:
            hits, fbo = _ssao_hit_targets(self.ctx, targets, settings.ssao.rays, low_name,
                                          low_resolution(camera.size, k))
        sspass.occlusion(gbuffer_textures, fbo, camera, settings, vis_dirs=vis_dirs,
                         env_rotation_deg=scene.environment.rotation_deg,
                         record_hits=record_hits)
        if k == 1:
            return low, hits
        self._pass_begin("ssao_upsample")
        tex, full_fbo = targets.extra(self.ctx, "ssao")
        sspass.upsample(gbuffer_textures, low, full_fbo, camera, settings)
        return tex, hits

    # ---- the render graph ---------------------------------------------------------------------
    def draw(self, scene: Scene, size: tuple[int, int] | None = None, progressive: bool = False,
             samples_per_frame: int = 1, aovs=()) -> FrameTargets:
        """Run every pass on the GPU; no readback. Returns the frame's :class:`FrameTargets`.

        Monte-Carlo models (``ggx_mc``) render ``scene.render.mc.samples`` samples per pixel in
        batches. With ``progressive=True`` a call adds only ``samples_per_frame`` samples to the
        running mean kept since the last call, as long as the scene (except exposure and tone
        mapping) and the size are unchanged (any change restarts), and stops adding once
        ``scene.render.mc.samples`` are in; ``FrameTargets.samples`` is the count accumulated.
        ``aovs``: G-buffer channels the caller will read from ``FrameTargets.gbuffer`` (the layout
        is specialised to the scene, so channels nothing reads are otherwise not allocated).
        The renderer's context is made current first, so several renderers and contexts can live
        in one process.
        """
        make_current(self.ctx)
        model = model_info(scene.render.model)  # unknown model -> SceneError before any GPU work
        settings = required_settings(scene.render)  # SSAO for a student that reads visibility
        if settings is not scene.render:
            scene = dataclasses.replace(scene, render=settings)
        camera = self.resolve_camera(scene, size)
        spec = self.specialization(scene, aovs)
        targets = self.resources.targets(spec.layout, camera.size)
        gkey = (scene.objects, camera, settings.splat_depth, self.geometry_cache.version)
        if spec.direct_stack or not (self.reuse_passes and targets.keys.get("gbuffer") == gkey):
            self._pass_begin("gbuffer")
            gbuffer = self._gbuffer(scene, spec, targets, camera)
        else:  # the same geometry seen from the same camera: last frame's G-buffer
            gbuffer = targets.gbuffer
        targets.keys["gbuffer"] = gkey
        self._pass_begin("ibl")  # precomputation, only when the environment is new
        ibl = self.ibl(scene)
        samples = self._lighting(scene, model, spec, targets, gbuffer, camera, ibl, progressive,
                                 samples_per_frame)
        blended = [] if spec.direct_stack else self._blended(scene)
        if blended:  # transparent surfaces over the shaded radiance (viewer/passes/forward.py)
            self._pass_begin("forward")
            # the forward model shades the environment's sun itself when it can (SUN_LIGHT)
            sun = settings.sun and model_info(forward_model(settings.model)).analytic_sun
            self.resources.layout_pass("forward", spec.layout).run(
                blended, gbuffer.textures, targets.radiance_fbo, camera,
                self.resources.ibl(scene.environment, sun=sun), scene.environment, settings,
                light=scene.light)
        self._pass_begin("tonemap")
        self.resources.tonemap().run(targets.radiance, targets.display_fbo,
                                     settings.display.exposure, settings.display.tonemap)
        self._pass_begin(None)
        extra = {name: tex for name, (tex, _) in targets.extras.items()}
        return FrameTargets(radiance=targets.radiance, display=targets.display, gbuffer=gbuffer,
                            camera=camera, variant=spec.variant, samples=samples,
                            ssao=extra.get("ssao") if settings.ssao.enabled else None,
                            direct=extra.get("direct") if settings.ssao.indirect else None,
                            indirect_factor=(extra.get("indirect_factor")
                                             if learns_indirect(settings) else None))

    def _gbuffer(self, scene: Scene, spec: Specialization, targets: TargetSet, camera: Camera):
        """G-buffer pass (image stacks, meshes) then splats; returns the G-buffer to shade."""
        gpass = self.resources.layout_pass("gbuffer", spec.layout)
        gb = targets.gbuffer
        if spec.direct_stack:
            # one image-space stack and nothing else: its uploaded textures already are a
            # G-buffer in this layout, so the lighting pass reads them and no copy pass runs
            stack = self.geometry(scene.objects[0])
            return gb.viewing(dict(gpass._stack_textures(stack)))
        gb.clear()
        meshes, clouds = [], []
        for obj in scene.objects:
            content = self.geometry(obj)
            if obj.type == "gbuffer":
                gpass.draw_image(gb, content)
            elif obj.type == "splats":
                clouds.append(content)
            else:  # alphaMode BLEND: the forward pass after lighting
                meshes.extend(m for m in content if m.alpha_mode != "BLEND")
        if meshes:
            gpass.draw_meshes(gb, camera, meshes)
        if clouds:  # after meshes: depth-tested against them, composited over them
            self._pass_begin("splats")
            self.resources.layout_pass("splats", spec.layout).draw_clouds(
                gb, camera, clouds, depth=scene.render.splat_depth)
        return gb

    def _blended(self, scene: Scene) -> list:
        """The scene's transparent meshes (glTF ``alphaMode: BLEND``), in file order."""
        return [m for obj in scene.objects if obj.type not in ("gbuffer", "splats")
                for m in self.geometry(obj) if m.alpha_mode == "BLEND"]

    def _lighting(self, scene: Scene, model: ShadingModel, spec: Specialization,
                  targets: TargetSet, gbuffer, camera: Camera, ibl, progressive: bool,
                  samples_per_frame: int) -> int:
        """SSAO -> lighting (accumulated for Monte-Carlo models) -> indirect, into ``radiance``.
        Returns the samples averaged. With ``indirect`` the lighting pass writes the direct-light
        target of this frame, and the indirect pass adds eq. 6.22 gathered from it; a neural
        student with a learned indirect factor also writes that factor (a second output, an R32F
        target made only for it) and the indirect pass scales its light by it."""
        settings = scene.render
        if scene.light is not None and model.directional_light == "ignored":
            _warn_light_ignored(settings.model)
        gbt = gbuffer.textures
        ssao = hits = None
        if settings.ssao.enabled or settings.ssao.indirect:
            sspass = self.resources.layout_pass("ssao", spec.layout)
        if settings.ssao.enabled:
            # + the environment's visibility (g channel) for a student that reads it; with the
            # indirect light, the rays' hit pixels for the indirect pass to reuse
            visibility = reads_visibility(settings)
            env = scene.environment
            skey = (targets.keys.get("gbuffer"), settings.ssao, settings.mc.seed, visibility,
                    settings.ssao.indirect,
                    dataclasses.replace(env, intensity=1.0) if visibility else None)
            if self.reuse_passes and skey[0] is not None and targets.keys.get("ssao") == skey:
                ssao = targets.extras["ssao"][0]  # last frame's occlusion, visibility and hits
                hits = (_ssao_hit_targets(self.ctx, targets, settings.ssao.rays,
                                          _occlusion_target(settings.ssao.scale),
                                          low_resolution(camera.size, settings.ssao.scale))[0]
                        if settings.ssao.indirect else None)
            else:
                self._pass_begin("ssao")
                ssao, hits = self._occlusion(sspass, scene, targets, gbt, camera, visibility,
                                             record_hits=settings.ssao.indirect)
            targets.keys["ssao"] = skey
        factor = None
        if settings.ssao.indirect:
            out_tex, out_fbo = targets.extra(self.ctx, "direct")
            if learns_indirect(settings):  # the student's 2nd output: its indirect factor
                factor, _ = targets.extra(self.ctx, "indirect_factor", components=1)
                out_fbo = targets.extras_fbo(self.ctx, ("direct", "indirect_factor"))
        else:
            out_tex, out_fbo = targets.radiance, targets.radiance_fbo
        env_sampling = self.env_sampling(scene) if "cdf" in model.needs else None
        spass = self.resources.layout_pass("shade", spec.layout)
        self._pass_begin("shade")

        if spec.variant.defines.get("SUN_LIGHT"):  # the IBL without the sun it shades itself
            ibl = self.resources.ibl(scene.environment, sun=True)

        def shade(fbo, sample_range=(0, 1)):
            spass.run(gbt, fbo, camera, ibl, scene.environment, settings,
                      env_sampling=env_sampling, ssao=ssao, sample_range=sample_range,
                      variant=spec.variant, light=scene.light)

        samples = 1
        if model.accumulates:
            samples = self._accumulate(scene, camera, shade, out_fbo, progressive,
                                       samples_per_frame)
        else:
            shade(out_fbo)
        if settings.ssao.indirect:
            self._pass_begin("indirect")
            # reads the occlusion pass's hits; marches the rays itself without that pass
            k = int(settings.ssao.scale)
            gather_fbo = None if k == 1 else targets.extra(
                self.ctx, f"gathered/{k}", size=low_resolution(camera.size, k))[1]
            sspass.indirect(gbt, out_tex, targets.radiance_fbo, camera, settings, factor=factor,
                            hits=hits, gather_fbo=gather_fbo)
        return samples

    def _accumulate(self, scene: Scene, camera: Camera, shade, out_fbo, progressive: bool,
                    samples_per_frame: int) -> int:
        """Monte-Carlo batches into the running mean of this camera size; returns its count."""
        settings = scene.render
        if settings.mc.samples < 1:
            raise SceneError(f"render.samples must be at least 1 for {settings.model}, got "
                             f"{settings.mc.samples}", where=scene.source or "render.samples")
        acc = self.resources.accumulator(camera.size)
        # exposure and tone mapping act after the running mean: they do not restart it
        display = dataclasses.replace(settings.display, exposure=0.0, tonemap="none")
        key = (dataclasses.replace(scene, render=dataclasses.replace(settings, display=display)),
               camera)
        if not progressive or acc.key != key:
            acc.reset(key)
        if progressive:
            todo = min(max(int(samples_per_frame), 1), max(settings.mc.samples - acc.count, 0))
        else:
            todo = settings.mc.samples
        if todo == 0:  # converged: the history holds the mean
            self.ctx.copy_framebuffer(dst=out_fbo, src=acc.history_fbo)
        while todo > 0:
            n = min(todo, self.MC_BATCH)
            shade(acc.batch_fbo, (acc.count, n))
            acc.add(n, out_fbo)
            todo -= n
        return acc.count

    def _pass_begin(self, name: str | None) -> None:
        """Profiling hook between passes: ``profiler.begin(name)`` ends the previous pass's timer
        and starts ``name``'s (``None`` ends the last). Nothing without a profiler."""
        if self.profiler is not None:
            self.profiler.begin(name)

    # ---- read-back ------------------------------------------------------------------------------
    def render(self, scene: Scene, aovs: tuple[str, ...] | list[str] = (),
               size: tuple[int, int] | None = None) -> Frame:
        """Render ``scene`` and read back radiance, display pixels and the requested AOVs."""
        make_current(self.ctx)
        check_aovs(aovs)
        targets = self.draw(scene, size, aovs=tuple(a for a in aovs if a != "color"))
        radiance = read_texture(targets.radiance, "f4")
        display = read_texture(targets.display, "f1")
        frame = Frame(radiance=radiance, display=display, camera=targets.camera)
        if aovs:
            gb = targets.gbuffer
            channels = gb.read()
            for name in aovs:
                if name == "color" and "color" not in channels:
                    # meshes: the unlit colour is the albedo, premultiplied by coverage
                    channels["color"] = channels["albedo"] * channels["alpha"]
                frame.aovs[name] = channels[name]
        return frame

    def release(self) -> None:
        """Free every GPU resource (and the context, if this renderer created it)."""
        make_current(self.ctx)
        self.resources.release()
        if self._owns_context:
            self.ctx.release()


def check_aovs(aovs) -> None:
    """Every name in ``aovs`` is a G-buffer channel (:data:`AOV_NAMES`), or a one-line error."""
    unknown = [a for a in aovs if a not in AOV_NAMES]
    if unknown:
        raise SceneError(f"unknown AOV {', '.join(map(repr, unknown))} "
                         f"(known: {', '.join(AOV_NAMES)})", where="--aov")


def _occlusion_target(scale: int) -> str:
    """The extra target the occlusion pass draws to: ``ssao`` at full scale, ``ssao/<k>`` (low
    resolution, upsampled into ``ssao``) at reduced scale."""
    return "ssao" if int(scale) == 1 else f"ssao/{int(scale)}"


def _ssao_hit_targets(ctx, targets: TargetSet, rays: int, occlusion: str = "ssao",
                      size=None) -> tuple[list, object]:
    """The RGBA32UI targets of SSAO's ray hits for ``rays`` rays (``<occlusion>_hits<i>``, of
    ``size``: the occlusion target's) and the framebuffer the occlusion pass draws to with them:
    the target ``occlusion`` (O(x)) at attachment 0, the hits after it."""
    names = tuple(f"{occlusion}_hits{i}" for i in range(hit_targets(rays)))
    hits = [targets.extra(ctx, name, dtype="u4", size=size)[0] for name in names]
    return hits, targets.extras_fbo(ctx, (occlusion,) + names)


_LIGHT_WARNED: set[str] = set()


def _warn_light_ignored(model: str) -> None:
    """Once per model and process: ``model`` renders without the scene's directional light."""
    if model not in _LIGHT_WARNED:
        _LIGHT_WARNED.add(model)
        warnings.warn(f"model {model!r} ignores the scene's [light] (trained under environment "
                      f"light only); it is shaded by the environment alone", stacklevel=4)
