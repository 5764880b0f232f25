"""Twins of ``shaders/passes/deferred.glsl``, the code every lighting pass shares: the view ray of a
pixel and the environment's frame. The passes themselves: :mod:`learned.twins.shade`."""
from __future__ import annotations

import torch

from .equirect import rotate_y


def view_ray_ws(frag_coord: torch.Tensor, camera_to_world: torch.Tensor,
                tan_half_fov: torch.Tensor, resolution: torch.Tensor) -> torch.Tensor:
    """GLSL ``vec3 view_ray_ws(vec2 frag_coord)`` of ``passes/deferred.glsl``.
    frag_coord [..., 2] (pixel centres, origin bottom-left), camera_to_world [3, 3] (columns right,
    up, back) -> [..., 3] unit world directions."""
    ndc = frag_coord / resolution * 2.0 - 1.0
    d_vs = torch.cat([ndc * tan_half_fov, -torch.ones_like(ndc[..., :1])], dim=-1)
    d = d_vs @ camera_to_world.T
    return d / torch.linalg.vector_norm(d, dim=-1, keepdim=True)


def env_dir(d_ws: torch.Tensor, rotation: float) -> torch.Tensor:
    """GLSL ``vec3 env_dir(vec3 d_ws)``: world direction -> the rotated environment's frame."""
    return rotate_y(d_ws, torch.full(d_ws.shape[:-1], -rotation, dtype=d_ws.dtype))


def emitted_radiance(g: dict[str, torch.Tensor]) -> torch.Tensor:
    """GLSL ``vec3 emitted_radiance(GBuffer g)``: the G-buffer's emission channel ([..., 3]), zero
    where the layout has none (as ``gbuffer_background``)."""
    if "emission" in g:
        return g["emission"]
    return torch.zeros(*g["alpha"].shape[:-1], 3, dtype=g["alpha"].dtype)


def reflect(i: torch.Tensor, n: torch.Tensor) -> torch.Tensor:
    """GLSL built-in ``reflect(I, N)`` = I - 2 dot(N, I) N."""
    return i - 2.0 * (n * i).sum(-1, keepdim=True) * n


# ---------------------------------------------------------------------------------------------
# model-level parity: render in GL, shade the read-back G-buffer in torch, compare
# ---------------------------------------------------------------------------------------------
