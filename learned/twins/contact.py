"""Twins of ``shaders/lib/contact.glsl`` (screen-space contact shadows) and of the march over the
G-buffer, ``contact_shadow`` of ``shaders/passes/lights.glsl``."""
from __future__ import annotations

import torch

CONTACT_STEPS = 12  # passes/lights.glsl


def contact_project(p_ws, right, up, back, camera_pos, tan_half_fov, resolution) -> torch.Tensor:
    """GLSL ``vec3 contact_project(vec3 p_ws, vec3 right, vec3 up, vec3 back, vec3 camera_pos,
    vec2 tan_half_fov, vec2 resolution)``: (pixel x, pixel y, view depth)."""
    d = p_ws - camera_pos
    v = torch.stack([(d * right).sum(-1), (d * up).sum(-1), (d * back).sum(-1)], -1)
    depth = -v[..., 2]
    ndc = v[..., :2] / (torch.clamp_min(depth, 1e-6)[..., None] * tan_half_fov)
    return torch.cat([(ndc * 0.5 + 0.5) * resolution, depth[..., None]], -1)


def contact_occluded(ray_depth, scene_depth, bias, thickness) -> torch.Tensor:
    """GLSL ``float contact_occluded(float ray_depth, float scene_depth, float bias,
    float thickness)``."""
    d = ray_depth - scene_depth
    return ((scene_depth > 0.0) & (d > bias) & (d < thickness)).float()


def contact_jitter(frag_coord) -> torch.Tensor:
    """GLSL ``float contact_jitter(vec2 frag_coord)``."""
    t = frag_coord[..., 0] * 0.06711056 + frag_coord[..., 1] * 0.00583715
    return torch.frac(52.9829189 * torch.frac(t))


def contact_shadow(depth_image, p, n, l, frag_coord, camera_to_world, camera_pos, tan_half_fov,
                   resolution, length) -> torch.Tensor:
    """GLSL ``float contact_shadow(vec3 p, vec3 n, vec3 l)`` (passes/lights.glsl) with its
    uniforms as arguments: ``depth_image`` [H, W] the G-buffer's depth in GL row order (row 0 the
    bottom), ``camera_to_world`` [3, 3] (columns right, up, back), ``length`` the march's."""
    right, up, back = camera_to_world[:, 0], camera_to_world[:, 1], camera_to_world[:, 2]
    res = torch.as_tensor(resolution, dtype=torch.float32)
    tan = torch.as_tensor(tan_half_fov, dtype=torch.float32)
    cam = torch.as_tensor(camera_pos, dtype=torch.float32)
    c = contact_project(p, right, up, back, cam, tan, res)
    pixel = 2.0 * tan[1] / res[1]
    start = p + n * (2.0 * pixel * c[..., 2])[..., None]
    step = length / CONTACT_STEPS
    thickness = torch.clamp_min(2.0 * (l * back).sum(-1).abs() * step,
                                torch.tensor(0.5 * length))
    jitter = contact_jitter(frag_coord)
    vis = torch.ones(p.shape[:-1])
    going = torch.ones(p.shape[:-1], dtype=torch.bool)
    h, w = depth_image.shape
    for k in range(CONTACT_STEPS):
        s = contact_project(start + l * ((k + jitter) * step)[..., None], right, up, back, cam,
                            tan, res)
        inside = (s[..., 2] > 0) & (s[..., :2] >= 0).all(-1) & (s[..., :2] < res).all(-1)
        going = going & inside
        x = s[..., 0].long().clamp(0, w - 1)
        y = s[..., 1].long().clamp(0, h - 1)
        bias = pixel * s[..., 2]
        hit = contact_occluded(s[..., 2], depth_image[y, x], bias,
                               torch.maximum(thickness, 2.0 * bias)) > 0.5
        vis = torch.where(going & hit, torch.zeros_like(vis), vis)
        going = going & ~hit
    return vis
