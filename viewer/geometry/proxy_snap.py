"""An image-space stack's depth snapped to its shadow-only proxies' depth.

An estimated G-buffer (thesis ch. 4: depth and normals predicted from a photograph) seen with
proxy meshes that cast its shadows (``shadow_only``) puts each pixel a little in front of or
behind the proxy surface it belongs to. Behind it, that surface shadows the pixel: the proxy
shadows its own image. Raising the receiver's normal offset hides it, but only at a value tuned
to the estimate's error, and it loses the contact shadows. Instead, where the stack's depth lies
within ``tolerance`` (a fraction) of the proxies' depth at the same pixel, the pixel takes the
proxies' depth. It then lies on the caster's surface, and the default bias is enough. Elsewhere
the stack keeps its own depth, including where a proxy is missing or far off.

The proxies' depth is drawn by the G-buffer pass from the stack's camera
(:meth:`viewer.passes.gbuffer.GBufferPass.snapped_stack`).
"""
from __future__ import annotations

from dataclasses import replace

import numpy as np

from .imagespace import ImageGBuffer


def snap_depth(depth: np.ndarray, proxy: np.ndarray, tolerance: float) -> np.ndarray:
    """``depth`` (``[H, W, 1]`` view depth, 0 on the background) with the pixels where
    ``|depth - proxy| <= tolerance * proxy`` (both > 0) set to ``proxy``'s depth."""
    near = (depth > 0.0) & (proxy > 0.0) & (np.abs(depth - proxy) <= tolerance * proxy)
    return np.where(near, proxy, depth).astype(depth.dtype)


def snapped(stack: ImageGBuffer, proxy_depth: np.ndarray, tolerance: float) -> ImageGBuffer:
    """A copy of ``stack`` whose depth channel is :func:`snap_depth` of it and ``proxy_depth``
    (``[H, W, 1]``, row 0 at the top, as the stack's channels)."""
    depth = stack.channels["depth"]
    if proxy_depth.shape[:2] != depth.shape[:2]:
        raise ValueError(f"proxy depth {proxy_depth.shape[:2]} is not the stack's "
                         f"{depth.shape[:2]}")
    channels = dict(stack.channels)
    channels["depth"] = snap_depth(depth, proxy_depth.reshape(depth.shape), tolerance)
    return replace(stack, channels=channels)
