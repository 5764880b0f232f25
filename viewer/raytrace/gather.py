"""What rays see among a scene's contents (``(object, content)`` pairs): meshes and primitives
as they are, splat clouds as their Gaussians' proxies (:mod:`.splat_proxies`); image stacks and
alphaMode BLEND surfaces not at all (:mod:`.scene`'s module docstring says why)."""
from __future__ import annotations

from .splat_proxies import splat_proxies


def traced_meshes(contents) -> list:
    """The meshes rays see among ``(obj, content)`` pairs: meshes and primitives, splat clouds'
    proxies (:func:`~viewer.raytrace.splat_proxies.splat_proxies`); not image stacks or
    alphaMode BLEND surfaces."""
    out = []
    for obj, content in contents:
        if obj.type == "gbuffer":
            continue
        if obj.type == "splats":
            out.extend(splat_proxies(content))
            continue
        out.extend(m for m in content if m.alpha_mode != "BLEND")
    return out
