"""Twins of ``shaders/lib/ground.glsl`` (the shadow-catcher ground)."""
from __future__ import annotations

import torch

LUMA = (0.2126, 0.7152, 0.0722)  # Rec. 709, as the GLSL


def ground_fade(r, r_start, r_end) -> torch.Tensor:
    """GLSL ``float ground_fade(float r, float r_start, float r_end)``: 1 - smoothstep."""
    t = torch.clamp((r - r_start) / (r_end - r_start), 0.0, 1.0)
    return 1.0 - t * t * (3.0 - 2.0 * t)


def ground_catcher_radiance(shaded, unshadowed, background, fade) -> torch.Tensor:
    """GLSL ``vec3 ground_catcher_radiance(vec3 shaded, vec3 unshadowed, vec3 background,
    float fade)``: background x mix(1, clamp(luma(shaded) / luma(unshadowed), 0, 1), fade)."""
    luma = torch.tensor(LUMA, dtype=shaded.dtype)
    seen = torch.clamp((shaded * luma).sum(-1) / torch.clamp_min((unshadowed * luma).sum(-1),
                                                                   1e-8), 0.0, 1.0)
    return background * (1.0 + (seen - 1.0) * fade)[..., None]
