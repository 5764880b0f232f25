"""The GPU resources a :class:`~viewer.renderer.Renderer` keeps between frames, each bounded: the
render-target pool of the frame graph (:class:`viewer.graph.pool.TargetPool`, by bytes and age),
the passes per G-buffer layout (by count), and the environments (:class:`viewer.environment.store.
EnvironmentStore`, by bytes: loaded maps, prefiltered chains, suns, sampling tables; intensity and
rotation are uniforms, so light sliders never recompute them)."""
from __future__ import annotations

import numpy as np

from .cache import BoundedCache, Budgets, CacheStats
from .environment.maps import EnvironmentSpec
from .environment.store import EnvironmentStore
from .environment.sun import Sun
from .gbuffer import GBufferLayout
from .graph.pool import TargetPool
from .passes.accumulate import AccumulatePass
from .passes.antialias import AntialiasPass
from .passes.forward import ForwardPass
from .passes.rt_light import RTLightPass
from .passes.gbuffer import GBufferPass
from .passes.shade import ShadePass
from .passes.shadow import ShadowPass
from .passes.shadow_net import ShadowNetPass
from .passes.splats import SplatPass
from .passes.ssao import SSAOPass
from .passes.tonemap import TonemapPass
from .raytrace.upload import TraceStore

# the passes that are built per G-buffer layout
LAYOUT_PASSES = {"gbuffer": GBufferPass, "splats": SplatPass, "ssao": SSAOPass,
                 "shade": ShadePass, "forward": ForwardPass, "rt_light": RTLightPass,
                 "shadow_net": ShadowNetPass}


class GPUResources:
    """Everything the renderer keeps on the GPU between frames; see the module docstring."""

    def __init__(self, programs, budgets: Budgets = Budgets()):
        self.programs = programs
        self.budgets = budgets
        # every render target of every frame (viewer.graph.pool), bounded by bytes and age
        self.pool = TargetPool(programs.ctx, max_bytes=budgets.targets_bytes,
                               max_age=budgets.target_max_age)
        # (kind, layout) -> pass: a few per layout, each owning vertex arrays and uploads
        self._passes = BoundedCache("passes", max_items=4 * len(LAYOUT_PASSES),
                                    release=lambda p: p.release())
        # environments by bytes (and the user's disk cache: viewer.environment.disk_cache)
        self.env = EnvironmentStore(programs, budgets.environment_bytes)
        # traced scenes (BVH and triangle buffers) by the meshes they hold, by bytes
        self.trace = TraceStore(programs.ctx, budgets.raytrace_bytes)
        self._tonemap: TonemapPass | None = None
        self._accumulate: AccumulatePass | None = None
        self._shadow: ShadowPass | None = None
        self._antialias: AntialiasPass | None = None

    def layout_pass(self, kind: str, layout: GBufferLayout):
        """The ``kind`` pass (:data:`LAYOUT_PASSES`) built for ``layout``."""
        return self._passes.get_or_create((kind, layout),
                                          lambda: LAYOUT_PASSES[kind](self.programs, layout))

    def passes_stats(self) -> CacheStats:
        return self._passes.stats()

    def environment_stats(self) -> dict[str, CacheStats]:
        """name -> :class:`~viewer.cache.CacheStats` of the environment store."""
        return {"environments": self.env.stats()}

    def tonemap(self) -> TonemapPass:
        if self._tonemap is None:
            self._tonemap = TonemapPass(self.programs)
        return self._tonemap

    def antialias(self) -> AntialiasPass:
        if self._antialias is None:
            self._antialias = AntialiasPass(self.programs)
        return self._antialias

    def shadow_pass(self) -> ShadowPass:
        if self._shadow is None:
            self._shadow = ShadowPass(self.programs)
        return self._shadow

    def accumulate_pass(self) -> AccumulatePass:
        if self._accumulate is None:
            self._accumulate = AccumulatePass(self.programs)
        return self._accumulate

    # ---- environments (viewer.environment.store.EnvironmentStore) ------------------------------------
    def ibl(self, spec: EnvironmentSpec, sun: bool = False):
        """The environment's IBL; ``sun=True``: the one without its sun (SUN_LIGHT passes)."""
        return self.env.ibl(spec, sun=sun)

    def sun(self, spec: EnvironmentSpec) -> Sun | None:
        """The environment's compact sun (:func:`viewer.environment.sun.extract_sun`), or None."""
        return self.env.sun(spec)

    def env_lights(self, spec: EnvironmentSpec) -> tuple[Sun, ...]:
        """The environment's compact lights (:func:`viewer.environment.sun.extract_lights`), the sun first."""
        return self.env.lights(spec)

    def env_sampling(self, spec: EnvironmentSpec):
        """The environment's importance-sampling distribution."""
        return self.env.env_sampling(spec)

    def power_directions(self, spec: EnvironmentSpec) -> np.ndarray:
        """The environment's equal-power directions (environment frame)."""
        return self.env.power_directions(spec)

    def env_shadow_lights(self, spec: EnvironmentSpec, count: int, sunless: bool):
        """The environment's shadow directions (:meth:`EnvironmentStore.shadow_lights`)."""
        return self.env.shadow_lights(spec, count, sunless)

    @property
    def environments(self) -> int:
        """How many environments the store holds."""
        return self.env.environments

    def release(self) -> None:
        self.pool.clear()
        self._passes.clear()
        self.env.release()
        self.trace.release()
        for p in (self._tonemap, self._accumulate, self._shadow, self._antialias):
            if p is not None:
                p.release()
        self._tonemap = self._accumulate = self._shadow = self._antialias = None
