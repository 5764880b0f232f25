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

A frame is a frame graph (:mod:`viewer.graph`): :meth:`Renderer.draw` declares the passes the
scene's specialisation needs (:func:`viewer.graph.frame.build_frame`), and the graph culls, reuses
and allocates. A pass whose declared inputs did not change since the last frame at the same size
and layout is not drawn again (``Renderer.reuse_passes``, on by default): a light, exposure or
environment-intensity slider re-runs only what depends on it. ``with renderer.every_pass():``
draws every pass (the benchmarks' whole frames). ``relight graph SCENE`` prints the graph.

Every GPU resource is cached with a bound (:class:`viewer.cache.Budgets`): render targets in a
pool by bytes and age, programs by count, environments and geometry by bytes.
:meth:`Renderer.memory` reports each cache. Arrays are row 0 at the top.
"""
from __future__ import annotations

import dataclasses
import warnings
from contextlib import contextmanager

from .cache import BoundedCache, Budgets, CacheStats
from .errors import SceneError
from .frame import (Frame, FrameTargets, check_aovs, check_frame_size, is_shadow_aov,
                    read_frame)
from .gbuffer import GBufferLayout
from .geometry.cache import GeometryCache
from .gl import ContextOptions, Programs, create_context, make_current
from .graph.display import output_radiance, ssaa_factor
from .graph.frame import FrameRequest, build_frame, visibility_graph
from .graph.graph import FrameGraph
from .lighting.lights import gather_lights
from .models import contact_shadows, ignored_lobes, ignored_settings, model_info, sample_count
from .neural import required_settings, shades_sun
from .passes.ground import CATCHER_CHANNELS, scene_catcher
from .resources import GPUResources
from .scene.bounds import scene_bounds
from .scene.camera import Camera
from .scene.description import ObjectSpec, Scene
from .specialize import analyse, specialise

__all__ = ["Frame", "FrameTargets", "Renderer"]


class Renderer:
    """Owns one GL context and every GPU resource derived from scenes rendered with it."""

    def __init__(self, ctx=None, options: ContextOptions = ContextOptions(),
                 budgets: Budgets = Budgets()):
        self._owns_context = ctx is None
        self.ctx = ctx if ctx is not None else create_context(options)
        self.budgets = budgets
        self.programs = Programs(self.ctx, max_items=budgets.programs)  # compiled, by count
        # loaded geometry and its uploads, by bytes
        self.geometry_cache = GeometryCache(max_bytes=budgets.geometry_bytes)
        self.resources = GPUResources(self.programs, budgets)  # targets, passes, environments
        # (objects, environment) -> SceneFeatures: the analysis scans materials and texture maps
        self._features = BoundedCache("features", max_items=64)
        self._bounds = BoundedCache("bounds", max_items=64)  # scene content -> Bounds
        self.last_graph: FrameGraph | None = None  # the last frame's compiled graph
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
        scene = gather_lights(scene, self.geometry)  # + the meshes' own lights
        if scene_catcher(scene.objects) is not None:  # it finds its pixels by depth and normal
            aovs = tuple(aovs) + CATCHER_CHANNELS
        # a sun to shade analytically (SUN_LIGHT): only looked for where the model can use it
        # (a classical model that does, or a student whose base does: viewer.neural.shades_sun)
        # (the count of the environment's compact lights: the sun and the others, ENV_LIGHTS)
        sun = len(self.resources.env_lights(scene.environment)) \
            if ((model_info(scene.render.model).analytic_sun or shades_sun(scene.render))
                and scene.render.sun) else 0
        contact = contact_shadows(scene.render, any(o.type == "gbuffer" for o in scene.objects))
        if not scene.render.specialize:
            return specialise(None, scene.render, aovs, enabled=False, light=scene.light,
                              sun=sun, contact=contact)
        # the analysis scans materials and texture maps: once per scene content, not per frame
        key = (scene.objects, scene.environment.path, scene.environment.procedural)
        features = self._features.get_or_create(key, lambda: analyse(self, scene))
        return specialise(features, scene.render, aovs, light=scene.light, sun=sun,
                          contact=contact)

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
        normals are allocated): r = O(x), g = S(x), as a student with ``vis`` inputs reads them.
        Drawn into a target of its own (valid until the next call): for training data, tests and
        parity checks."""
        make_current(self.ctx)
        with self._frame(scene):
            spec = self.specialization(scene)
            graph = visibility_graph(self, scene, spec, frame)
            return graph.compile().execute()["ssao"].texture

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
        with self._frame(scene):
            return self._draw(scene, size, progressive, samples_per_frame, aovs)

    @contextmanager
    def _frame(self, scene: Scene):
        """Nothing a frame looks up (programs, geometry, its environment) is evicted before the
        frame ends."""
        with self.programs.frame(), self.geometry_cache.frame(), \
                self.resources.env.pinned(scene.environment):
            yield

    def _draw(self, scene, size, progressive, samples_per_frame, aovs) -> FrameTargets:
        model = model_info(scene.render.model)  # unknown model -> SceneError before any GPU work
        asked, settings = scene.render, required_settings(scene.render)  # + a network's needs
        if settings is not scene.render:
            scene = dataclasses.replace(scene, render=settings)
        if model.accumulates and sample_count(settings) < 1:
            raise SceneError(f"render.samples must be at least 1 for {settings.model}, got "
                             f"{settings.mc.samples}", where=scene.source or "render.samples")
        scene = gather_lights(scene, self.geometry)  # + the meshes' own lights
        if scene.light is not None and model.lights == "ignored":
            _warn_light_ignored(settings.model)
        camera = self.resolve_camera(scene, size)
        spec = self.specialization(scene, aovs)
        for lobe, message in ignored_lobes(model, self.specialization(  # what the scene has
                scene.with_render(specialize=True), aovs).layout):
            _warn_once(f"{lobe}:{settings.model}", message)
        check_frame_size(self.ctx, scene, camera, spec.layout, ssaa_factor(scene),
                         "--size" if size else None)
        self._pass_begin("ibl")  # precomputation, only when the environment is new
        request = FrameRequest(scene, model, spec, camera, progressive, samples_per_frame)
        graph = build_frame(self, request, reuse=self.reuse_passes).compile()
        for key, message in ignored_settings(model, asked, settings, spec.variant, graph):
            _warn_once(key, message)
        frame = graph.execute(on_pass=self._pass_begin)
        self.last_graph = graph
        return FrameTargets(
            radiance=frame[output_radiance(scene)].texture, display=frame["display"].texture,
            gbuffer=frame["gbuffer"], camera=camera, variant=spec.variant, samples=frame.samples,
            # rays stand in for SSAO and its bounce (RT_LIGHT): those targets then do not exist
            ssao=frame["ssao"].texture if "ssao" in graph.resources else None,
            direct=frame["direct"].texture if "direct" in graph.resources else None,
            indirect_factor=(frame["indirect_factor"].texture
                             if "indirect_factor" in graph.resources else None),
            targets={n: frame[n] for n, r in graph.resources.items() if r.kept})

    def blended(self, scene: Scene) -> list:
        """The scene's transparent meshes (glTF ``alphaMode: BLEND``), in file order."""
        return [m for obj in scene.objects
                if obj.type not in ("gbuffer", "splats") and not obj.shadow_only
                for m in self.geometry(obj) if m.alpha_mode == "BLEND"]

    def graph(self, scene: Scene, size: tuple[int, int] | None = None, aovs=()) -> FrameGraph:
        """The compiled frame graph :meth:`draw` would run for ``scene`` now (nothing drawn):
        what each pass reads and writes, whether it would be reused and why, what is culled."""
        make_current(self.ctx)
        settings = required_settings(scene.render)
        if settings is not scene.render:
            scene = dataclasses.replace(scene, render=settings)
        scene = gather_lights(scene, self.geometry)
        request = FrameRequest(scene, model_info(settings.model), self.specialization(scene, aovs),
                               self.resolve_camera(scene, size))
        return build_frame(self, request, reuse=self.reuse_passes).compile()

    def bounds(self, scene: Scene):
        """World bounds of what ``scene`` contains (:func:`viewer.scene.bounds.scene_bounds`; robust
        for splats), cached per scene content; None for image stacks alone."""
        key = (scene.objects, self.geometry_cache.version)
        return self._bounds.get_or_create(key, lambda: scene_bounds(self, scene))

    def memory(self) -> dict[str, CacheStats]:
        """Bytes and entries of every cache this renderer keeps (name -> stats)."""
        out = {"targets": self.resources.pool.stats(), "passes": self.resources.passes_stats(),
               "programs": self.programs.stats(), "geometry": self.geometry_cache.stats(),
               "traced scenes": self.resources.trace.stats()}
        out.update(self.resources.environment_stats())
        return out

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
        targets = self.draw(scene, size, aovs=tuple(a for a in aovs
                                                    if a != "color" and not is_shadow_aov(a)))
        return read_frame(targets, aovs, ssaa_factor(scene))

    def release(self) -> None:
        """Free every GPU resource (and the context, if this renderer created it)."""
        make_current(self.ctx)
        self.resources.release()
        self.geometry_cache.clear()
        self.programs.release()
        if self._owns_context:
            self.ctx.release()


_LIGHT_WARNED: set[str] = set()


def _warn_once(key: str, message: str) -> None:
    """Once per ``key`` and process."""
    if key not in _LIGHT_WARNED:
        _LIGHT_WARNED.add(key)
        warnings.warn(message, stacklevel=4)


def _warn_light_ignored(model: str) -> None:
    """Once per model and process: ``model`` renders without the scene's lights."""
    if model not in _LIGHT_WARNED:
        _LIGHT_WARNED.add(model)
        warnings.warn(f"model {model!r} ignores the scene's lights (trained under environment "
                      f"light only); it is shaded by the environment alone", stacklevel=4)
