"""Shadow maps of directional lights, judged against analytic geometry: a sphere's shadow on a floor
lands where the light's rays through the sphere meet the floor (within two pixels), its penumbra
widens with the light's angular size as PCSS predicts, a lit plane never shadows itself from 0 to
85 degrees of incidence, no light leaks into a closed box, splats cast and receive shadows, and a
light-intensity slider reuses the map."""
import dataclasses

import numpy as np
import pytest
from scipy import ndimage
from shadow_scenes import (
    CAMERA,
    CENTER,
    DARK,
    FLOOR,
    FOV,
    HEIGHT,
    RADIUS,
    SPHERE,
    N,
    floor_points,
    sphere_pixels,
)

from viewer.renderer import Renderer
from viewer.scene.description import ObjectSpec, scene_from_dict


@pytest.fixture(scope="module")
def renderer(ctx):
    r = Renderer(ctx=ctx)
    yield r
    r.release()


def scene(objects, direction, render=None, light=None):
    return scene_from_dict({
        "camera": CAMERA, "environment": DARK,
        "lights": [{"type": "directional", "direction": list(direction), "intensity": 3.0,
                    **(light or {})}],
        "objects": objects, "render": {"tonemap": "none", **(render or {})}})


def analytic_shadow(direction, x, z):
    """Whether the ray from the floor point (x, 0, z) towards the light hits the sphere."""
    d = np.asarray(direction, float) / np.linalg.norm(direction)
    o = np.stack([x, np.zeros_like(x), z], axis=-1) - CENTER
    b = (o * d).sum(-1)
    c = (o * o).sum(-1) - RADIUS ** 2
    disc = b * b - c
    return (disc > 0) & (-b - np.sqrt(np.maximum(disc, 0)) > 0)


def visibility(renderer, objects, direction, **kw):
    """Lit radiance with shadows / without, on the floor (the light's own term)."""
    lit = renderer.render(scene(objects, direction, **kw)).radiance[..., 0]
    kw = dict(kw)
    kw["render"] = {**(kw.get("render") or {}), "shadows": False}
    free = renderer.render(scene(objects, direction, **kw)).radiance[..., 0]
    return lit / np.maximum(free, 1e-6)


@pytest.mark.parametrize("direction", [(1.0, 1.0, 0.0), (0.4, 1.0, -0.7), (-0.8, 1.0, 0.5)])
def test_shadow_lands_on_its_analytic_projection(renderer, direction):
    vis = visibility(renderer, [FLOOR, SPHERE], direction)
    x, z = floor_points()
    truth = analytic_shadow(direction, x, z)
    keep = ~sphere_pixels(x, z)
    ours = vis < 0.5
    band = ndimage.binary_dilation(truth, iterations=2) & ~ndimage.binary_erosion(truth,
                                                                                  iterations=2)
    wrong = (ours != truth) & keep & ~band
    assert truth[keep].sum() > 200  # a real shadow, seen beside the sphere
    assert wrong.sum() == 0, np.argwhere(wrong)[:10]
    assert (vis[keep & ~truth & ~band] > 0.999).all()  # lit floor stays lit


def _penumbra_pixels(vis, keep):
    return int(((vis > 0.05) & (vis < 0.95) & keep).sum())


def test_penumbra_widens_with_the_lights_size(renderer):
    direction = (1.0, 1.0, 0.0)
    x, z = floor_points()
    keep = ~sphere_pixels(x, z)
    widths = {}
    for deg in (0.0, 5.0, 10.0, 20.0):
        vis = visibility(renderer, [FLOOR, SPHERE], direction,
                         light={"angular_diameter_deg": deg})
        widths[deg] = _penumbra_pixels(vis, keep)
    assert widths[0.0] < widths[5.0] < widths[10.0] < widths[20.0], widths
    # PCSS: the penumbra's width grows as tan(angle), and the band's pixel count (perimeter x
    # width) with it once it is several pixels wide: doubling the angle about doubles it. Here
    # 2.109 (5 -> 10) and 2.096 (10 -> 20); over 19 geometries (the light's azimuth every 30 deg,
    # five elevations, maps of 1024 and 4096) the 38 ratios are 2.07 +- 0.046 (1.98-2.19): the
    # band is about +-5 standard deviations. It fails a light clamped at 15 deg (10 -> 20: 1.54)
    # and penumbrae growing as angle^0.8 (1.77) or angle^1.2 (2.47), which 1.5-2.8 passed.
    for lo, hi in ((5.0, 10.0), (10.0, 20.0)):
        assert 1.85 < widths[hi] / widths[lo] < 2.3, widths


@pytest.mark.parametrize("elevation", [90.0, 60.0, 30.0, 15.0, 5.0])
def test_no_acne_on_a_lit_plane(renderer, elevation):
    """No occluder: every floor pixel sees the light fully at any incidence up to 85 degrees."""
    e = np.radians(elevation)
    vis = visibility(renderer, [FLOOR], (np.cos(e), np.sin(e), 0.3 * np.cos(e)),
                     render={"shadow_size": 512})
    assert vis.min() > 0.999, (elevation, vis.min())


def test_no_light_leaks_into_a_closed_box(renderer):
    """Six walls overlapping at their edges (separate quads meeting edge to edge are not watertight
    for a rasteriser: a crack one texel wide would be a hole in the box, not a leak). What a map's
    texels cannot resolve is the crease where a wall meets the floor: pixels right at it read a
    partly lit filter footprint. Measured: 8 / 4 / 1 / 0 such pixels (of 4096) with 512 / 1024 /
    2048 / 4096-texel maps; so the default map may leak at one crease pixel, a 4096 map at none."""
    def wall(center, normal, size):
        return {"type": "plane", "center": center, "normal": normal, "size": size,
                "material": {"albedo": [0.5, 0.5, 0.5], "roughness": 0.9}}
    w = [2.1, 2.1]
    box = [wall([0, 0, 0], [0, 1, 0], w), wall([0, 2, 0], [0, -1, 0], w),
           wall([1, 1, 0], [-1, 0, 0], w), wall([-1, 1, 0], [1, 0, 0], w),
           wall([0, 1, 1], [0, 0, -1], w), wall([0, 1, -1], [0, 0, 1], w)]
    sc = scene_from_dict({
        "camera": {"position": [0, 1.8, 0.2], "target": [0, 0, 0], "fov_y": 80, "size": [64, 64]},
        "environment": {"procedural": "white", "width": 32, "intensity": 0.0},
        "lights": [{"type": "directional", "direction": [0.3, 1, 0.2], "intensity": 5.0}],
        "objects": box, "render": {"tonemap": "none"}})
    lit = renderer.render(sc.with_render(shadows=False)).radiance
    assert lit[..., :3].max() > 0.5  # without shadows the light reaches the floor
    img = renderer.render(sc).radiance[..., 0]
    assert (img > 0).sum() <= 1, np.argwhere(img > 0)
    fine = renderer.render(sc.with_render(shadow_size=4096)).radiance
    assert fine[..., :3].max() == 0.0, np.argwhere(fine[..., 0] > 0)


def _splat_sphere():
    from viewer.splats.generate import sphere_splats

    cloud = sphere_splats(3000, radius=RADIUS)
    return dataclasses.replace(cloud, means=cloud.means + CENTER.astype(np.float32))


def test_splats_cast_shadows(renderer):
    obj = ObjectSpec(type="splats", path="in-memory-splat-sphere")
    renderer.add_geometry(obj, _splat_sphere())
    direction = (1.0, 1.0, 0.0)
    sc = scene([FLOOR], direction)
    sc = dataclasses.replace(sc, objects=sc.objects + (obj,))
    lit = renderer.render(sc).radiance[..., 0]
    free = renderer.render(sc.with_render(shadows=False)).radiance[..., 0]
    x, z = floor_points()
    truth = analytic_shadow(direction, x, z)
    core = ndimage.binary_erosion(truth, iterations=3)
    assert core.sum() > 100
    assert np.median(lit[core] / np.maximum(free[core], 1e-6)) < 0.1


def test_splats_receive_shadows(renderer):
    """A floor made of flat splats under a mesh sphere: the splats in its shadow are dark."""
    from viewer.splats.data import Splats

    g = np.linspace(-3, 3, 120, dtype=np.float32)
    gx, gz = np.meshgrid(g, g)
    n = gx.size
    means = np.stack([gx.ravel(), np.zeros(n, np.float32), gz.ravel()], 1)
    floor = Splats(means=means, scales=np.tile(np.float32([0.04, 0.002, 0.04]), (n, 1)),
                   rotations=np.tile(np.float32([1, 0, 0, 0]), (n, 1)),
                   opacities=np.full(n, 0.99, np.float32), sh=np.full((n, 1, 3), 0.5, np.float32),
                   albedo=np.full((n, 3), 0.5, np.float32), roughness=np.full(n, 0.9, np.float32),
                   metallic=np.zeros(n, np.float32),
                   normals=np.tile(np.float32([0, 1, 0]), (n, 1)), has_materials=True)
    obj = ObjectSpec(type="splats", path="in-memory-splat-floor")
    renderer.add_geometry(obj, floor)
    direction = (1.0, 1.0, 0.0)
    sc = scene([SPHERE], direction)
    sc = dataclasses.replace(sc, objects=sc.objects + (obj,))
    lit = renderer.render(sc).radiance[..., 0]
    free = renderer.render(sc.with_render(shadows=False)).radiance[..., 0]
    x, z = floor_points()
    core = ndimage.binary_erosion(analytic_shadow(direction, x, z), iterations=3)
    assert core.sum() > 100
    assert np.median(lit[core] / np.maximum(free[core], 1e-6)) < 0.1
    outside = ~ndimage.binary_dilation(core, iterations=12) & ~sphere_pixels(x, z) & \
        (free > 0.05)
    assert np.median(lit[outside] / free[outside]) > 0.99


def test_a_light_slider_reuses_the_shadow_map(renderer):
    from viewer.gl.timing import PassTimer

    sc = scene([FLOOR, SPHERE], (1.0, 1.0, 0.0))
    renderer.profiler = timer = PassTimer(renderer.ctx)
    try:
        renderer.draw(sc)
        timer.enabled = True
        brighter = dataclasses.replace(sc, lights=(dataclasses.replace(sc.lights[0],
                                                                       intensity=6.0),))
        img = renderer.render(brighter).radiance
        drawn = set(timer.milliseconds())
        assert "shadow0" not in drawn and "shade" in drawn, drawn
        timer.enabled = False
        with renderer.every_pass():
            full = renderer.render(brighter).radiance
        np.testing.assert_array_equal(img, full)
        turned = dataclasses.replace(sc, lights=(dataclasses.replace(
            sc.lights[0], direction=(0.0, 0.7071, 0.7071)),))
        timer.enabled = True
        timer.reset()
        renderer.render(turned)
        assert "shadow0" in set(timer.milliseconds())
    finally:
        timer.enabled = False
        renderer.profiler = None


def test_the_environments_sun_casts_its_shadow(renderer):
    """Under a sky with a sun (shaded analytically: SUN_LIGHT) the sphere's shadow is where the
    sun's direction (extracted from the map, turned by the environment's rotation) projects it;
    the sky's own diffuse light is left unshadowed, so the test reads the darkening."""
    from viewer.graph.frame import env_to_world

    sc = scene_from_dict({
        "camera": {"position": [0, HEIGHT, 0], "target": [0, 0, 0], "up": [0, 0, -1],
                   "fov_y": FOV, "size": [N, N]},
        "environment": {"procedural": "sky", "width": 256, "rotation_deg": 40,
                        "sun_elevation_deg": 40},
        # the sun's shadow map (the rays trace its visibility instead: test_rt_light.py)
        "objects": [FLOOR, SPHERE], "render": {"tonemap": "none", "raytrace": False}})
    sun = renderer.resources.sun(sc.environment)
    assert sun is not None
    direction = env_to_world(sun.direction, sc.environment.rotation_deg)
    lit = renderer.render(sc).radiance[..., 0]
    free = renderer.render(sc.with_render(shadows=False)).radiance[..., 0]
    dark = free - lit
    assert dark.min() >= -1e-6  # shadows only take light away
    x, z = floor_points()
    truth = analytic_shadow(direction, x, z)
    keep = ~sphere_pixels(x, z)
    ours = dark > 0.5 * dark[truth & keep].max()
    band = ndimage.binary_dilation(truth, iterations=2) & ~ndimage.binary_erosion(truth,
                                                                                  iterations=2)
    assert (truth & keep).sum() > 200
    wrong = (ours != truth) & keep & ~band
    assert wrong.sum() == 0, np.argwhere(wrong)[:10]


def test_evicted_geometry_releases_its_shadow_copies(ctx):
    """The shadow pass's copies of a mesh go with the geometry entry holding it."""
    from viewer.gl.tracking import ObjectTracker

    r = Renderer(ctx=ctx)
    tracker = ObjectTracker(ctx).install()
    try:
        sc = scene([FLOOR, SPHERE], (1.0, 1.0, 0.0))
        r.render(sc)
        spass = r.resources.shadow_pass()
        # the sphere's level of detail (the floor under it, lit from above, is left out)
        copies = len(spass.batches)
        assert copies >= 1 and len(spass.casters) >= 2
        before = tracker.live()
        r.geometry_cache.clear()
        assert len(spass.batches) == 0 and len(spass.casters) == 0
        after = tracker.live()
        assert after["VertexArray"] <= before["VertexArray"] - copies
    finally:
        tracker.uninstall()
        r.release()


def umbra_points(direction, angular_radius, x, z, margin=0.05):
    """Floor points (x, 0, z) from which the sphere hides the whole light disc (every ray within
    ``angular_radius`` of ``direction``), with ``margin`` world units to spare: the distance from
    the sphere's centre to the central ray is below R - margin - t sin(angular_radius) at the
    ray's closest approach t."""
    d = np.asarray(direction, float) / np.linalg.norm(direction)
    o = np.stack([x, np.zeros_like(x), z], axis=-1)
    t = ((CENTER - o) * d).sum(-1)
    closest = o + t[..., None] * d
    dist = np.linalg.norm(closest - CENTER, axis=-1)
    return (t > 0) & (dist < RADIUS - margin - t * np.sin(angular_radius))


@pytest.mark.parametrize("cascades", [1, "auto"])
def test_a_wide_light_over_a_large_floor_keeps_its_umbra(renderer, cascades):
    """A 6.5-degree light over a 100 m floor: the map's depth range (so the blocker search's
    radius, which must cover every occluder that could reach a receiver) is the whole scene's,
    far wider than the small sphere's shadow. The receiver's own texel is searched too, so a point
    whose light the sphere hides entirely is in the umbra, not taken for lit where the sparse
    search misses the sphere."""
    floor = {**FLOOR, "size": [100, 100]}
    direction, diameter = (1.0, 1.0, 0.0), 6.5
    vis = visibility(renderer, [floor, SPHERE], direction,
                     light={"angular_diameter_deg": diameter},
                     render={"shadow_cascades": cascades})
    x, z = floor_points()
    umbra = umbra_points(direction, np.radians(diameter / 2.0), x, z) & ~sphere_pixels(x, z)
    assert umbra.sum() > 20, umbra.sum()
    assert np.percentile(vis[umbra], 95) < 0.1, np.percentile(vis[umbra], [50, 95, 100])


def test_an_empty_texel_never_occludes():
    """A map texel of depth 1 holds nothing: a receiver near the map's far end whose plane, tilted
    towards grazing, passes depth 1 within the filters' reach is lit over an empty map (it once
    counted the empty texels beyond depth 1 as occluders), and a real occluder still shadows it.
    The lighting pass's lookups are these functions (the parity check shadow:lookups holds the
    GLSL to them: at most 1 in 500 lookups beyond 1e-5, each within one flipped sample)."""
    import torch

    from learned.twins.shadow import shadow_pcss

    n = 64
    empty = torch.ones(n, n)
    # receivers at depths 0.990 .. 0.999, the plane's depth rising 4 per uv unit (the clamp's
    # steepest) along u: 8 texels away it lies beyond 1
    z = torch.linspace(0.990, 0.999, 10)
    s = torch.stack([torch.full_like(z, 0.5), torch.full_like(z, 0.5), z], -1)
    plane = torch.stack([z, torch.full_like(z, 4.0), torch.zeros_like(z)], -1)
    lens = torch.tensor([1.0, 0.1, 0.0, 1.0])  # a wide light: search and PCF reach far
    lit = shadow_pcss(empty, s, plane, lens, 0.3, -1)
    assert torch.equal(lit, torch.ones_like(lit))
    blocked = empty.clone()
    blocked[28:36, 28:36] = 0.5  # an occluder over the receivers' own texels
    assert (shadow_pcss(blocked, s, plane, lens, 0.3, -1) < 0.5).all()


def _plain_blocker_search(depth_map, uv, z, search, phi):
    """The blocker search as lib/shadow.glsl documents it, written plainly (float64, a sample's
    angle by cos and sin, not the shaders' rotation): the receiver's texel, the Vogel spiral's
    taps (ceil(pi / 2 (r size)^2) of them, 4 to 16) at sqrt((i + 0.5) / n) r (cos, sin)(phi +
    i golden); the odd taps count only where the texel or an even tap occludes. -> (mean occluder
    depth or -1, umbra, whether only odd taps occlude, the taps' least distance to a texel
    boundary in texels)."""
    size = depth_map.shape[0]
    n = int(np.clip(np.ceil(np.pi / 2.0 * (search * size) ** 2), 4, 16))
    i = np.arange(n)
    radius = np.sqrt((i + 0.5) / n) * search
    angle = phi + i * 2.39996323
    taps = np.concatenate([[uv], uv + radius[:, None] * np.stack([np.cos(angle),
                                                                  np.sin(angle)], -1)])
    t = taps * size
    edge = np.abs(t - np.round(t)).min()
    idx = np.clip(np.floor(t).astype(int), 0, size - 1)
    d = depth_map[idx[:, 1], idx[:, 0]].astype(np.float64)
    occludes = d < min(z, 1.0)
    if not (occludes[0] or occludes[1::2].any()):  # the centre and the even taps (i = 0, 2, ..)
        return -1.0, False, bool(occludes.any()), edge
    return float(d[occludes].mean()), bool(occludes.all()), False, edge


def test_the_blocker_search_reads_its_odd_taps_wherever_an_occluder_is_found():
    """The search reads the spiral's even taps, and its odd taps only where the receiver's texel
    or an even tap occluded: wherever the search finds an occluder, its mean depth and umbra are
    those of the whole spiral, and a receiver it calls lit has no occluder under the receiver's
    texel or any even tap - against a plain search over a map of 8-texel occluders, written here
    from the shader's documentation (not the twin's helpers). Receivers with a tap within 1e-3
    texel of a texel boundary are left out (there the two spirals' rounding may read
    neighbours). The GLSL is the twin's within one flipped sample (parity shadow:lookups)."""
    import torch

    from learned.twins.shadow import shadow_blocker_depth

    rng = np.random.default_rng(3)
    n = 128
    blobs = rng.random((n // 8, n // 8)) < 0.15
    m = np.where(np.repeat(np.repeat(blobs, 8, 0), 8, 1),
                 0.2 + 0.3 * rng.random((n, n)), 1.0).astype(np.float32)
    k = 2000
    uv = rng.random((k, 2)).astype(np.float32)
    z = (0.6 + 0.3 * rng.random(k)).astype(np.float32)
    phi = (6.2831853 * rng.random(k)).astype(np.float32)
    search = (0.002 + 0.05 * rng.random(k)).astype(np.float32)
    plane = torch.from_numpy(np.stack([z, np.zeros(k), np.zeros(k)], -1).astype(np.float32))
    dir_ = torch.from_numpy(np.stack([np.cos(phi), np.sin(phi)], -1))
    lens = torch.tensor([1.0, 0.01, 0.0, 10.0]).expand(k, 4)
    depth, umbra = shadow_blocker_depth(torch.from_numpy(m), torch.from_numpy(uv), plane,
                                        torch.from_numpy(search), dir_, torch.tensor(float(n)),
                                        lens, -1)
    plain = [_plain_blocker_search(m, uv[j].astype(np.float64), float(z[j]), float(search[j]),
                                   float(phi[j])) for j in range(k)]
    want = np.array([p[0] for p in plain])
    want_umbra = np.array([p[1] for p in plain])
    odd_only = np.array([p[2] for p in plain])
    clear = np.array([p[3] for p in plain]) > 1e-3
    assert clear.sum() > 0.9 * k
    found = want >= 0.0
    assert 200 < int((found & clear).sum()) < k - 200  # both outcomes are common
    assert (want_umbra & clear).sum() > 20 and (found & ~want_umbra & clear).sum() > 50
    assert (odd_only & clear).sum() > 20  # where the skipped odd taps would have found one
    np.testing.assert_array_equal(depth.numpy()[clear] >= 0.0, found[clear])
    np.testing.assert_allclose(depth.numpy()[clear & found], want[clear & found], rtol=1e-6)
    np.testing.assert_array_equal(umbra.numpy()[clear], want_umbra[clear])
