"""The real-time tier's passes in the frame graph (``[render] raytrace``; the draw calls are
:mod:`viewer.passes.rt_light`): ``raytrace`` (rays from the G-buffer into ``rt_raw<k>``, folded
into the kept running mean ``rt_history<k>``) and ``raytrace_filter`` (the a-trous iterations
into ``rt_light<k>``, which the lighting pass reads under RT_LIGHT).

The running mean restarts whenever anything but the display settings changes (the scene, the
camera, a slider): nothing of an earlier view lingers, so a slider move never ghosts. A still
view in the interactive viewer adds one frame of rays per frame up to ``ray_frames``, then
stops tracing (the image is then still, exactly); a headless render traces ``ray_still_frames``
frames at once (default :data:`STILL_FRAMES`)."""
from __future__ import annotations

import dataclasses

from ..passes.rt_light import FILTER_STEPS
from ..passes.ssao import low_resolution
from ..scene.camera import Camera
from ..scene.description import Scene
from ..scene.settings import RaytraceSettings
from .graph import FrameGraph
from .resources import TextureDesc

# frames of rays a headless (non-progressive) render accumulates by default (ray_still_frames)
STILL_FRAMES = RaytraceSettings.still_frames
TARGETS = 3


def raytrace_passes(g: FrameGraph, renderer, scene: Scene, spec, camera: Camera,
                    progressive: bool, lighting_settings) -> tuple[str, ...]:
    """Declare the tier's passes; returns the filtered targets the lighting pass reads."""
    res = renderer.resources
    settings = scene.render
    size = tuple(camera.size)
    raw = tuple(f"rt_raw{k}" for k in range(TARGETS))
    hist = tuple(f"rt_history{k}" for k in range(TARGETS))
    out = tuple(f"rt_light{k}" for k in range(TARGETS))
    tmp = tuple(f"rt_tmp{k}" for k in range(TARGETS))
    pong = tuple(f"rt_pong{k}" for k in range(TARGETS))
    scale = int(settings.raytrace.scale)
    # at ray_scale k > 1 the rays, their history and the filter run at 1/k^2 of the pixels, the
    # filter ending in rt_low<k>, which rt_upsample brings to rt_light<k>
    low = tuple(f"rt_low{k}" for k in range(TARGETS)) if scale > 1 else out
    small = low_resolution(size, scale)
    for name in raw + tmp + pong + (low if scale > 1 else ()):
        g.create(name, TextureDesc(small, 4, "f4"))
    for name in hist:
        g.create(name, TextureDesc(small, 4, "f4"), kept=True)
    for name in out:
        g.create(name, TextureDesc(size, 4, "f4"), kept=True)
    rpass = res.layout_pass("rt_light", spec.layout)
    defines = spec.variant.defines
    # at reduced scale the sun's ray is traced for every pixel (its shadow's edge): rt_sunraw,
    # folded into rt_sunhist as the other targets are into rt_history
    full_sun = scale > 1 and bool(defines.get("RT_SUN"))
    sun = ("rt_sunraw", "rt_suntmp", "rt_sunhist") if full_sun else ()
    if full_sun:
        g.create("rt_sunraw", TextureDesc(size, 4, "f4"))
        g.create("rt_suntmp", TextureDesc(size, 4, "f4"))
        g.create("rt_sunhist", TextureDesc(size, 4, "f4"), kept=True)
    ibl = res.ibl(scene.environment, sun=bool(defines.get("SUN_LIGHT")))
    contents = [(obj, renderer.geometry(obj)) for obj in scene.objects]
    window = int(settings.raytrace.frames)
    still = int(settings.raytrace.still_frames)

    def rays(f):
        trace = res.trace.get(contents, renderer.geometry_cache.version)
        sampling = renderer.env_sampling(scene)
        state = f.state(hist[0])
        key = (dataclasses.replace(scene, render=lighting_settings), camera)
        if not progressive or state.get("key") != key:
            state.update(key=key, count=0)
        todo = (1 if state["count"] < window else 0) if progressive else still
        gb = f["gbuffer"].textures
        for _ in range(todo):
            rpass.trace(gb, f.fbo(*raw), camera, ibl, sampling, scene.environment, settings,
                        defines, scene.light, trace, state["count"])
            state["count"] += 1
            weight = 1.0 / min(state["count"], window)
            rpass.accumulate([f[n].texture for n in raw], [f[n].texture for n in hist],
                             f.fbo(*tmp), weight)
            for a, b in zip(tmp, hist):  # the new mean becomes the history
                renderer.ctx.copy_framebuffer(dst=f[b].fbo, src=f[a].fbo)
            if full_sun:
                rpass.trace(gb, f.fbo("rt_sunraw"), camera, ibl, sampling, scene.environment,
                            settings, defines, scene.light, trace, state["count"] - 1,
                            sun_only=True)
                res.accumulate_pass().add(f["rt_sunraw"].texture, f["rt_sunhist"],
                                          min(state["count"], window) - 1, 1,
                                          f.fbo("rt_suntmp"))
    g.add_pass("raytrace", rays, reads=("gbuffer",), writes=raw + hist + tmp + sun,
               inputs={"objects": scene.objects, "render": lighting_settings,
                       "environment": scene.environment, "light": scene.light,
                       "camera": camera, "defines": tuple(sorted(defines.items()))},
               volatile=progressive)

    def denoise(f):
        gb = f["gbuffer"].textures
        if not settings.raytrace.denoise:
            if scale > 1:
                rpass.upsample(gb, [f[n].texture for n in hist], f.fbo(*out), camera, scale,
                               f["rt_sunhist"].texture if full_sun else None)
                return
            for a, b in zip(hist, out):
                renderer.ctx.copy_framebuffer(dst=f[b].fbo, src=f[a].fbo)
            return
        source, steps = hist, (FILTER_STEPS if scale == 1 else FILTER_STEPS[:-1])
        for i, step in enumerate(steps):
            # ping-pong between rt_pong and rt_light (rt_low at reduced scale), ending in it
            target = low if (len(steps) - 1 - i) % 2 == 0 else pong
            rpass.filter(gb, [f[n].texture for n in source], f.fbo(*target), step, camera, scale)
            source = target
        if scale > 1:
            rpass.upsample(gb, [f[n].texture for n in low], f.fbo(*out), camera, scale,
                           f["rt_sunhist"].texture if full_sun else None)
    g.add_pass("raytrace_filter", denoise, reads=("gbuffer",) + hist + sun[2:],
               writes=out + pong + (low if scale > 1 else ()),
               inputs={"denoise": settings.raytrace.denoise, "scale": scale, "camera": camera})
    return out
