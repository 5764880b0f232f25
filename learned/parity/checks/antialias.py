"""The anti-aliasing passes (``passes/fxaa.frag``, ``passes/ssaa_resolve.frag``) against
:func:`learned.twins.antialias.fxaa` and :func:`~learned.twins.antialias.ssaa_resolve`, each on
the GL pass's own input."""
from __future__ import annotations

import numpy as np
import torch

from learned.twins.antialias import fxaa, ssaa_resolve
from viewer.renderer import Renderer
from viewer.scene.description import scene_from_dict

from ..results import ParityResult, compare
from . import collector
from .models import PARITY_SCENE, gl_texture


def _bytes(texture) -> np.ndarray:
    """An RGBA8 target as [H, W, 4] float32 in [0, 1], GL row order."""
    w, h = texture.size
    return np.frombuffer(texture.read(), np.uint8).reshape(h, w, 4).astype(np.float32) / 255.0


def checks() -> dict:
    """This module's pass checks: name -> (model or None, check(programs) -> results)."""
    found, register_pass_check = collector()

    @register_pass_check("antialias")
    def check_antialias(programs):
        scene = scene_from_dict(PARITY_SCENE).with_render(shadows=False, model="ggx_split_sum")
        renderer = Renderer(ctx=programs.ctx)
        try:
            # FXAA's input is the tone-mapped image the same frame shows without it
            plain = _bytes(renderer.draw(scene.with_render(aa="none")).display)
            filtered = _bytes(renderer.draw(scene.with_render(aa="fxaa")).display)
            targets = renderer.draw(scene.with_render(ssaa=3))
            high = gl_texture(targets.targets["radiance"].texture)
            resolved = gl_texture(targets.radiance)
        finally:
            renderer.release()
        h, w = plain.shape[:2]
        ys, xs = torch.meshgrid(torch.arange(h), torch.arange(w), indexing="ij")
        pos = torch.stack([xs + 0.5, ys + 0.5], -1).float()
        with torch.no_grad():
            ref = fxaa(torch.from_numpy(plain), pos).numpy()
            box = ssaa_resolve(torch.from_numpy(high), 3).numpy()
        return [_fxaa_compare("antialias:fxaa", filtered, ref, plain),
                compare("antialias:ssaa_resolve", resolved, box, atol=1e-6, rtol=2e-6,
                        kind="pass", measured="max rel 2.6e-7 on llvmpipe",
                        envelope="the mean of 9 float32 values summed in another order: 9 "
                                 "roundings of partial sums (all >= 0) + the division -> "
                                 "1.2e-6 rel at most")]

    return found


def _fxaa_compare(name, gl, ref, plain):
    """The GL pass writes RGBA8: the twin's float result rounded to the nearest byte matches
    it, except where float32 rounding moves a value across a half-byte (1/255 off) or flips one
    of FXAA's threshold tests (the edge test, a search end): rare pixels, bounded by the largest
    change one pixel's filtering can make. ``plain``: the pass's input (FXAA must have changed
    some pixels, or nothing was compared)."""
    changed = float((np.abs(gl - plain).max(axis=-1) > 0.5 / 255.0).mean())
    diff = np.abs(gl - np.round(ref * 255.0) / 255.0).max(axis=-1)
    exact = float((diff <= 0.5 / 255.0).mean())
    within = float((diff <= 1.5 / 255.0).mean())
    ok = within >= 0.995 and exact >= 0.98 and changed > 0.01
    return ParityResult(name, float(diff.max()), float(diff.max()),
                        f">= 98% of pixels the same byte, >= 99.5% within one ({exact:.2%}, "
                        f"{within:.2%}; FXAA changed {changed:.1%})", ok, "pass",
                        "100% of pixels the same byte on llvmpipe (FXAA changes 10.6% of them)",
                        "the twin mirrors every operation (bilinear weights in float, not a "
                        "GPU's fixed-point ones), so the float results agree to ~1e-6 and the "
                        "bytes differ only where one straddles a rounding boundary or a "
                        "threshold test flips")
