"""The headless deferred renderer: scene -> G-buffer -> lighting -> tone mapping.

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
"""
from __future__ import annotations

import dataclasses
import warnings
from dataclasses import dataclass, field

import numpy as np

from .camera import Camera
from .environment import load_environment
from .envsampling import build_env_sampling
from .errors import SceneError
from .gbuffer import CHANNEL_NAMES, GBufferLayout
from .geometry.cache import GeometryCache
from .gl import ContextOptions, Programs, create_context, make_current
from .ibl import IBLOptions, build_ibl
from .models import ShadeVariant, ShadingModel, model_info
from .passes.accumulate import Accumulator
from .passes.gbuffer import GBufferPass, GBufferTargets
from .passes.shade import ShadePass
from .passes.splats import SplatPass
from .passes.ssao import SSAOPass
from .passes.tonemap import TonemapPass
from .scene import ObjectSpec, Scene
from .specialize import analyse, specialise

AOV_NAMES = CHANNEL_NAMES  # albedo, alpha, normal, roughness, metallic, specular, ao, depth, color


@dataclass
class Frame:
    """What one render produced, read back to numpy (row 0 at the top)."""

    radiance: np.ndarray  # [H, W, 4] float32 linear radiance, alpha = coverage
    display: np.ndarray  # [H, W, 4] uint8 sRGB after exposure and tone mapping
    aovs: dict[str, np.ndarray] = field(default_factory=dict)  # [H, W, C] float32 each
    camera: Camera | None = None


@dataclass
class FrameTargets:
    """What :meth:`Renderer.draw` leaves on the GPU for one frame (nothing read back): what a
    window shows, the debug views read and the parity checks compare. Textures are moderngl
    textures, GL row order (row 0 at the bottom)."""

    radiance: object  # RGBA32F: linear radiance composited over the background, alpha = coverage
    display: object  # RGBA8: exposed, tone-mapped, sRGB-encoded
    gbuffer: GBufferTargets  # the G-buffer the frame was shaded from (.textures, .read())
    camera: Camera  # the camera it was rendered with (a stack's own camera for image stacks)
    variant: ShadeVariant  # the lighting-pass program that shaded it
    samples: int = 1  # Monte-Carlo samples averaged in `radiance` (1 for single-sample models)
    ssao: object | None = None  # RGBA32F occlusion (r), when render.ssao
    direct: object | None = None  # RGBA32F direct light before the indirect pass (render.indirect)


class Renderer:
    """Owns one GL context and every GPU resource derived from scenes rendered with it."""

    def __init__(self, ctx=None, options: ContextOptions = ContextOptions()):
        self._owns_context = ctx is None
        self.ctx = ctx if ctx is not None else create_context(options)
        self.programs = Programs(self.ctx)
        self.geometry_cache = GeometryCache()  # CPU geometry per object shape
        self._ibl: dict[tuple, object] = {}
        self._targets: dict[tuple, dict] = {}
        self._gbuffer_passes: dict[GBufferLayout, object] = {}
        self._shade_passes: dict[GBufferLayout, object] = {}
        self._tonemap = None
        self._env_sampling: dict[tuple, object] = {}  # environment -> EnvSampling (model needs "cdf")
        self._features: dict[tuple, object] = {}  # (objects, environment) -> SceneFeatures
        self._accumulators: dict[tuple, object] = {}  # size -> Accumulator (Monte-Carlo models)
        self._ssao_passes: dict[GBufferLayout, object] = {}
        self._splat_passes: dict[GBufferLayout, object] = {}
        # optional per-pass profiler (the viewer's GPU timer queries): .begin(name) between passes
        self.profiler = None

    # ---- scene content ------------------------------------------------------------------------
    def geometry(self, obj: ObjectSpec):
        """CPU geometry for an object: a list of meshes, an image-space G-buffer or a splat cloud
        (:class:`~viewer.geometry.cache.GeometryCache`: loaded once, shared across materials)."""
        return self.geometry_cache.get(obj)

    def add_geometry(self, obj: ObjectSpec, content) -> None:
        """Use ``content`` (as the loaders return it) for ``obj`` instead of loading ``obj.path``:
        geometry made in memory (tests, benchmarks, generated data), taken as given."""
        self.geometry_cache.add(obj, content)

    def _pass_begin(self, name: str | None) -> None:
        """Profiling hook between passes: ``profiler.begin(name)`` ends the previous pass's timer
        and starts ``name``'s (``None`` ends the last). Nothing without a profiler."""
        if self.profiler is not None:
            self.profiler.begin(name)

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
        if not scene.render.specialize:
            return specialise(None, scene.render, aovs, enabled=False, light=scene.light)
        # the analysis scans materials and texture maps: once per scene content, not per frame
        key = (scene.objects, scene.environment.path, scene.environment.procedural)
        if key not in self._features:
            self._features[key] = analyse(self, scene)
        return specialise(self._features[key], scene.render, aovs, light=scene.light)

    def layout_for(self, scene: Scene, aovs=()) -> GBufferLayout:
        return self.specialization(scene, aovs).layout

    def ibl(self, scene: Scene):
        spec = dataclasses.replace(scene.environment, intensity=1.0, rotation_deg=0.0)
        key = (spec, IBLOptions())
        if key not in self._ibl:
            env = load_environment(spec)
            self._ibl[key] = build_ibl(self.programs, env, IBLOptions())
        return self._ibl[key]

    def env_sampling(self, scene: Scene):
        """The environment's importance-sampling distribution (built on the GPU from the IBL's
        radiance texture; cached like the IBL)."""
        spec = dataclasses.replace(scene.environment, intensity=1.0, rotation_deg=0.0)
        key = (spec, IBLOptions())
        if key not in self._env_sampling:
            self._env_sampling[key] = build_env_sampling(self.programs, self.ibl(scene).radiance)
        return self._env_sampling[key]

    def _target_set(self, layout: GBufferLayout, size: tuple[int, int]) -> dict:
        key = (layout, tuple(size))
        if key not in self._targets:
            ctx = self.ctx
            radiance = ctx.texture(size, 4, dtype="f4")
            display = ctx.texture(size, 4, dtype="f1")
            for t in (radiance, display):
                t.filter = (ctx.NEAREST, ctx.NEAREST)
            self._targets[key] = {
                "gbuffer_targets": GBufferTargets.create(ctx, layout, size),
                "radiance": radiance,
                "radiance_fbo": ctx.framebuffer(color_attachments=[radiance]),
                "display": display,
                "display_fbo": ctx.framebuffer(color_attachments=[display]),
            }
        return self._targets[key]

    # ---- rendering --------------------------------------------------------------------------
    def draw(self, scene: Scene, size: tuple[int, int] | None = None, **kwargs) -> FrameTargets:
        """Run every pass on the GPU; no readback. Returns the frame's :class:`FrameTargets`.

        The renderer's context is made current first, so several renderers and contexts can live
        in one process.
        """
        make_current(self.ctx)
        return self._draw(scene, size, **kwargs)

    def _draw(self, scene: Scene, size: tuple[int, int] | None = None, progressive: bool = False,
              samples_per_frame: int = 1, aovs=()) -> FrameTargets:
        """Run every pass on the GPU; no readback. Returns the frame's :class:`FrameTargets`.

        Monte-Carlo models (``ggx_mc``) render ``scene.render.mc.samples`` samples per pixel in
        batches. With ``progressive=True`` a call adds only ``samples_per_frame`` samples to the
        running mean kept since the last call, as long as the scene (except exposure and tone
        mapping) and the size are unchanged (any change restarts), and stops adding once
        ``scene.render.mc.samples`` are in; ``FrameTargets.samples`` is the count accumulated.
        ``aovs``: G-buffer channels the caller will read from ``FrameTargets.gbuffer`` (the layout
        is specialised to the scene, so channels nothing reads are otherwise not allocated).
        """
        settings = scene.render
        model = model_info(settings.model)  # unknown model -> SceneError before any GPU work
        camera = self.resolve_camera(scene, size)
        spec = self.specialization(scene, aovs)
        layout = spec.layout
        targets = self._target_set(layout, camera.size)
        targets["variant"] = spec.variant
        gpass = self._gbuffer_passes.get(layout)
        if gpass is None:
            gpass = self._gbuffer_passes[layout] = GBufferPass(self.programs, layout)
        gb = targets["gbuffer_targets"]
        targets["gbuffer"] = gb
        self._pass_begin("gbuffer")
        direct = spec.direct_stack
        if direct:
            # one image-space stack and nothing else: its uploaded textures already are a
            # G-buffer in this layout, so the lighting pass reads them and no copy pass runs
            stack = self.geometry(scene.objects[0])
            targets["gbuffer"] = gb.viewing(dict(gpass._stack_textures(stack)))
        else:
            gb.clear()
        targets["gbuffer_textures"] = targets["gbuffer"].textures
        meshes, clouds = [], []
        for obj in (() if direct else scene.objects):
            content = self.geometry(obj)
            if obj.type == "gbuffer":
                gpass.draw_image(gb, content)
            elif obj.type == "splats":
                clouds.append(content)
            else:
                meshes.extend(content)
        if meshes:
            gpass.draw_meshes(gb, camera, meshes)
        if clouds:  # after meshes: depth-tested against them, composited over them

            self._pass_begin("splats")
            if layout not in self._splat_passes:
                self._splat_passes[layout] = SplatPass(self.programs, layout)
            self._splat_passes[layout].draw_clouds(gb, camera, clouds)
        spass = self._shade_passes.get(layout)
        if spass is None:
            spass = self._shade_passes[layout] = ShadePass(self.programs, layout)
        self._pass_begin("ibl")  # precomputation, only when the environment is new
        ibl = self.ibl(scene)
        self._shade_frame(scene, model, layout, targets, camera, ibl, spass, progressive,
                          samples_per_frame)
        if self._tonemap is None:
            self._tonemap = TonemapPass(self.programs)
        self._pass_begin("tonemap")
        self._tonemap.run(targets["radiance"], targets["display_fbo"], settings.display.exposure,
                          settings.display.tonemap)
        self._pass_begin(None)
        return FrameTargets(radiance=targets["radiance"], display=targets["display"],
                            gbuffer=targets["gbuffer"], camera=camera, variant=spec.variant,
                            samples=targets["samples"],
                            ssao=targets.get("ssao") if settings.ssao.enabled else None,
                            direct=targets.get("direct") if settings.ssao.indirect else None)

    MC_BATCH = 16  # Monte-Carlo samples per lighting draw (keeps each draw short)

    def _shade_frame(self, scene: Scene, info: ShadingModel, layout: GBufferLayout, targets: dict,
                     camera: Camera, ibl, spass, progressive: bool,
                     samples_per_frame: int) -> None:
        """SSAO -> lighting (accumulated for Monte-Carlo models) -> indirect, into ``radiance``.

        With ``indirect`` the lighting pass writes the direct-lighting buffer ``direct`` of this
        frame, and the indirect pass adds eq. 6.22 gathered from it into ``radiance``.
        """
        settings = scene.render
        if scene.light is not None and info.directional_light == "ignored":
            _warn_light_ignored(settings.model)
        gbt = targets["gbuffer_textures"]
        ssao = None
        if settings.ssao.enabled or settings.ssao.indirect:
            sspass = self._ssao_passes.get(layout)
            if sspass is None:
                sspass = self._ssao_passes[layout] = SSAOPass(self.programs, layout)
        if settings.ssao.enabled:
            self._pass_begin("ssao")
            ssao = self._extra_target(targets, "ssao")
            sspass.occlusion(gbt, targets["ssao_fbo"], camera, settings)
        if settings.ssao.indirect:
            out_tex = self._extra_target(targets, "direct")
            out_fbo = targets["direct_fbo"]
        else:
            out_tex, out_fbo = targets["radiance"], targets["radiance_fbo"]
        env_sampling = self.env_sampling(scene) if "cdf" in info.needs else None
        self._pass_begin("shade")
        if info.accumulates:
            if settings.mc.samples < 1:
                raise SceneError(f"render.samples must be at least 1 for {settings.model}, got "
                                 f"{settings.mc.samples}", where=scene.source or "render.samples")
            acc = self._accumulator(camera.size)
            # exposure and tone mapping act after the running mean: they do not restart it
            display = dataclasses.replace(settings.display, exposure=0.0, tonemap="none")
            key = (dataclasses.replace(scene, render=dataclasses.replace(
                settings, display=display)), camera)
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
                spass.run(gbt, acc.batch_fbo, camera, ibl, scene.environment, settings,
                          env_sampling=env_sampling, ssao=ssao, sample_range=(acc.count, n),
                          variant=targets["variant"], light=scene.light)
                acc.add(n, out_fbo)
                todo -= n
            targets["samples"] = acc.count
        else:
            spass.run(gbt, out_fbo, camera, ibl, scene.environment, settings,
                      env_sampling=env_sampling, ssao=ssao, variant=targets["variant"],
                      light=scene.light)
            targets["samples"] = 1
        if settings.ssao.indirect:
            self._pass_begin("indirect")
            sspass.indirect(gbt, out_tex, targets["radiance_fbo"], camera, settings)

    def _extra_target(self, targets: dict, name: str):
        """An RGBA32F texture ``targets[name]`` (+ ``targets[name + "_fbo"]``) of the set's size,
        made on first use (SSAO and direct-lighting buffers)."""
        if name not in targets:
            ctx = self.ctx
            tex = ctx.texture(targets["radiance"].size, 4, dtype="f4")
            tex.filter = (ctx.NEAREST, ctx.NEAREST)
            targets[name] = tex
            targets[name + "_fbo"] = ctx.framebuffer(color_attachments=[tex])
        return targets[name]

    def _accumulator(self, size: tuple[int, int]):
        key = tuple(size)
        if key not in self._accumulators:
            self._accumulators[key] = Accumulator(self.programs, key)
        return self._accumulators[key]

    def render(self, scene: Scene, aovs: tuple[str, ...] | list[str] = (),
               size: tuple[int, int] | None = None) -> Frame:
        """Render ``scene`` and read back radiance, display pixels and the requested AOVs."""
        make_current(self.ctx)
        return self._render(scene, aovs, size)

    def _render(self, scene: Scene, aovs: tuple[str, ...] | list[str] = (),
                size: tuple[int, int] | None = None) -> Frame:
        """Render ``scene`` and read back radiance, display pixels and the requested AOVs."""
        unknown = [a for a in aovs if a not in AOV_NAMES]
        if unknown:
            raise SceneError(f"unknown AOV {', '.join(map(repr, unknown))} "
                             f"(known: {', '.join(AOV_NAMES)})", where="--aov")
        targets = self._draw(scene, size, aovs=tuple(a for a in aovs if a != "color"))
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
        self._release()
        if self._owns_context:
            self.ctx.release()

    def _release(self) -> None:
        for ibl in self._ibl.values():
            ibl.release()
        for t in self._targets.values():
            t["gbuffer_targets"].release()
            for k in ("radiance", "radiance_fbo", "display", "display_fbo", "ssao", "ssao_fbo",
                      "direct", "direct_fbo"):
                if k in t:
                    t[k].release()
        for obj in (list(self._env_sampling.values()) + list(self._accumulators.values())
                    + list(self._ssao_passes.values())):
            obj.release()
        self._env_sampling.clear()
        self._accumulators.clear()
        self._ssao_passes.clear()
        for p in (list(self._gbuffer_passes.values()) + list(self._shade_passes.values())
                  + list(self._splat_passes.values())):
            p.release()
        self._splat_passes.clear()
        self._ibl.clear()
        self._targets.clear()
        self._gbuffer_passes.clear()
        self._shade_passes.clear()


_LIGHT_WARNED: set[str] = set()


def _warn_light_ignored(model: str) -> None:
    """Once per model and process: ``model`` renders without the scene's directional light."""
    if model not in _LIGHT_WARNED:
        _LIGHT_WARNED.add(model)
        warnings.warn(f"model {model!r} ignores the scene's [light] (trained under environment "
                      f"light only); it is shaded by the environment alone", stacklevel=4)


def read_texture(texture, dtype: str) -> np.ndarray:
    """A texture read back as ``[H, W, C]`` numpy (``"f4"`` float32, ``"f1"`` uint8), row 0 at the
    top (flipped from GL's bottom-up order)."""
    w, h = texture.size
    np_dtype = np.float32 if dtype == "f4" else np.uint8
    arr = np.frombuffer(texture.read(), dtype=np_dtype).reshape(h, w, texture.components)
    return arr[::-1].copy()
