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
    # width) with it once it is several pixels wide: doubling the angle about doubles it (the
    # bounds allow for the ellipse's curvature, the penumbra eating into the umbra, noise)
    for lo, hi in ((5.0, 10.0), (10.0, 20.0)):
        assert 1.5 < widths[hi] / widths[lo] < 2.8, widths


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
        "objects": [FLOOR, SPHERE], "render": {"tonemap": "none"}})
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
    The lighting pass's lookups are these functions (their parity check compares the two)."""
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


def test_the_blocker_search_reads_its_odd_taps_wherever_an_occluder_is_found():
    """The search reads the spiral's even taps, and its odd taps only where the receiver's texel
    or an even tap occluded: wherever the search finds an occluder, its mean depth and umbra are
    those of the whole spiral (every tap read, the same order of sums), and a receiver it calls
    lit has no occluder under the receiver's texel or any even tap. Random maps of small
    occluders, random receivers: exact equality (the same float32 operations)."""
    import torch

    from learned.twins.shadow import (
        SHADOW_SEARCH_SAMPLES,
        _disk_loop,
        shadow_blocker_depth,
        shadow_sample,
        shadow_taps,
    )

    g = torch.Generator().manual_seed(3)
    n = 128
    m = torch.ones(n, n)
    blobs = (torch.rand(n // 8, n // 8, generator=g) < 0.15).float()  # 8-texel occluders
    m = torch.where(blobs.repeat_interleave(8, 0).repeat_interleave(8, 1) > 0,
                    0.2 + 0.3 * torch.rand(n, n, generator=g), m)
    k = 4000
    uv = torch.rand(k, 2, generator=g)
    plane = torch.stack([0.6 + 0.3 * torch.rand(k, generator=g), torch.zeros(k),
                         torch.zeros(k)], -1)
    lens = torch.tensor([1.0, 0.01, 0.0, 10.0]).expand(k, 4)
    phi = 6.2831853 * torch.rand(k, generator=g)
    dir_ = torch.stack([torch.cos(phi), torch.sin(phi)], -1)
    search = 0.002 + 0.05 * torch.rand(k, generator=g)
    size = torch.tensor(float(n))
    depth, umbra = shadow_blocker_depth(m, uv, plane, search, dir_, size, lens, -1)
    # the whole spiral, every tap, summed centre, even taps, odd taps
    centre = shadow_sample(m, uv, -1)
    walk = list(_disk_loop(m, uv, plane, search, dir_, size, lens, -1, SHADOW_SEARCH_SAMPLES,
                           True))
    hits = [centre < plane[:, 0].clamp_max(1.0)] + [a & (d < z) for d, z, a in walk]
    vals = [centre] + [d for d, _, _ in walk]
    order = [0] + [1 + i for i in range(0, len(walk), 2)] + [1 + i for i in range(1, len(walk), 2)]
    total = torch.zeros(k)
    count = torch.zeros(k)
    for i in order:
        total = total + torch.where(hits[i], vals[i], torch.zeros_like(vals[i]))
        count = count + hits[i].float()
    found = count > 0
    even_found = hits[0] | torch.stack([hits[1 + i] for i in range(0, len(walk), 2)]).any(0)
    taps = shadow_taps(search, size, SHADOW_SEARCH_SAMPLES)
    assert 200 < int(even_found.sum()) < k - 200  # both outcomes are common
    assert (found & ~even_found).any()  # where only odd taps occlude: what the search skips
    assert torch.equal(depth[even_found], (total / count.clamp_min(1.0))[even_found])
    assert torch.equal(umbra[even_found], (count == taps + 1)[even_found])
    assert (depth[~even_found] == -1.0).all() and not umbra[~even_found].any()
