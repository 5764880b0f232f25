"""Twins of ``shaders/lib/shadow.glsl``: shadow-map lookups (receiver bias, PCSS blocker search,
percentage-closer filtering). A map is a ``[H, W]`` tensor in GL row order (row 0 = texel row 0,
the bottom), as ``texelFetch`` addresses it; inputs broadcast over leading dimensions."""
from __future__ import annotations

import torch

SHADOW_SEARCH_SAMPLES = 16
SHADOW_PCF_SAMPLES = 32


def vogel_disk(i, n, phi) -> torch.Tensor:
    """GLSL ``vec2 vogel_disk(int i, int n, float phi)``."""
    i = torch.as_tensor(i, dtype=torch.float32)
    n = torch.as_tensor(n, dtype=torch.float32)
    phi = torch.as_tensor(phi, dtype=torch.float32)
    r = torch.sqrt((i + 0.5) / n)
    theta = i * 2.39996323 + phi
    return torch.stack([r * torch.cos(theta), r * torch.sin(theta)], dim=-1)


def shadow_phi(frag_coord) -> torch.Tensor:
    """GLSL ``float shadow_phi(vec2 frag_coord)``: interleaved gradient noise times 2 pi."""
    t = frag_coord[..., 0] * 0.06711056 + frag_coord[..., 1] * 0.00583715
    return 6.28318531 * torch.frac(52.9829189 * torch.frac(t))


def shadow_receiver(p_ws, n_ws, l_ws, texel_world) -> torch.Tensor:
    """GLSL ``vec3 shadow_receiver(vec3 p_ws, vec3 n_ws, vec3 l_ws, float texel_world)``."""
    NoL = (n_ws * l_ws).sum(-1).clamp(0.0, 1.0)
    return p_ws + n_ws * (torch.as_tensor(texel_world) * (1.5 + 3.0 * (1.0 - NoL)))[..., None]


def shadow_depth_at(map_, uv) -> torch.Tensor:
    """GLSL ``float shadow_depth_at(sampler2D map, vec2 uv)`` (nearest texel, clamped)."""
    h, w = map_.shape[-2:]
    tx = torch.floor(uv[..., 0] * w).long().clamp(0, w - 1)
    ty = torch.floor(uv[..., 1] * h).long().clamp(0, h - 1)
    return map_[ty, tx]


def shadow_depth_slope(m) -> torch.Tensor:
    """GLSL ``vec2 shadow_depth_slope(vec3 m)``: the receiver plane's depth per uv unit."""
    mz = m[..., 2]
    mz = torch.where(mz.abs() > 1e-6, mz, torch.full_like(mz, 1e-6))
    g = -m[..., :2] / mz[..., None]
    n = torch.linalg.vector_norm(g, dim=-1, keepdim=True)
    return torch.where(n > 4.0, g * (4.0 / n.clamp_min(1e-30)), g)


def shadow_blocker_depth(map_, uv, z, dz, search_uv, phi) -> torch.Tensor:
    """GLSL ``float shadow_blocker_depth(sampler2D map, vec2 uv, float z, vec2 dz,
    float search_uv, float phi)``: mean occluder depth in the search disk, -1 where none."""
    total = torch.zeros_like(z)
    count = torch.zeros_like(z)
    for i in range(SHADOW_SEARCH_SAMPLES):
        off = vogel_disk(i, SHADOW_SEARCH_SAMPLES, phi) * search_uv[..., None]
        d = shadow_depth_at(map_, uv + off)
        hit = d < z + (dz * off).sum(-1)
        total = total + torch.where(hit, d, torch.zeros_like(d))
        count = count + hit.float()
    return torch.where(count > 0, total / count.clamp_min(1.0), torch.full_like(z, -1.0))


def shadow_pcf(map_, uv, z, dz, r_uv, phi) -> torch.Tensor:
    """GLSL ``float shadow_pcf(sampler2D map, vec2 uv, float z, vec2 dz, float r_uv,
    float phi)``."""
    lit = torch.zeros_like(z)
    for i in range(SHADOW_PCF_SAMPLES):
        off = vogel_disk(i, SHADOW_PCF_SAMPLES, phi) * r_uv[..., None]
        lit = lit + (shadow_depth_at(map_, uv + off) >= z + (dz * off).sum(-1)).float()
    return lit / float(SHADOW_PCF_SAMPLES)


def shadow_visibility(map_, s, dz, angle, depth_range, extent, phi) -> torch.Tensor:
    """GLSL ``float shadow_visibility(sampler2D map, vec3 s, vec2 dz, float angle,
    float depth_range, float extent, float phi)``: PCSS visibility of a directional light of
    angular radius ``angle`` at the light-space receiver point ``s`` (plane slope ``dz``)."""
    angle = torch.as_tensor(angle, dtype=torch.float32)
    outside = ((s < 0.0) | (s > 1.0)).any(-1)
    texel_uv = 1.0 / float(map_.shape[-1])
    t = torch.tan(angle.clamp(0.0, 0.3))
    z = s[..., 2]
    search = torch.clamp_min(z * depth_range * t / extent, 2.0 * texel_uv)
    blocker = shadow_blocker_depth(map_, s[..., :2], z, dz, search, phi)
    penumbra = (z - blocker) * depth_range * 2.0 * t / extent
    vis = shadow_pcf(map_, s[..., :2], z, dz, torch.clamp_min(penumbra * 0.5, texel_uv), phi)
    vis = torch.where(blocker < 0.0, torch.ones_like(vis), vis)
    return torch.where(outside, torch.ones_like(vis), vis)
