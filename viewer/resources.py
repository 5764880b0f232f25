"""The GPU resources a :class:`~viewer.renderer.Renderer` keeps between frames, cached by value:
render targets per G-buffer layout and size, passes per layout, Monte-Carlo accumulators per size,
and each environment's IBL precomputation and importance-sampling distribution (intensity and
rotation are uniforms, so light sliders never recompute them)."""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field

import numpy as np

from .environment import EnvironmentSpec, load_environment
from .envsampling import build_env_sampling, power_directions
from .gbuffer import GBufferLayout
from .ibl import IBLOptions, build_ibl
from .sun import Sun, extract_sun
from .passes.accumulate import Accumulator
from .passes.forward import ForwardPass
from .passes.gbuffer import GBufferPass, GBufferTargets
from .passes.shade import ShadePass
from .passes.splats import SplatPass
from .passes.ssao import SSAOPass
from .passes.tonemap import TonemapPass

# the passes that are built per G-buffer layout
LAYOUT_PASSES = {"gbuffer": GBufferPass, "splats": SplatPass, "ssao": SSAOPass,
                 "shade": ShadePass, "forward": ForwardPass}


@dataclass
class TargetSet:
    """The render targets of one layout and size: the G-buffer, linear radiance (RGBA32F) and the
    display image (RGBA8), plus extra targets made on first use (``ssao``, ``direct``, SSAO's hit
    targets ``ssao_hits<i>``)."""

    gbuffer: GBufferTargets
    radiance: object
    radiance_fbo: object
    display: object
    display_fbo: object
    extras: dict[str, tuple[object, object]] = field(default_factory=dict)  # name -> (tex, fbo)
    # attachment names -> a framebuffer drawing to several extras at once (multiple render targets)
    multi: dict[tuple, object] = field(default_factory=dict)
    # what the G-buffer and the SSAO targets were last drawn from (viewer.renderer: a frame whose
    # key is unchanged reuses them instead of drawing again)
    keys: dict[str, tuple] = field(default_factory=dict)

    @classmethod
    def create(cls, ctx, layout: GBufferLayout, size: tuple[int, int]) -> "TargetSet":
        radiance = ctx.texture(size, 4, dtype="f4")
        display = ctx.texture(size, 4, dtype="f1")
        for t in (radiance, display):
            t.filter = (ctx.NEAREST, ctx.NEAREST)
        return cls(GBufferTargets.create(ctx, layout, size), radiance,
                   ctx.framebuffer(color_attachments=[radiance]), display,
                   ctx.framebuffer(color_attachments=[display]))

    def extra(self, ctx, name: str, components: int = 4, dtype: str = "f4", size=None
              ) -> tuple[object, object]:
        """``(texture, framebuffer)`` of the target ``name`` with ``components`` channels of
        ``dtype`` (RGBA32F by default; ``"u4"``: unsigned integers, e.g. SSAO's ray hits; made on
        first use), of ``size`` (default the frame's: SSAO at reduced scale has smaller ones)."""
        if name not in self.extras:
            tex = ctx.texture(tuple(size or self.radiance.size), components, dtype=dtype)
            tex.filter = (ctx.NEAREST, ctx.NEAREST)
            self.extras[name] = (tex, ctx.framebuffer(color_attachments=[tex]))
        return self.extras[name]

    def extras_fbo(self, ctx, names: tuple[str, ...]):
        """A framebuffer with the extras ``names`` (made first with :meth:`extra`) as colour
        attachments 0, 1, ...: a pass with several outputs draws to them at once."""
        if names not in self.multi:
            self.multi[names] = ctx.framebuffer(
                color_attachments=[self.extras[n][0] for n in names])
        return self.multi[names]

    def release(self) -> None:
        self.gbuffer.release()
        for obj in (self.radiance, self.radiance_fbo, self.display, self.display_fbo):
            obj.release()
        for fbo in self.multi.values():
            fbo.release()
        self.multi.clear()
        for tex, fbo in self.extras.values():
            tex.release()
            fbo.release()
        self.extras.clear()


class GPUResources:
    """Everything the renderer keeps on the GPU between frames; see the module docstring."""

    def __init__(self, programs):
        self.programs = programs
        self._targets: dict[tuple, TargetSet] = {}
        self._passes: dict[tuple, object] = {}  # (kind, layout) -> pass
        self._tonemap: TonemapPass | None = None
        self._accumulators: dict[tuple, Accumulator] = {}
        self._ibl: dict[tuple, object] = {}
        self._env_sampling: dict[tuple, object] = {}
        self._power_directions: dict[tuple, np.ndarray] = {}
        self._suns: dict[tuple, tuple[np.ndarray, Sun | None]] = {}  # (residual, sun) per env
        self._ibl_sun: dict[tuple, object] = {}  # the IBL without the sun, where there is one
        self._env_arrays: dict[tuple, np.ndarray] = {}  # each environment loaded once

    def targets(self, layout: GBufferLayout, size: tuple[int, int]) -> TargetSet:
        key = (layout, tuple(size))
        if key not in self._targets:
            self._targets[key] = TargetSet.create(self.programs.ctx, layout, size)
        return self._targets[key]

    def layout_pass(self, kind: str, layout: GBufferLayout):
        """The ``kind`` pass (:data:`LAYOUT_PASSES`) built for ``layout``."""
        key = (kind, layout)
        if key not in self._passes:
            self._passes[key] = LAYOUT_PASSES[kind](self.programs, layout)
        return self._passes[key]

    def tonemap(self) -> TonemapPass:
        if self._tonemap is None:
            self._tonemap = TonemapPass(self.programs)
        return self._tonemap

    def accumulator(self, size: tuple[int, int]) -> Accumulator:
        key = tuple(size)
        if key not in self._accumulators:
            self._accumulators[key] = Accumulator(self.programs, key)
        return self._accumulators[key]

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
        for obj in (list(self._ibl.values()) + list(self._ibl_sun.values())
                    + list(self._targets.values())
                    + list(self._env_sampling.values()) + list(self._accumulators.values())
                    + list(self._passes.values())
                    + ([self._tonemap] if self._tonemap is not None else [])):
            obj.release()
        for d in (self._ibl, self._ibl_sun, self._targets, self._env_sampling, self._accumulators,
                  self._passes, self._power_directions, self._suns, self._env_arrays):
            d.clear()
        self._tonemap = None
