"""The frame's last passes, from linear radiance to the displayed image: the supersampling resolve
(``ssaa_resolve``), tone mapping (``tonemap``) and FXAA (``fxaa``); see
:mod:`viewer.graph.frame` for the whole frame and :mod:`viewer.passes.antialias` for the draws."""
from __future__ import annotations

import warnings

from ..scene.description import Scene
from .graph import FrameGraph
from .resources import TextureDesc


def ssaa_factor(scene: Scene) -> int:
    """The supersampling factor a frame of ``scene`` renders at: ``[render] ssaa``, or 1 for an
    image-space G-buffer stack (its G-buffer has its own resolution; warned once)."""
    n = int(scene.render.display.ssaa)
    if n > 1 and any(o.type == "gbuffer" for o in scene.objects):
        if not _SSAA_WARNED:
            _SSAA_WARNED.append(True)
            warnings.warn(f"render.ssaa = {n} is ignored for image-space G-buffers (their "
                          f"G-buffer has its own resolution); rendering at 1x", stacklevel=4)
        return 1
    return n


_SSAA_WARNED: list = []


def output_radiance(scene: Scene) -> str:
    """The frame's resource holding the output-size linear radiance (``resolved`` when
    supersampled, else ``radiance``)."""
    return "resolved" if ssaa_factor(scene) > 1 else "radiance"


def display_passes(g: FrameGraph, renderer, settings, n: int, out_size) -> None:
    """``ssaa_resolve`` (n > 1), ``tonemap`` and ``fxaa`` (``aa = "fxaa"``) into ``display``."""
    res = renderer.resources
    radiance = "radiance"
    if n > 1:
        radiance = g.create("resolved", TextureDesc(out_size, 4, "f4"), kept=True)

        def resolve(f):
            res.antialias().resolve(f["radiance"].texture, f["resolved"].fbo, n)
        g.add_pass("ssaa_resolve", resolve, reads=("radiance",), writes=("resolved",),
                   inputs={"ssaa": n})
    # supersampled edges are already filtered: FXAA on top only blurs them (measured against an
    # 8 x 8 supersampled frame: edge error 0.0195 at ssaa 4, 0.0346 with FXAA as well)
    fxaa = settings.display.aa == "fxaa" and n == 1
    # FXAA reads the tone-mapped image from a target of its own (kept: an exposure slider then
    # says it redraws for the exposure; RGBA8, small)
    ldr = g.create("tonemapped", TextureDesc(out_size, 4, "f1"), kept=True) if fxaa else "display"

    def tonemap(f):
        res.tonemap().run(f[radiance].texture, f[ldr].fbo, settings.display.exposure,
                          settings.display.tonemap)
    g.add_pass("tonemap", tonemap, reads=(radiance,), writes=(ldr,),
               inputs={"exposure": settings.display.exposure,
                       "tonemap": settings.display.tonemap})
    if fxaa:
        def antialias(f):
            res.antialias().fxaa(f[ldr].texture, f["display"].fbo)
        g.add_pass("fxaa", antialias, reads=(ldr,), writes=("display",), inputs={"aa": "fxaa"})
