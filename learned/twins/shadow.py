"""Twins of ``shaders/lib/shadow.glsl``: shadow-map lookups (receiver bias, PCSS blocker search,
percentage-closer filtering) of orthographic, perspective and cube maps. A map is a ``[H, W]``
tensor in GL row order (row 0 = texel row 0, the bottom), as ``texelFetch`` addresses it (a cube
map: the atlas, 3 faces wide and 2 high); inputs broadcast over leading dimensions. The filters'
loops run to the largest tap count of the batch with each element's own count masking the rest,
as the GLSL loop runs each pixel's."""
from __future__ import annotations

import torch

SHADOW_SEARCH_SAMPLES = 16
SHADOW_PCF_SAMPLES = 32
SHADOW_MIN_SAMPLES = 4
SHADOW_MAX_SEARCH_UV = 0.25
SHADOW_NEAREST_BLOCKER = 0.25
SHADOW_ORTHO, SHADOW_PERSPECTIVE, SHADOW_CUBE = 1, 2, 3
SHADOW_MAX_CASCADES = 4
SHADOW_CASCADE_MARGIN = 0.02
_GOLDEN = (-0.73736888, 0.67549030)  # (cos, sin) of the golden angle 2.39996323


def _f(x) -> torch.Tensor:
    return torch.as_tensor(x, dtype=torch.float32)


def vogel_disk(i, n, phi) -> torch.Tensor:
    """GLSL ``vec2 vogel_disk(int i, int n, float phi)``."""
    i = torch.as_tensor(i, dtype=torch.float32)
    n = torch.as_tensor(n, dtype=torch.float32)
    phi = torch.as_tensor(phi, dtype=torch.float32)
    r = torch.sqrt((i + 0.5) / n)
    theta = 6.28318531 * torch.frac(i * 0.381966011 + phi * 0.159154943)
    return torch.stack([r * torch.cos(theta), r * torch.sin(theta)], dim=-1)


def vogel_turn(dir_) -> torch.Tensor:
    """GLSL ``vec2 vogel_turn(vec2 dir)``: ``dir`` turned by the golden angle."""
    gx, gy = _GOLDEN
    x, y = dir_[..., 0], dir_[..., 1]
    return torch.stack([x * gx - y * gy, x * gy + y * gx], dim=-1)


def shadow_taps(r_uv, size, n_max) -> torch.Tensor:
    """GLSL ``int shadow_taps(float r_uv, float size, int n_max)`` (as float32)."""
    r = _f(r_uv) * _f(size)
    n = torch.ceil(1.57079633 * r * r)
    return torch.minimum(torch.clamp_min(n, SHADOW_MIN_SAMPLES), _f(n_max))


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


def shadow_atlas_depth(map_, t, size) -> torch.Tensor:
    """GLSL ``float shadow_atlas_depth(sampler2D map, vec2 t, vec2 size)``: the texel floor(t)
    (texel units) of the atlas, clamped to it."""
    h, w = map_.shape[-2:]
    tx = torch.floor(t[..., 0]).long().clamp(0, w - 1)
    ty = torch.floor(t[..., 1]).long().clamp(0, h - 1)
    return map_[ty, tx]


def shadow_map_size(map_, face) -> torch.Tensor:
    """GLSL ``float shadow_map_size(sampler2D map, int face)``: texels a side of a 2D map (face
    -1), a cube face (face >= 0: half the atlas's height), a cascade tile (face < -1: half the
    atlas's width)."""
    h, w = map_.shape[-2:]
    face = torch.as_tensor(face)
    return torch.where(face < -1, _f(float(w // 2)),
                       torch.where(face < 0, _f(float(h)), _f(h / 2.0)))


def shadow_tile_depth(map_, uv, k) -> torch.Tensor:
    """GLSL ``float shadow_tile_depth(sampler2D map, vec2 uv, int k)``: cascade k's tile (2 tiles
    wide), nearest texel, clamped to the tile."""
    n = map_.shape[-1] / 2
    k = torch.as_tensor(k).to(torch.int64).expand(uv.shape[:-1])
    t = torch.minimum(torch.clamp_min(uv * n, 0.0), _f(n - 1.0))
    corner = torch.stack([(k % 2).float(), torch.div(k, 2, rounding_mode="floor").float()], -1)
    return shadow_atlas_depth(map_, t + corner * n, None)


def shadow_cube_face(d) -> torch.Tensor:
    """GLSL ``vec3 shadow_cube_face(vec3 d)``: (u, v, face) of direction ``d``."""
    a = d.abs()
    x, y, z = d[..., 0], d[..., 1], d[..., 2]
    ax, ay, az = a[..., 0], a[..., 1], a[..., 2]
    on_x = (ax >= ay) & (ax >= az)
    on_y = ~on_x & (ay >= az)
    h = torch.full_like(x, 0.5)
    fx = torch.stack([torch.where(x > 0, h - 0.5 * z / ax, h + 0.5 * z / ax), h + 0.5 * y / ax,
                      torch.where(x > 0, 0.0, 1.0).to(x)], -1)
    fy = torch.stack([h + 0.5 * x / ay, torch.where(y > 0, h - 0.5 * z / ay, h + 0.5 * z / ay),
                      torch.where(y > 0, 2.0, 3.0).to(x)], -1)
    fz = torch.stack([torch.where(z > 0, h + 0.5 * x / az, h - 0.5 * x / az), h + 0.5 * y / az,
                      torch.where(z > 0, 4.0, 5.0).to(x)], -1)
    return torch.where(on_x[..., None], fx, torch.where(on_y[..., None], fy, fz))


def shadow_cube_dir(face, uv) -> torch.Tensor:
    """GLSL ``vec3 shadow_cube_dir(int face, vec2 uv)``: the face plane's direction at ``uv``."""
    face = torch.as_tensor(face).to(torch.int64)
    st = uv * 2.0 - 1.0
    s, t = st[..., 0], st[..., 1]
    one = torch.ones_like(s)
    face = face.expand(s.shape)
    table = torch.stack([torch.stack([one, t, -s], -1), torch.stack([-one, t, s], -1),
                         torch.stack([s, one, -t], -1), torch.stack([s, -one, t], -1),
                         torch.stack([s, t, one], -1), torch.stack([-s, t, -one], -1)], 0)
    return torch.gather(table, 0, face.clamp(0, 5)[None, ..., None].expand(1, *s.shape, 3))[0]


def shadow_sample(map_, uv, face) -> torch.Tensor:
    """GLSL ``float shadow_sample(sampler2D map, vec2 uv, int face)``: a 2D map's texel
    (face < 0) or the cube atlas texel of the direction through face ``face``'s plane at uv."""
    face = torch.as_tensor(face).to(torch.int64).expand(uv.shape[:-1])
    flat = shadow_depth_at(map_, uv)
    if bool((face < -1).any()):
        flat = torch.where(face < -1, shadow_tile_depth(map_, uv, (-2 - face).clamp_min(0)), flat)
    if bool((face < 0).all()):
        return flat
    fc = shadow_cube_face(shadow_cube_dir(face.clamp_min(0), uv))
    f = fc[..., 2].long()
    n = map_.shape[-2] / 2
    t = torch.minimum(torch.clamp_min(fc[..., :2] * n, 0.0), _f(n - 1.0))
    corner = torch.stack([(f % 3).float(), (f // 3).float()], -1)
    return torch.where(face < 0, flat, shadow_atlas_depth(map_, t + corner * n, None))


def shadow_plane_normal(du, dv, dd, n) -> torch.Tensor:
    """GLSL ``vec3 shadow_plane_normal(vec3 du, vec3 dv, vec3 dd, vec3 n)``."""
    def dot_cross(a, b):
        return (torch.linalg.cross(a, b) * n).sum(-1)
    return torch.stack([dot_cross(dv, dd), dot_cross(dd, du), dot_cross(du, dv)], -1)


def shadow_penumbra_uv(lens, zr, zb) -> torch.Tensor:
    """GLSL ``float shadow_penumbra_uv(vec4 lens, float zr, float zb)``."""
    zr, zb = _f(zr), _f(zb)
    ortho = lens[..., 1] * (zr - zb) * lens[..., 3]
    r = lens[..., 2] + zr * lens[..., 3]
    b = lens[..., 2] + zb * lens[..., 3]
    persp = lens[..., 1] * (1.0 / b - 1.0 / r)
    return torch.where(lens[..., 0] < 1.5, ortho, persp)


def shadow_receiver_depth(plane, lens, face, uv, o) -> torch.Tensor:
    """GLSL ``float shadow_receiver_depth(vec3 plane, vec4 lens, int face, vec2 uv, vec2 o)``."""
    face = torch.as_tensor(face).to(torch.int64).expand(uv.shape[:-1])
    z = plane[..., 0] + (plane[..., 1:] * o).sum(-1)
    axial = 1.0 / torch.maximum(z, 0.25 * plane[..., 0])
    ray = torch.linalg.vector_norm(shadow_cube_dir(face.clamp_min(0), uv + o), dim=-1)
    dist = torch.where(face < 0, axial, axial * ray)
    persp = (dist - lens[..., 2]) / lens[..., 3]
    return torch.where(lens[..., 0] < 1.5, z, persp)


def shadow_depth_slope(m) -> torch.Tensor:
    """GLSL ``vec2 shadow_depth_slope(vec3 m)``: the receiver plane's depth per uv unit."""
    mz = m[..., 2]
    mz = torch.where(mz.abs() > 1e-6, mz, torch.full_like(mz, 1e-6))
    g = -m[..., :2] / mz[..., None]
    n = torch.linalg.vector_norm(g, dim=-1, keepdim=True)
    return torch.where(n > 4.0, g * (4.0 / n.clamp_min(1e-30)), g)


def _disk_loop(map_, uv, plane, radius, dir_, size, lens, face, n_max, adaptive):
    """The filters' common walk: (per-sample stored depth, receiver depth, active) for each tap
    of the Vogel spiral of radius ``radius`` from the unit direction ``dir_`` (shadow_taps of them
    on a map region ``size`` texels a side where adaptive, else n_max); the receiver's depth at
    most 1 (a texel of depth 1 holds nothing and never occludes)."""
    n = shadow_taps(radius, size, n_max) if adaptive else torch.full_like(radius, float(n_max))
    inv_n = 1.0 / n
    dir_ = _f(dir_).expand(*radius.shape, 2)
    for i in range(int(n.max().item()) if n.numel() else 0):
        o = (torch.sqrt((i + 0.5) * inv_n) * radius)[..., None] * dir_
        yield (shadow_sample(map_, uv + o, face),
               shadow_receiver_depth(plane, lens, face, uv, o).clamp_max(1.0), i < n)
        dir_ = vogel_turn(dir_)


def shadow_blocker_depth(map_, uv, plane, search_uv, dir_, size, lens, face, adaptive=True):
    """GLSL ``float shadow_blocker_depth(sampler2D map, vec2 uv, vec3 plane, float search_uv,
    vec2 dir, float size, vec4 lens, int face, bool adaptive, out bool umbra)``: (mean occluder
    depth or -1, umbra): the receiver's own texel, then the disk's even taps, then its odd taps
    where the centre or an even tap occluded (summed in that order)."""
    search_uv = _f(search_uv).expand(uv.shape[:-1])
    centre = shadow_sample(map_, uv, face)
    zc = shadow_receiver_depth(plane, lens, face, uv, torch.zeros_like(uv)).clamp_max(1.0)
    hit = centre < zc
    total = torch.where(hit, centre, torch.zeros_like(centre))
    count = hit.float()
    taps = shadow_taps(search_uv, size, SHADOW_SEARCH_SAMPLES) if adaptive \
        else torch.full_like(search_uv, float(SHADOW_SEARCH_SAMPLES))
    walk = list(_disk_loop(map_, uv, plane, search_uv, dir_, size, lens, face,
                           SHADOW_SEARCH_SAMPLES, adaptive))
    for d, z, active in walk[0::2]:
        hit = active & (d < z)
        total = total + torch.where(hit, d, torch.zeros_like(d))
        count = count + hit.float()
    found = count > 0
    for d, z, active in walk[1::2]:
        hit = found & active & (d < z)
        total = total + torch.where(hit, d, torch.zeros_like(d))
        count = count + hit.float()
    depth = torch.where(count > 0, total / count.clamp_min(1.0), torch.full_like(total, -1.0))
    return depth, count == taps + 1


def shadow_pcf(map_, uv, plane, r_uv, dir_, size, lens, face, adaptive=True) -> torch.Tensor:
    """GLSL ``float shadow_pcf(sampler2D map, vec2 uv, vec3 plane, float r_uv, vec2 dir,
    float size, vec4 lens, int face, bool adaptive)``."""
    r_uv = _f(r_uv).expand(uv.shape[:-1])
    lit = torch.zeros_like(r_uv)
    taps = shadow_taps(r_uv, size, SHADOW_PCF_SAMPLES) if adaptive else \
        torch.full_like(r_uv, float(SHADOW_PCF_SAMPLES))
    for d, z, active in _disk_loop(map_, uv, plane, r_uv, dir_, size, lens, face,
                                   SHADOW_PCF_SAMPLES, adaptive):
        lit = lit + (active & (d >= z)).float()
    return lit * (1.0 / taps)


def shadow_pcss(map_, s, plane, lens, phi, face, adaptive=True) -> torch.Tensor:
    """GLSL ``float shadow_pcss(sampler2D map, vec3 s, vec3 plane, vec4 lens, float phi,
    int face, bool adaptive)``."""
    face_t = torch.as_tensor(face)
    outside = ((s < 0.0) | (s > 1.0)).any(-1)
    size = shadow_map_size(map_, face_t)
    texel_uv = 1.0 / size
    phi = _f(phi)
    dir_ = torch.stack([torch.cos(phi), torch.sin(phi)], -1)
    z = s[..., 2]
    ortho = lens[..., 0] < 1.5
    nearest = torch.where(ortho, torch.zeros_like(z), torch.clamp_min(
        ((lens[..., 2] + z * lens[..., 3]) * SHADOW_NEAREST_BLOCKER - lens[..., 2])
        / lens[..., 3], 0.0))
    search = torch.minimum(torch.maximum(shadow_penumbra_uv(lens, z, nearest), 1.5 * texel_uv),
                           _f(SHADOW_MAX_SEARCH_UV))
    blocker, umbra = shadow_blocker_depth(map_, s[..., :2], plane, search, dir_, size, lens,
                                          face, adaptive)
    r = torch.maximum(shadow_penumbra_uv(lens, z, blocker), texel_uv)
    vis = shadow_pcf(map_, s[..., :2], plane, r, dir_, size, lens, face, adaptive)
    if adaptive:
        vis = torch.where(umbra, torch.zeros_like(vis), vis)
    vis = torch.where(blocker < 0.0, torch.ones_like(vis), vis)
    return torch.where(outside, torch.ones_like(vis), vis)


def shadow_visibility(map_, s, dz, angle, depth_range, extent, phi) -> torch.Tensor:
    """GLSL ``float shadow_visibility(sampler2D map, vec3 s, vec2 dz, float angle,
    float depth_range, float extent, float phi)``: shadow_pcss of a directional light of angular
    radius ``angle`` at the light-space receiver point ``s`` (plane slope ``dz``)."""
    angle = _f(angle)
    t = torch.tan(angle.clamp(0.0, 0.3))
    z = s[..., 2]
    lens = torch.stack(torch.broadcast_tensors(torch.ones_like(z), t / _f(extent),
                                               torch.zeros_like(z), _f(depth_range)), -1)
    return shadow_pcss(map_, s, torch.cat([z[..., None], dz], -1), lens, phi, -1, False)


def shadow_light_visibility(map_, m, lens, offset, light_pos, l, p, n, phi) -> torch.Tensor:
    """GLSL ``float shadow_light_visibility(sampler2D map, mat4 m, vec4 lens, float offset,
    vec3 light_pos, vec3 l, vec3 p, vec3 n, float phi)`` for one map (``m``: [4, 4] with rows
    as in :class:`viewer.lighting.shadow_frames.ShadowFrame.matrix`; ``lens`` [4]; a single kind per call)."""
    kind = int(round(float(lens[0])))
    lens_b = lens.expand(*p.shape[:-1], 4)
    if kind == 0:
        return torch.ones(p.shape[:-1])
    light_pos = _f(light_pos)
    ortho = kind == SHADOW_ORTHO
    texel = _f(offset) if ortho else _f(offset) * torch.linalg.vector_norm(p - light_pos, dim=-1)
    q = shadow_receiver(p, n, l, texel)
    face = torch.full(p.shape[:-1], -1, dtype=torch.int64)
    rows = m.expand(*p.shape[:-1], 4, 4)
    if kind == SHADOW_CUBE:
        d = q - light_pos
        face = shadow_cube_face(d)[..., 2].long()
        a = shadow_cube_dir(face, torch.full((*face.shape, 2), 0.5))
        r = shadow_cube_dir(face, torch.stack(torch.broadcast_tensors(
            torch.ones(face.shape), torch.full(face.shape, 0.5)), -1)) - a
        t = shadow_cube_dir(face, torch.stack(torch.broadcast_tensors(
            torch.full(face.shape, 0.5), torch.ones(face.shape)), -1)) - a
        ra, ta = r + a, t + a
        zero = torch.zeros_like(a)

        def row(v, w):
            return torch.cat([v, w[..., None]], -1)
        rows = torch.stack([row(0.5 * ra, -0.5 * (ra * light_pos).sum(-1)),
                            row(0.5 * ta, -0.5 * (ta * light_pos).sum(-1)),
                            row(zero, torch.zeros_like(a[..., 0])),
                            row(a, -(a * light_pos).sum(-1))], -2)
    h = (rows @ torch.cat([q, torch.ones_like(q[..., :1])], -1)[..., None])[..., 0]
    w = h[..., 3]
    s = torch.stack([h[..., 0] / w, h[..., 1] / w, h[..., 2]], -1)
    m3 = rows[..., 3, :3]
    du = (rows[..., 0, :3] - s[..., 0:1] * m3) / w[..., None]
    dv = (rows[..., 1, :3] - s[..., 1:2] * m3) / w[..., None]
    if ortho:
        dz = shadow_depth_slope(shadow_plane_normal(du, dv, rows[..., 2, :3], n))
        return shadow_pcss(map_, s, torch.cat([s[..., 2:3], dz], -1), lens_b, phi, face)
    if kind == SHADOW_CUBE:
        dist = torch.linalg.vector_norm(q - light_pos, dim=-1)
        s = torch.stack([s[..., 0], s[..., 1], (dist - lens[2]) / lens[3]], -1)
    c = shadow_plane_normal(du, dv, -m3 / (w * w)[..., None], n)
    cz = c[..., 2]
    cz = torch.where(cz.abs() > 1e-30, cz, torch.full_like(cz, 1e-30))
    g = -c[..., :2] / cz[..., None]
    return shadow_pcss(map_, s, torch.cat([(1.0 / w)[..., None], g], -1), lens_b, phi, face)


def shadow_cascade_uv(s, c) -> torch.Tensor:
    """GLSL ``vec3 shadow_cascade_uv(vec3 s, vec4 c)``: ((uv - c.yz) c.x, depth)."""
    return torch.cat([(s[..., :2] - c[..., 1:3]) * c[..., 0:1], s[..., 2:3]], -1)


def shadow_cascade_index(uv, c0, c1, c2, c3, count) -> torch.Tensor:
    """GLSL ``int shadow_cascade_index(vec2 uv, vec4 c0, vec4 c1, vec4 c2, vec4 c3, int count)``
    (as int64)."""
    count = torch.as_tensor(count).to(torch.int64).expand(uv.shape[:-1])
    out = count - 1
    for k, c in reversed(list(enumerate((c0, c1, c2)))):
        t = (uv - c[..., 1:3]) * c[..., 0:1]
        inside = ((t >= SHADOW_CASCADE_MARGIN) & (t <= 1.0 - SHADOW_CASCADE_MARGIN)).all(-1)
        out = torch.where(inside & (k < count - 1), torch.full_like(out, k), out)
    return out


def shadow_cascade_visibility(map_, m, lens, offset, c0, c1, c2, c3, count, l, p, n, phi,
                              adaptive=True) -> torch.Tensor:
    """GLSL ``float shadow_cascade_visibility(sampler2D map, mat4 m, vec4 lens, float offset,
    vec4 c0, vec4 c1, vec4 c2, vec4 c3, int count, vec3 l, vec3 p, vec3 n, float phi,
    bool adaptive)`` for one light (``m`` [4, 4] rows as ``ShadowFrame.matrix``, ``lens`` [4],
    ``c0..c3`` [4] each)."""
    def xyz(q):
        return q @ m[:3, :3].T + m[:3, 3]
    k = shadow_cascade_index(xyz(p)[..., :2], c0, c1, c2, c3, count)
    c = torch.stack([c0, c1, c2, c3])[k]  # [..., 4]
    q = shadow_receiver(p, n, l, _f(offset) / c[..., 0])
    s = shadow_cascade_uv(xyz(q), c)
    du = m[0, :3] * c[..., 0:1]
    dv = m[1, :3] * c[..., 0:1]
    dz = shadow_depth_slope(shadow_plane_normal(du, dv, m[2, :3].expand_as(du), n))
    lens_c = torch.stack(torch.broadcast_tensors(lens[0], lens[1] * c[..., 0], lens[2],
                                                 lens[3]), -1)
    return shadow_pcss(map_, s, torch.cat([s[..., 2:3], dz], -1), lens_c, phi, -2 - k, adaptive)


def shadow_tile_visibility(map_, m, lens, offset, tile, l, p, n, phi) -> torch.Tensor:
    """GLSL ``float shadow_tile_visibility(sampler2D map, mat4 m, vec4 lens, float offset,
    int tile, vec3 l, vec3 p, vec3 n, float phi)`` for one tile (``m`` [4, 4] rows as
    ``ShadowFrame.matrix``, ``lens`` [4])."""
    q = shadow_receiver(p, n, l, _f(offset))
    s = q @ m[:3, :3].T + m[:3, 3]
    du, dv, dd = (m[i, :3].expand_as(q) for i in range(3))
    dz = shadow_depth_slope(shadow_plane_normal(du, dv, dd, n))
    lens_b = lens.expand(*p.shape[:-1], 4)
    face = torch.full(p.shape[:-1], -2 - int(tile), dtype=torch.int64)
    return shadow_pcss(map_, s, torch.cat([s[..., 2:3], dz], -1), lens_b, phi, face, True)
