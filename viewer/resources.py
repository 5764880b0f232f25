"""The GPU resources a :class:`~viewer.renderer.Renderer` keeps between frames, cached by value:
render targets per G-buffer layout and size, passes per layout, Monte-Carlo accumulators per size,
and each environment's IBL precomputation and importance-sampling distribution (intensity and
rotation are uniforms, so light sliders never recompute them)."""
from __future__ import annotations

import dataclasses
import numpy as np

from .environment import EnvironmentSpec, load_environment
from .envsampling import build_env_sampling, power_directions
from .gbuffer import GBufferLayout
from .ibl import IBLOptions, build_ibl
from .sun import Sun, extract_sun
from .cache import BoundedCache, Budgets
from .graph.pool import TargetPool
from .passes.accumulate import AccumulatePass
from .passes.forward import ForwardPass
from .passes.gbuffer import GBufferPass
from .passes.shade import ShadePass
from .passes.shadow import ShadowPass
from .passes.splats import SplatPass
from .passes.ssao import SSAOPass
from .passes.tonemap import TonemapPass

# the passes that are built per G-buffer layout
LAYOUT_PASSES = {"gbuffer": GBufferPass, "splats": SplatPass, "ssao": SSAOPass,
                 "shade": ShadePass, "forward": ForwardPass}


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
        self._tonemap: TonemapPass | None = None
        self._accumulate: AccumulatePass | None = None
        self._shadow: ShadowPass | None = None
        self._ibl: dict[tuple, object] = {}
        self._env_sampling: dict[tuple, object] = {}
        self._power_directions: dict[tuple, np.ndarray] = {}
        self._suns: dict[tuple, tuple[np.ndarray, Sun | None]] = {}  # (residual, sun) per env
        self._ibl_sun: dict[tuple, object] = {}  # the IBL without the sun, where there is one
        self._env_arrays: dict[tuple, np.ndarray] = {}  # each environment loaded once

    def layout_pass(self, kind: str, layout: GBufferLayout):
        """The ``kind`` pass (:data:`LAYOUT_PASSES`) built for ``layout``."""
        return self._passes.get_or_create((kind, layout),
                                          lambda: LAYOUT_PASSES[kind](self.programs, layout))

    def passes_stats(self):
        return self._passes.stats()

    def environment_stats(self) -> dict:
        """name -> :class:`~viewer.cache.CacheStats` of the environment caches."""
        from .cache import CacheStats, array_bytes, texture_bytes
        ibls = list(self._ibl.values()) + list(self._ibl_sun.values())
        nbytes = sum(texture_bytes(t) for i in ibls for t in (i.radiance, i.prefiltered))
        nbytes += array_bytes(list(self._env_arrays.values()))
        return {"environments": CacheStats("environments", len(self._ibl), nbytes, None, None,
                                           0, 0, 0)}

    def tonemap(self) -> TonemapPass:
        if self._tonemap is None:
            self._tonemap = TonemapPass(self.programs)
        return self._tonemap

    def shadow_pass(self) -> ShadowPass:
        if self._shadow is None:
            self._shadow = ShadowPass(self.programs)
        return self._shadow

    def accumulate_pass(self) -> AccumulatePass:
        if self._accumulate is None:
            self._accumulate = AccumulatePass(self.programs)
        return self._accumulate

    @staticmethod
    def _environment_key(spec: EnvironmentSpec) -> tuple:
        # intensity and rotation are uniforms: one precomputation serves every value of them
        return (dataclasses.replace(spec, intensity=1.0, rotation_deg=0.0), IBLOptions())

    def _environment(self, key: tuple) -> np.ndarray:
        """The loaded environment of ``key`` (one file read, one warning, per environment)."""
        if key not in self._env_arrays:
            self._env_arrays[key] = load_environment(key[0])
        return self._env_arrays[key]

    def ibl(self, spec: EnvironmentSpec, sun: bool = False):
        """The environment's IBL. ``sun=True``: the one whose prefiltered levels >= 1 and SH
        leave out the environment's sun (:func:`viewer.sun.extract_sun`), for passes that shade it
        analytically (``SUN_LIGHT``); the plain IBL when the environment has no sun."""
        key = self._environment_key(spec)
        if sun and self.sun(spec) is not None:
            if key not in self._ibl_sun:
                residual, found = self._suns[key]
                ibl = build_ibl(self.programs, self._environment(key), key[1], sun=found,
                                residual=residual)
                ibl.full_prefiltered = self.ibl(spec).prefiltered  # owned by the plain IBL
                self._ibl_sun[key] = ibl
            return self._ibl_sun[key]
        if key not in self._ibl:
            self._ibl[key] = build_ibl(self.programs, self._environment(key), key[1])
        return self._ibl[key]

    def sun(self, spec: EnvironmentSpec) -> Sun | None:
        """The environment's compact sun (:func:`viewer.sun.extract_sun`), or None; computed once
        on the CPU from the loaded image."""
        key = self._environment_key(spec)
        if key not in self._suns:
            self._suns[key] = extract_sun(self._environment(key))
        return self._suns[key][1]

    def env_sampling(self, spec: EnvironmentSpec):
        """The environment's importance-sampling distribution, built on the GPU from the IBL's
        radiance texture."""
        key = self._environment_key(spec)
        if key not in self._env_sampling:
            self._env_sampling[key] = build_env_sampling(self.programs, self.ibl(spec).radiance)
        return self._env_sampling[key]

    def power_directions(self, spec: EnvironmentSpec) -> np.ndarray:
        """The environment's equal-power directions (:func:`viewer.envsampling.power_directions`,
        environment frame), computed once on the CPU from the loaded image."""
        key = self._environment_key(spec)
        if key not in self._power_directions:
            self._power_directions[key] = power_directions(self._environment(key))
        return self._power_directions[key]

    @property
    def environments(self) -> int:
        """How many environments have an IBL precomputation cached."""
        return len(self._ibl)

    def release(self) -> None:
        self.pool.clear()
        self._passes.clear()
        for obj in (list(self._ibl.values()) + list(self._ibl_sun.values())
                    + list(self._env_sampling.values())
                    + [p for p in (self._tonemap, self._accumulate, self._shadow)
                       if p is not None]):
            obj.release()
        for d in (self._ibl, self._ibl_sun, self._env_sampling, self._power_directions,
                  self._suns, self._env_arrays):
            d.clear()
        self._tonemap = self._accumulate = self._shadow = None
