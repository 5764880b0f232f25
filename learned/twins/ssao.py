"""Twins of ``shaders/lib/ssao.glsl`` and of the pass ``shaders/passes/ssao.frag`` (screen-space
ambient occlusion and one-bounce indirect light, thesis eqs. 6.19-6.22).

Images are in GL row order (row 0 at the bottom), as the pass sees them. Registers the pass check
``ssao`` (occlusion and indirect, GL vs torch on the same G-buffer).
"""
from __future__ import annotations

import torch

from .deferred import view_ray_ws
from .equirect import rotate_y
from .mc import mc_sample_2d, sample_cosine_hemisphere
from .sampling import tangent_to_world
from .shading import shading_normal


def view_position(frag_coord, resolution, depth, tan_half_fov) -> torch.Tensor:
    """GLSL ``vec3 view_position(vec2 frag_coord, vec2 resolution, float depth,
    vec2 tan_half_fov)``."""
    ndc = frag_coord / resolution * 2.0 - 1.0
    xy = ndc * tan_half_fov
    return depth[..., None] * torch.cat([xy, -torch.ones_like(xy[..., :1])], dim=-1)


def view_to_frag(p_vs, resolution, tan_half_fov) -> torch.Tensor:
    """GLSL ``vec3 view_to_frag(vec3 p_vs, vec2 resolution, vec2 tan_half_fov)`` -> (x, y,
    depth)."""
    depth = -p_vs[..., 2]
    ndc = p_vs[..., :2] / (depth.clamp_min(1e-30)[..., None] * tan_half_fov)
    return torch.cat([(ndc * 0.5 + 0.5) * resolution, depth[..., None]], dim=-1)


def surface_depth_at(q_vs, p_vs, n_vs, depth_center) -> torch.Tensor:
    """GLSL ``float surface_depth_at(vec3 q_vs, vec3 p_vs, vec3 n_vs, float depth_center)``."""
    qn = (q_vs * n_vs).sum(-1)
    len_q = torch.linalg.vector_norm(q_vs, dim=-1)
    ok = qn.abs() > 0.05 * len_q
    z = -q_vs[..., 2] * ((p_vs * n_vs).sum(-1) / torch.where(ok, qn, torch.ones_like(qn)))
    front = ((q_vs - p_vs) * n_vs).sum(-1) >= -1e-4 * len_q  # grazing: on or before the plane
    return torch.where(ok, z, torch.where(front, -q_vs[..., 2], depth_center))


def ssao_upsample_weight(bilinear, p_vs, n_vs, q_vs, nq_vs) -> torch.Tensor:
    """GLSL ``float ssao_upsample_weight(float bilinear, vec3 p_vs, vec3 n_vs, vec3 q_vs,
    vec3 nq_vs)``: bilinear x plane closeness (0 beyond 2 % of p's depth) x cos^8."""
    plane = ((p_vs - q_vs) * nq_vs).sum(-1).abs() / (-p_vs[..., 2]).clamp_min(1e-30)
    w_plane = (1.0 - plane * 50.0).clamp_min(0.0)
    c = (n_vs * nq_vs).sum(-1).clamp_min(0.0)
    c2 = c * c
    c4 = c2 * c2
    return bilinear * w_plane * (c4 * c4)


def ssao_occluded(z, z_d, thickness) -> torch.Tensor:
    """GLSL ``float ssao_occluded(float z, float z_d, float thickness)`` (thesis eq. 6.20)."""
    hit = (z_d > 0.0) & (z > z_d * (1.0 + 1e-4)) & (z < z_d + thickness)
    return hit.to(torch.float32)


class MarchTarget:
    """What :func:`ssao_march` reads of a G-buffer (GL order): alpha and depth ``[H, W]``, the
    view-space unit normals ``hn_vs [H, W, 3]`` (0 where the normal is 0), and the camera."""

    def __init__(self, alpha, depth, hn_vs, resolution, tan_half_fov, thickness: float):
        self.alpha, self.depth, self.hn_vs = alpha, depth, hn_vs
        self.resolution, self.tan_half_fov, self.thickness = resolution, tan_half_fov, thickness


def ssao_march(p_vs, w, radius: float, steps: int, jitter, target: MarchTarget, alive
               ) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
    """GLSL ``bool ssao_march(vec3 p_vs, vec3 w, float radius, int steps, float jitter,
    out ivec2 hit)`` of ``passes/ssao.frag`` for every pixel at once (``alive [H, W]``: the pixels
    that march; at reduced scale the low-resolution texels') -> (hit, hit pixel x, y: alive's
    shape, bool / int64 full-resolution pixels)."""
    h, w_px = target.alpha.shape  # the full-resolution G-buffer; the march's pixels: alive's
    hit = torch.zeros(alive.shape, dtype=torch.bool)
    hit_x = torch.zeros(alive.shape, dtype=torch.int64)
    hit_y = torch.zeros(alive.shape, dtype=torch.int64)
    alive = alive.clone()
    for j in range(steps):
        q = p_vs + w * (radius * (float(j) + jitter) / float(steps))[..., None]
        f = view_to_frag(q, target.resolution, target.tan_half_fov)
        inside = (f[..., 2] > 0.0) & (f[..., :2] >= 0.0).all(-1) & (f[..., 0] < w_px) \
            & (f[..., 1] < h)
        alive = alive & inside
        hx = torch.floor(f[..., 0]).to(torch.int64).clamp(0, w_px - 1)
        hy = torch.floor(f[..., 1]).to(torch.int64).clamp(0, h - 1)
        h_alpha, h_depth = target.alpha[hy, hx], target.depth[hy, hx]
        hp_frag = torch.stack([hx, hy], dim=-1).to(torch.float32) + 0.5
        hp_vs = view_position(hp_frag, target.resolution, h_depth, target.tan_half_fov)
        z_d = surface_depth_at(q, hp_vs, target.hn_vs[hy, hx], h_depth)
        now = alive & (h_alpha > 0.0) & (ssao_occluded(f[..., 2], z_d, target.thickness) > 0.5)
        hit_x = torch.where(now, hx, hit_x)
        hit_y = torch.where(now, hy, hit_y)
        hit = hit | now
        alive = alive & ~now
    return hit, hit_x, hit_y


def ssao_sample_pixel(t, scale: int, size) -> torch.Tensor:
    """GLSL ``ivec2 ssao_sample_pixel(ivec2 t)`` of ``passes/ssao_upsample.glsl``: the
    full-resolution pixel low-resolution texel ``t [..., 2]`` (x, y; int64) marches from at
    ``scale`` in a frame of ``size`` (W, H)."""
    lim = torch.tensor([int(size[0]) - 1, int(size[1]) - 1])
    return torch.minimum(t * int(scale) + int(scale) // 2, lim)


class _View:
    """The camera of a frame as the SSAO passes use it (GL order, ``[H, W]`` G-buffer)."""

    def __init__(self, gbuffer: dict, camera):
        self.g = gbuffer
        self.h, self.w = gbuffer["alpha"].shape[:2]
        self.c2w = torch.tensor(camera.basis(), dtype=torch.float32).T  # columns right, up, back
        self.tan = torch.tensor(camera.tan_half_fov(), dtype=torch.float32)
        self.res = torch.tensor([float(self.w), float(self.h)])

    def at(self, px, py):
        """(frag, alpha, depth, view-space shading normal, view-space position) at pixels."""
        frag = torch.stack([px, py], dim=-1).to(torch.float32) + 0.5
        d = view_ray_ws(frag, self.c2w, self.tan, self.res)
        alpha, depth = self.g["alpha"][py, px, 0], self.g["depth"][py, px, 0]
        n_vs = shading_normal(self.g["normal"][py, px], -d) @ self.c2w  # transpose(M) * n
        return frag, alpha, depth, n_vs, view_position(frag, self.res, depth, self.tan)


def ssao_upsample(low: torch.Tensor, gbuffer: dict, camera, scale: int,
                  fallback: float) -> torch.Tensor:
    """GLSL ``vec4 ssao_upsample(sampler2D low, ivec2 pixel, GBuffer g, vec4 fallback)`` of
    ``passes/ssao_upsample.glsl`` at every pixel: ``low [h, w, C]`` (a reduced-scale pass's
    target, GL order) -> ``[H, W, C]`` (meaningful on surface pixels; the passes write their own
    value on the background)."""
    view = _View(gbuffer, camera)
    k = int(scale)
    ys, xs = torch.meshgrid(torch.arange(view.h), torch.arange(view.w), indexing="ij")
    _, _, depth, n, p = view.at(xs, ys)
    lh, lw = low.shape[:2]
    c = (torch.stack([xs, ys], dim=-1) - k // 2).to(torch.float32) / float(k)
    t0 = torch.floor(c).to(torch.int64)
    f = c - t0.to(torch.float32)
    total = torch.zeros(view.h, view.w, low.shape[-1])
    wsum = torch.zeros(view.h, view.w)
    best = torch.full((view.h, view.w), 3.0e38)
    nearest = torch.full((view.h, view.w, low.shape[-1]), float(fallback))
    for i in range(4):
        ox, oy = i & 1, i >> 1
        tx = (t0[..., 0] + ox).clamp(0, lw - 1)
        ty = (t0[..., 1] + oy).clamp(0, lh - 1)
        q = ssao_sample_pixel(torch.stack([tx, ty], dim=-1), k, (view.w, view.h))
        _, h_alpha, h_depth, nq, pq = view.at(q[..., 0], q[..., 1])
        ok = (h_alpha > 0.0) & (h_depth > 0.0)
        v = low[ty, tx]
        bil = (f[..., 0] if ox else 1.0 - f[..., 0]) * (f[..., 1] if oy else 1.0 - f[..., 1])
        w = torch.where(ok, ssao_upsample_weight(bil, p, n, pq, nq), torch.zeros_like(bil))
        total = total + w[..., None] * torch.where(ok[..., None], v, torch.zeros_like(v))
        wsum = wsum + w
        dz = (h_depth - depth).abs()
        closer = ok & (dz < best)
        best = torch.where(closer, dz, best)
        nearest = torch.where(closer[..., None], v, nearest)
    return torch.where((wsum > 1e-6)[..., None],
                       total / torch.where(wsum > 1e-6, wsum, 1.0)[..., None], nearest)


def ssao_blur(ao: torch.Tensor, gbuffer: dict, camera) -> torch.Tensor:
    """GLSL ``vec4 ssao_blur(sampler2D ao, ivec2 pixel, GBuffer g)`` of
    ``passes/ssao_upsample.glsl`` at every pixel: ``ao [H, W, C]`` (GL order) -> ``[H, W, C]``
    (meaningful on surface pixels; the pass writes 1 on the background)."""
    view = _View(gbuffer, camera)
    ys, xs = torch.meshgrid(torch.arange(view.h), torch.arange(view.w), indexing="ij")
    _, _, _, n, p = view.at(xs, ys)
    binomial = (1.0, 4.0, 6.0, 4.0, 1.0)
    total = torch.zeros(view.h, view.w, ao.shape[-1])
    wsum = torch.zeros(view.h, view.w)
    for j in range(-2, 3):
        for i in range(-2, 3):
            qx, qy = xs + i, ys + j
            inside = (qx >= 0) & (qx < view.w) & (qy >= 0) & (qy < view.h)
            qx, qy = qx.clamp(0, view.w - 1), qy.clamp(0, view.h - 1)
            _, h_alpha, h_depth, nq, pq = view.at(qx, qy)
            ok = inside & (h_alpha > 0.0) & (h_depth > 0.0)
            w = ssao_upsample_weight(torch.full_like(wsum, binomial[i + 2] * binomial[j + 2]),
                                     p, n, pq, nq)
            w = torch.where(ok, w, torch.zeros_like(w))
            total = total + w[..., None] * torch.where(ok[..., None], ao[qy, qx],
                                                       torch.zeros_like(ao[qy, qx]))
            wsum = wsum + w
    return total / torch.where(wsum > 0.0, wsum, 1.0)[..., None]


def ssao_pass(gbuffer: dict, camera, rays: int, steps: int, radius: float, thickness: float,
              seed: int, direct: torch.Tensor | None = None, vis_dirs: torch.Tensor | None = None,
              vis_steps: int = 16, vis_radius: float = 2.0, env_rotation: float = 0.0,
              factor: torch.Tensor | None = None, scale: int = 1,
              gather: bool = False, denoise: bool = False) -> torch.Tensor:
    """Twin of ``passes/ssao.frag``: G-buffer channels ``[H, W, C]`` (GL order) -> ``[H, W, 4]``:
    O(x) in every channel, or (with ``direct`` [H, W, 4]) direct + L_ind (eq. 6.22). With
    ``vis_dirs`` (``[8, 3]``, environment frame: ``SSAO_ENV_VIS``) the g channel holds the
    environment's screen-space visibility S(x) instead (``env_rotation`` in radians). ``factor``
    ``[H, W]`` (``SSAO_INDIRECT_FACTOR``): a neural student's learned factor on L_ind.
    ``scale`` k > 1 (``SSAO_SCALE``): the occlusion mode returns its low-resolution target
    ``[ceil(H / k), ceil(W / k), 4]`` (:func:`ssao_upsample` brings it to full resolution, as
    ``passes/ssao_upsample.frag`` does); ``gather`` (with ``direct``, ``SSAO_GATHER``) returns the
    low-resolution gathered light (E, 1) (0 off surfaces); with ``direct`` and no ``gather`` the
    gather then the full-resolution composite (direct + (1 - m) a f E with E upsampled).
    ``denoise`` (scale 1, ``indirect_blur``): E through :func:`ssao_blur` before the
    composite (``SSAO_COMPOSITE`` at k = 1)."""
    g = gbuffer
    view = _View(g, camera)
    h, w = view.h, view.w
    k = int(scale)
    if direct is not None and (k > 1 or denoise) and not gather:  # the composite pass
        e = ssao_pass(g, camera, rays, steps, radius, thickness, seed, direct=direct, scale=k,
                      gather=True)
        if denoise and k == 1:
            e = ssao_blur(e, g, camera)
        return _composite(g, direct, ssao_upsample(e[..., :3], g, camera, k, 0.0), factor)
    th, tw = -(-h // k), -(-w // k)
    ty, tx = torch.meshgrid(torch.arange(th), torch.arange(tw), indexing="ij")
    q = ssao_sample_pixel(torch.stack([tx, ty], dim=-1), k, (w, h))
    xs, ys = q[..., 0], q[..., 1]  # the pixels the texels march from (= the texels at k = 1)
    _, alpha, depth, n_vs, p_vs = view.at(xs, ys)
    active = (alpha > 0.0) & (depth > 0.0)
    hn = g["normal"]
    hn_len2 = (hn * hn).sum(-1, keepdim=True)
    hn_ok = hn_len2 > 1e-12
    hn_vs = torch.where(hn_ok, (hn * torch.rsqrt(torch.where(hn_ok, hn_len2, 1.0))) @ view.c2w,
                        torch.zeros_like(hn))
    target = MarchTarget(g["alpha"][..., 0], g["depth"][..., 0], hn_vs, view.res, view.tan,
                         thickness)
    hits = torch.zeros(th, tw)
    gathered = torch.zeros(th, tw, 3)
    for r in range(rays):
        u = mc_sample_2d(xs, ys, torch.full_like(xs, r), seed, 2)
        jitter = 1.0 - mc_sample_2d(xs, ys, torch.full_like(xs, r), seed, 3)[..., 0]
        wdir = tangent_to_world(sample_cosine_hemisphere(u), n_vs)
        hit, hx, hy = ssao_march(p_vs, wdir, radius, steps, jitter, target, active)
        hits = hits + hit.to(torch.float32)
        if direct is not None:
            gathered = gathered + torch.where(hit[..., None], direct[hy, hx, :3], torch.zeros(3))
    n_rays = float(max(rays, 1))
    if direct is None:
        o = torch.where(active, 1.0 - hits / n_rays, torch.ones_like(hits))
        out = o[..., None].expand(th, tw, 4).clone()
        if vis_dirs is not None:
            out[..., 1] = torch.where(active, env_visibility(
                p_vs, n_vs, vis_dirs, view.c2w, env_rotation, vis_steps, vis_radius, seed, xs,
                ys, target, active), torch.ones_like(hits))
        return out
    if gather:
        e = torch.cat([gathered / n_rays, torch.ones(th, tw, 1)], dim=-1)
        return torch.where(active[..., None], e, torch.zeros_like(e))
    return _composite(g, direct, gathered, factor, n_rays)


def _composite(g: dict, direct, e, factor, divisor: float = 1.0) -> torch.Tensor:
    """direct + (1 - m) a f E / divisor on surface pixels (the indirect pass's last lines, in
    their order of operations)."""
    alpha, depth = g["alpha"][..., 0], g["depth"][..., 0]
    active = (alpha > 0.0) & (depth > 0.0)
    indirect = (1.0 - g["metallic"].clamp(0.0, 1.0)) * g["albedo"] * e / divisor
    if factor is not None:
        indirect = indirect * factor[..., None]
    indirect = torch.where(torch.isfinite(indirect).all(-1, keepdim=True),
                           indirect * alpha[..., None], torch.zeros_like(indirect))
    out = torch.where(active[..., None], direct[..., :3] + indirect, direct[..., :3])
    return torch.cat([out, direct[..., 3:]], dim=-1)


def env_visibility(p_vs, n_vs, vis_dirs, c2w, env_rotation: float, steps: int, radius: float,
                   seed: int, xs, ys, target: MarchTarget, active) -> torch.Tensor:
    """The ``SSAO_ENV_VIS`` block of ``passes/ssao.frag``: S(x) = sum_k V_k max(n.l_k, 0) /
    sum_k max(n.l_k, 0) over the environment's power directions ``vis_dirs [K, 3]``, 1 where none
    is above the horizon -> ``[H, W]``."""
    lit = torch.zeros(p_vs.shape[:-1])
    total = torch.zeros(p_vs.shape[:-1])
    angle = torch.tensor(float(env_rotation))
    for k in range(vis_dirs.shape[0]):
        l_ws = rotate_y(vis_dirs[k].to(torch.float32), angle)
        l_vs = (l_ws @ c2w).expand_as(n_vs)  # transpose(M) * l
        c = (n_vs * l_vs).sum(-1).clamp_min(0.0)
        up = active & (c > 0.0)
        jitter = 1.0 - mc_sample_2d(xs, ys, torch.full_like(xs, k), seed, 4)[..., 0]
        hit, _, _ = ssao_march(p_vs, l_vs, radius, steps, jitter, target, up)
        total = total + torch.where(up, c, torch.zeros_like(c))
        lit = lit + torch.where(up & ~hit, c, torch.zeros_like(c))
    return torch.where(total > 0.0, lit / torch.where(total > 0.0, total, 1.0),
                       torch.ones_like(total))
