"""Screen-space ambient occlusion and one-bounce indirect light (``passes/ssao.frag``; thesis
eqs. 6.19-6.22).

:meth:`SSAOPass.occlusion` writes the visibility O(x) of every pixel to an RGBA32F texture that the
lighting passes multiply into their diffuse term (``USE_SSAO``); :meth:`SSAOPass.indirect` adds the
diffuse one-bounce light gathered from the direct-lighting buffer (the lighting pass's output for
this frame) at each ray's hit pixel, scaled per pixel by a factor texture when a neural student
learned one (``SSAO_INDIRECT_FACTOR``). The rays are marched once per frame when both run: with
``record_hits`` the occlusion pass also writes each ray's hit pixel to :func:`hit_targets` RGBA32UI
targets (``SSAO_HITS``), and the indirect pass given them reads the hits instead of marching the
same rays again (the same light, bit for bit; it marches only rays beyond
:data:`HIT_TARGETS_MAX` targets, and all of them without the occlusion pass). With ``vis_dirs`` (the
environment's :func:`~viewer.environment.sampling.power_directions`) the occlusion pass also writes the
screen-space visibility of the environment's light to the g channel (``SSAO_ENV_VIS``), the input
of the students that see visibility; it marches :data:`ENV_VIS_STEPS` steps up to
:data:`ENV_VIS_RADIUS` towards each of the :data:`ENV_VIS_DIRECTIONS` directions. These are
constants, not settings: a student is trained on what they produce.

At reduced scale (``settings.ssao.scale`` = k > 1, TOML ``ssao_scale``) the rays are marched for
one pixel in k x k (:func:`low_resolution` targets, ``SSAO_SCALE``): :meth:`SSAOPass.occlusion`
draws the low-resolution target and :meth:`SSAOPass.upsample` (``passes/ssao_upsample.frag``)
brings it to full resolution with a depth- and normal-aware (joint bilateral) filter;
:meth:`SSAOPass.indirect` gathers the one-bounce light at low resolution (``SSAO_GATHER``) and
composites it at full resolution with each pixel's own albedo. Cost falls with k^2; the error it
adds is measured by ``relight bench`` (the ``ssao_scale`` knob).
"""
from __future__ import annotations

import math

import numpy as np

from ..gbuffer import GBufferLayout
from ..scene.camera import Camera
from ..scene.settings import RenderSettings
from . import FullscreenDraw, bind_gbuffer, set_deferred_camera
from . import set_uniform as _set
from .ground import ground_center

ENV_VIS_DIRECTIONS = 8  # ENV_VIS_DIRS of passes/ssao.frag
ENV_VIS_STEPS = 16  # steps per direction
ENV_VIS_RADIUS = 2.0  # world units: long enough for a sun shadow of a unit-sized object
# RGBA32UI hit targets beside O(x) (attachment 0): GL 4.3 guarantees 8 draw buffers; 4 rays each
HIT_TARGETS_MAX = 7
HITS_PER_TARGET = 4


def low_resolution(size: tuple[int, int], scale: int) -> tuple[int, int]:
    """The size of the reduced-scale targets for a frame of ``size`` at ``scale``: ceil(W / k) x
    ceil(H / k) (the last texels' sample pixels are clamped to the frame)."""
    k = max(int(scale), 1)
    return (-(-int(size[0]) // k), -(-int(size[1]) // k))


def hit_targets(rays: int) -> int:
    """How many RGBA32UI targets hold the hits of ``rays`` rays (``SSAO_HITS``): 4 rays per
    target, at most :data:`HIT_TARGETS_MAX` (the indirect pass marches the rays beyond)."""
    return min(-(-max(int(rays), 0) // HITS_PER_TARGET), HIT_TARGETS_MAX)


def denoised(settings: RenderSettings) -> bool:
    """Whether the indirect light's gathered E goes through the bilateral blur before it is added
    (``indirect_blur`` at scale 1; at k > 1 the upsampling filters it)."""
    return bool(settings.ssao.indirect_blur) and int(settings.ssao.scale) == 1


def staged(settings: RenderSettings) -> bool:
    """Whether the indirect light is gather then composite (reduced scale, or denoised) rather
    than one pass."""
    return int(settings.ssao.scale) > 1 or denoised(settings)


class SSAOPass:
    def __init__(self, programs, layout: GBufferLayout):
        self.programs = programs
        self.ctx = programs.ctx
        self.layout = layout
        self._draw = FullscreenDraw(self.ctx)

    def _run(self, indirect: bool, gbuffer_textures: dict, out_fbo, camera: Camera,
             settings: RenderSettings, direct=None, vis_dirs=None, env_rotation_deg=0.0,
             factor=None, n_hits: int = 0, hits=(), gather: bool = False,
             gathered=None, ground=None) -> None:
        env_vis = vis_dirs is not None
        scale = int(settings.ssao.scale)
        composite = gathered is not None
        prog = self.programs.graphics("passes/fullscreen.vert", "passes/ssao.frag",
                                      defines={"SSAO_INDIRECT": int(indirect),
                                               "SSAO_ENV_VIS": int(env_vis),
                                               "SSAO_INDIRECT_FACTOR": int(factor is not None),
                                               "SSAO_HITS": n_hits,
                                               # the indirect pass marches rays beyond the hits
                                               "SSAO_MARCH_REST": int(
                                                   indirect and not composite
                                                   and 0 < n_hits * HITS_PER_TARGET
                                                   < settings.ssao.rays),
                                               "SSAO_SCALE": scale,
                                               "SSAO_GATHER": int(gather),
                                               "SSAO_COMPOSITE": int(composite),
                                               "BACKGROUND_ENVIRONMENT": 0},
                                      virtual=self.layout.virtual_files())
        unit = bind_gbuffer(prog, gbuffer_textures)
        for name, tex in (("u_direct", direct), ("u_gathered", gathered)):
            if tex is not None and name in prog:
                tex.use(unit)
                prog[name].value = unit
                unit += 1
        if factor is not None:
            factor.use(unit)
            prog["u_indirect_factor"].value = unit
            unit += 1
        if hits:
            for i, tex in enumerate(hits):
                tex.use(unit + i)
            _set(prog, "u_hits", np.arange(unit, unit + len(hits), dtype=np.int32).tobytes())
            unit += len(hits)
        set_deferred_camera(prog, camera)
        _set(prog, "u_ground_center", ground_center(ground, camera))  # no bounce on the catcher
        _set(prog, "u_rays", int(settings.ssao.rays))
        _set(prog, "u_steps", int(settings.ssao.steps))
        _set(prog, "u_radius", float(settings.ssao.radius))
        _set(prog, "u_thickness", float(settings.ssao.thickness))
        _set(prog, "u_seed", int(settings.mc.seed))
        if env_vis:
            dirs = np.ascontiguousarray(vis_dirs, np.float32).reshape(ENV_VIS_DIRECTIONS, 3)
            prog["u_vis_dirs"].write(dirs.tobytes())
            _set(prog, "u_vis_steps", ENV_VIS_STEPS)
            _set(prog, "u_vis_radius", ENV_VIS_RADIUS)
            _set(prog, "u_env_rotation", math.radians(env_rotation_deg))
        out_fbo.use()
        self.ctx.viewport = (0, 0) + tuple(out_fbo.size)  # low resolution at reduced scale
        self._draw(prog)

    def occlusion(self, gbuffer_textures: dict, out_fbo, camera: Camera,
                  settings: RenderSettings, vis_dirs=None, env_rotation_deg: float = 0.0,
                  record_hits: bool = False) -> None:
        """O(x) (eq. 6.19) into all four channels of ``out_fbo``'s first attachment (1 on the
        background); with ``vis_dirs`` (``[8, 3]``, environment frame) S(x) in the g channel
        instead. With ``record_hits`` ``out_fbo`` has ``hit_targets(settings.ssao.rays)`` RGBA32UI
        attachments after it, which receive each ray's hit pixel for :meth:`indirect`. At
        ``settings.ssao.scale`` k > 1 ``out_fbo`` is :func:`low_resolution` (one texel per k x k
        block of the frame; :meth:`upsample` brings O and S to full resolution)."""
        self._run(False, gbuffer_textures, out_fbo, camera, settings, vis_dirs=vis_dirs,
                  env_rotation_deg=env_rotation_deg,
                  n_hits=hit_targets(settings.ssao.rays) if record_hits else 0)

    def upsample(self, gbuffer_textures: dict, low, out_fbo, camera: Camera,
                 settings: RenderSettings) -> None:
        """The occlusion pass's low-resolution result ``low`` (scale k > 1) to full resolution
        in ``out_fbo`` (``passes/ssao_upsample.frag``: joint bilateral, 1 on the background)."""
        self._filter("passes/ssao_upsample.frag", {"SSAO_SCALE": int(settings.ssao.scale)},
                     gbuffer_textures, low, "u_low", out_fbo, camera)

    def blur(self, gbuffer_textures: dict, ao, out_fbo, camera: Camera, env_vis: bool) -> None:
        """The full-resolution occlusion ``ao`` through the bilateral blur into ``out_fbo``
        (``passes/ssao_blur.frag``; ``env_vis``: the g channel, S(x), passed through)."""
        self._filter("passes/ssao_blur.frag", {"SSAO_ENV_VIS": int(env_vis)}, gbuffer_textures,
                     ao, "u_ao", out_fbo, camera)

    def _filter(self, frag: str, defines: dict, gbuffer_textures: dict, source, uniform: str,
                out_fbo, camera: Camera) -> None:
        """A full-resolution pass of ``frag`` over the G-buffer and the occlusion ``source``
        (bound as ``uniform``) into ``out_fbo``: the upsample and the blur."""
        prog = self.programs.graphics("passes/fullscreen.vert", frag,
                                      defines={**defines, "BACKGROUND_ENVIRONMENT": 0},
                                      virtual=self.layout.virtual_files())
        unit = bind_gbuffer(prog, gbuffer_textures)
        source.use(unit)
        prog[uniform].value = unit
        set_deferred_camera(prog, camera)
        out_fbo.use()
        self.ctx.viewport = (0, 0, camera.width, camera.height)
        self._draw(prog)

    def indirect(self, gbuffer_textures: dict, direct, out_fbo, camera: Camera,
                 settings: RenderSettings, factor=None, hits=None, gather_fbo=None,
                 ground=None) -> None:
        """``direct`` (RGBA32F texture, L_dir) plus L_ind of eq. 6.22 into ``out_fbo``; with
        ``factor`` (a texture, r channel: a neural student's learned factor) f L_ind. ``hits``:
        the hit targets :meth:`occlusion` recorded for the same G-buffer, camera and settings
        (read instead of marching the rays again); ``None`` marches. At ``settings.ssao.scale``
        k > 1 this is :meth:`gather` into ``gather_fbo`` (one RGBA32F target of
        :func:`low_resolution`) then :meth:`composite`. With ``indirect_blur`` (:func:`denoised`)
        the frame graph runs :meth:`gather`, :meth:`blur` and :meth:`composite` itself (a
        ``ValueError`` here). ``ground``: the scene's shadow catcher
        (:func:`viewer.passes.ground.scene_catcher`), which gets no bounce light."""
        hits = self._check_hits(hits, settings)
        if denoised(settings):
            raise ValueError("indirect_blur: the indirect light is gathered, blurred and "
                             "composited as three passes of the frame (viewer/graph/frame.py)")
        if int(settings.ssao.scale) == 1:
            self._run(True, gbuffer_textures, out_fbo, camera, settings, direct=direct,
                      factor=factor, n_hits=len(hits), hits=hits, ground=ground)
            return
        if gather_fbo is None:
            raise ValueError(f"ssao scale {settings.ssao.scale}: the indirect light needs a "
                             f"low-resolution gather target")
        self.gather(gbuffer_textures, direct, gather_fbo, camera, settings, hits=hits)
        self.composite(gbuffer_textures, direct, out_fbo, camera, settings,
                       gather_fbo.color_attachments[0], factor=factor, ground=ground)

    def gather(self, gbuffer_textures: dict, direct, gather_fbo, camera: Camera,
               settings: RenderSettings, hits=None) -> None:
        """At scale k > 1: the one-bounce light E gathered at low resolution into
        ``gather_fbo`` (from ``hits``, low resolution too, or marching the rays)."""
        hits = self._check_hits(hits, settings)
        self._run(True, gbuffer_textures, gather_fbo, camera, settings, direct=direct,
                  n_hits=len(hits), hits=hits, gather=True)

    def composite(self, gbuffer_textures: dict, direct, out_fbo, camera: Camera,
                  settings: RenderSettings, gathered, factor=None, ground=None) -> None:
        """At scale k > 1: ``direct`` + (1 - m) a f E into ``out_fbo``, with E the
        :meth:`gather` result ``gathered`` upsampled to full resolution (none on ``ground``'s
        catcher)."""
        self._run(True, gbuffer_textures, out_fbo, camera, settings, direct=direct,
                  factor=factor, gathered=gathered, ground=ground)

    @staticmethod
    def _check_hits(hits, settings: RenderSettings) -> tuple:
        hits = tuple(hits or ())
        if hits and len(hits) != hit_targets(settings.ssao.rays):
            raise ValueError(f"{len(hits)} hit targets for {settings.ssao.rays} rays: "
                             f"expected {hit_targets(settings.ssao.rays)}")
        return hits

    def release(self) -> None:
        self._draw.release()
