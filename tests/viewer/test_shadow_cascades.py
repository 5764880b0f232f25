"""Cascaded shadow maps (viewer/lighting/cascades.py) on a 100 m floor: a small sphere near the camera and
a large one 30 m away under a directional light. Both shadows land on their analytic projections
(the rays from the floor towards the light that meet a sphere), the near shadow's edge is sharper
than one whole-scene map gives, a small-object scene keeps one map, and a small camera move does
not move the shadow on the floor (texel snapping)."""
import dataclasses

import numpy as np
import pytest
from scipy import ndimage

from viewer.errors import SceneError
from viewer.lighting.cascades import cascade_count, cascade_frames, practical_splits
from viewer.renderer import Renderer
from viewer.scene.bounds import Bounds
from viewer.scene.description import scene_from_dict

N = 128
LIGHT = (0.7, 1.0, -0.5)
SPHERES = ((np.array([0.0, 0.5, -4.0]), 0.3), (np.array([4.0, 3.0, -30.0]), 2.0))
FLOOR = {"type": "plane", "center": [0, 0, 0], "size": [100, 100], "normal": [0, 1, 0],
         "material": {"albedo": [0.5, 0.5, 0.5], "roughness": 0.9}}

@pytest.fixture(scope="module")
def renderer(ctx):
    r = Renderer(ctx=ctx)
    yield r
    r.release()

def scene(cascades="auto", dx=0.0, objects=None, shadows=True, size=100.0):
    floor = {**FLOOR, "size": [size, size]}
    objs = objects if objects is not None else [floor] + [
        {"type": "sphere", "center": c.tolist(), "radius": r} for c, r in SPHERES]
    return scene_from_dict({
        "camera": {"position": [dx, 3.0, 0.0], "target": [dx, 0.0, -8.0], "fov_y": 50,
                   "size": [N, N]},
        "environment": {"procedural": "white", "width": 32, "intensity": 0.0},
        "lights": [{"type": "directional", "direction": list(LIGHT), "intensity": 3.0}],
        "objects": objs,
        # shadow maps (no rays: they trace the sun's visibility instead of its map)
        "render": {"tonemap": "none", "shadow_cascades": cascades, "shadow_size": 1024,
                   "raytrace": False,
                   "shadows": shadows}})

def visibility(renderer, sc):
    lit = renderer.render(sc).radiance[..., 0]
    free = renderer.render(sc.with_render(shadows=False)).radiance[..., 0]
    return lit / np.maximum(free, 1e-6)

def floor_and_truth(sc, light=LIGHT):
    """Per pixel (row 0 at the top): the floor point its view ray meets (NaN: none), whether the
    ray meets a sphere first, and which sphere's shadow the floor point is in (0 none, 1, 2)."""
    cam = sc.camera
    rays = cam.view_rays_ws().astype(np.float64)
    o = np.asarray(cam.position, np.float64)
    t = np.where(rays[..., 1] < -1e-6, -o[1] / np.minimum(rays[..., 1], -1e-6), np.nan)
    p = o + rays * t[..., None]
    p[(np.abs(p[..., 0]) > 49.0) | (np.abs(p[..., 2]) > 49.0)] = np.nan  # past the floor
    on_sphere = np.zeros(t.shape, bool)
    shadow = np.zeros(t.shape, int)
    d = np.asarray(light) / np.linalg.norm(light)
    for k, (c, r) in enumerate(SPHERES):
        oc = o - c
        b = (rays * oc).sum(-1)
        disc = b * b - ((oc * oc).sum(-1) - r * r)
        on_sphere |= (disc > 0) & (-b - np.sqrt(np.maximum(disc, 0)) < t)
        q = p - c
        b = (q * d).sum(-1)
        disc = b * b - ((q * q).sum(-1) - r * r)
        shadow[(disc > 0) & (-b - np.sqrt(np.maximum(disc, 0)) > 0)] = k + 1
    return p, on_sphere, shadow

def edge_width(vis, truth, keep):
    """The shadow edge's 10-90 % width in pixels: the pixels between 10 and 90 % visibility
    within 4 pixels of the analytic edge, per pixel of that edge."""
    edge = truth & ~ndimage.binary_erosion(truth)
    near = ndimage.binary_dilation(edge, iterations=4) & keep
    return float(((vis > 0.1) & (vis < 0.9) & near).sum()) / max(int(edge.sum()), 1)

def test_small_object_scenes_keep_one_map(renderer):
    small = scene(objects=[{**FLOOR, "center": [0, 0, -5], "size": [3.0, 3.0]},
                           {"type": "sphere", "center": [0, 0.5, -3.0], "radius": 0.3}])
    assert cascade_count("auto", renderer.bounds(small), small.camera, 1024, LIGHT) == 1
    g = renderer.graph(small)
    shadow = [p for p in g.passes if p.name.startswith("shadow")]
    assert [p.name for p in shadow] == ["shadow0"] and "camera" not in shadow[0].inputs
    big = scene()
    assert cascade_count("auto", renderer.bounds(big), big.camera, 1024, LIGHT) >= 2
    # the same passes, one atlas; the camera enters the cascaded pass's inputs only
    gb = renderer.graph(big)
    assert [p.name for p in gb.passes] == [p.name for p in g.passes]
    assert [p.inputs.get("camera") for p in gb.passes if p.name == "shadow0"] == [big.camera]
    assert cascade_count("auto", renderer.bounds(big), big.camera, 1024, LIGHT) >= 2

def test_bad_cascade_setting_is_named():
    with pytest.raises(SceneError, match="shadow_cascades"):
        scene(cascades=5)
    with pytest.raises(SceneError, match="shadow_cascades"):
        scene(cascades="many")

def test_splits_and_fits():
    s = practical_splits(1.0, 100.0, 4, lam=0.5)
    assert s[0] == 1.0 and s[-1] == 100.0 and all(a < b for a, b in zip(s, s[1:]))
    # lambda 0: uniform, 1: logarithmic
    assert np.allclose(practical_splits(1.0, 100.0, 2, lam=0.0), [1.0, 50.5, 100.0])
    assert np.allclose(practical_splits(1.0, 100.0, 2, lam=1.0), [1.0, 10.0, 100.0])
    sc = scene()
    bounds = Bounds((-50.0, 0.0, -50.0), (50.0, 4.0, 50.0))
    cf = cascade_frames(bounds, LIGHT, sc.camera, 3, 1024)
    sides = [f.extent[0] for f in cf.faces]
    assert sides == sorted(sides) and sides[0] < 0.2 * cf.base.extent[0]
    # a cascade's origin sits on whole texels of its own grid (snapping), and a small camera
    # move keeps each cascade's size and grid: its texels stay put in the world (no shimmer)
    moved = cascade_frames(bounds, LIGHT, scene(dx=0.031).camera, 3, 1024)
    for (scale, u0, v0, _), (scale2, u2, v2, _), f in zip(cf.boxes, moved.boxes, cf.faces):
        texel = 1.0 / (scale * f.resolution)
        assert scale2 == scale
        for a in (u0, v0, u2 - u0, v2 - v0):
            assert abs(a / texel - round(a / texel)) < 1e-6

def test_cascaded_shadows_land_and_are_sharper(renderer):
    sc = scene()
    p, on_sphere, shadow = floor_and_truth(sc)
    keep = np.isfinite(p[..., 0]) & ~ndimage.binary_dilation(on_sphere, iterations=1)
    vis = visibility(renderer, sc)
    one = visibility(renderer, scene(cascades=1))
    for k, tol in ((1, 2), (2, 3)):  # the far sphere's shadow: a few pixels
        truth = shadow == k
        assert truth[keep].sum() > 15, k
        band = ndimage.binary_dilation(truth, iterations=tol) & ~ndimage.binary_erosion(
            truth, iterations=tol)
        region = ndimage.binary_dilation(truth, iterations=12) & keep & ~band
        wrong = ((vis < 0.5) != truth) & region
        assert wrong.sum() == 0, (k, np.argwhere(wrong)[:10])
    truth = shadow == 1
    sharp, blurred = edge_width(vis, truth, keep), edge_width(one, truth, keep)
    print(f"near shadow edge 10-90 % width: cascades {sharp:.2f} px, one map {blurred:.2f} px")
    assert sharp < 0.6 * blurred, (sharp, blurred)

def test_a_small_camera_move_does_not_move_the_shadow(renderer):
    centres = []
    for dx in (0.0, 0.013, 0.029):
        sc = scene(dx=dx)
        p, on_sphere, shadow = floor_and_truth(sc)
        keep = np.isfinite(p[..., 0]) & ~ndimage.binary_dilation(on_sphere, iterations=1)
        near = ndimage.binary_dilation(shadow == 1, iterations=6) & keep
        w = np.where(near, 1.0 - np.clip(visibility(renderer, sc), 0.0, 1.0), 0.0)
        centres.append((np.nan_to_num(p[..., [0, 2]]) * w[..., None]).sum((0, 1)) / w.sum())
    # one pixel's footprint on the floor at the near shadow (about 5.4 m from the camera)
    pixel = 2.0 * np.tan(np.radians(25.0)) * 5.4 / N
    for c in centres[1:]:
        print(f"shadow centre moved {np.linalg.norm(c - centres[0]) / pixel:.3f} px")
        assert np.linalg.norm(c - centres[0]) < 0.5 * pixel, (centres, pixel)


def test_the_suns_map_is_cascaded_too(renderer):
    """The environment's sun (a sky with one, no lights): ``shadowsun`` is cascaded (the camera
    among its inputs) and the near sphere's shadow lands on its analytic projection."""
    from viewer.graph.frame import env_to_world

    sky = scene_from_dict({"environment": {"procedural": "sky", "width": 64},
                           "objects": [FLOOR]}).environment
    sc = dataclasses.replace(scene(), lights=(), environment=sky).with_render(
        shadow_softness=0.2)  # a sharp sun: the test judges where the shadow is
    passes = {p.name: p for p in renderer.graph(sc).passes}
    assert passes["shadowsun"].inputs.get("camera") == sc.camera
    sun = renderer.resources.sun(sky)
    p, on_sphere, shadow = floor_and_truth(sc, env_to_world(sun.direction, sky.rotation_deg))
    keep = np.isfinite(p[..., 0]) & ~ndimage.binary_dilation(on_sphere, iterations=1)
    vis = visibility(renderer, sc)
    truth = shadow == 1
    assert truth[keep].sum() > 50
    band = ndimage.binary_dilation(truth, iterations=2) & ~ndimage.binary_erosion(
        truth, iterations=2)
    region = ndimage.binary_dilation(truth, iterations=12) & keep & ~band
    # the sky lights the shadow too: the sun's share of the light is what the shadow removes
    dark = vis < 0.5 * (1.0 + np.median(vis[truth & keep & ~band]))
    assert (dark != truth)[region].sum() == 0, np.argwhere((dark != truth) & region)[:10]


def test_a_camera_move_redraws_cascades_only(renderer):
    small = scene(objects=[{**FLOOR, "center": [0, 0, -5], "size": [3.0, 3.0]},
                           {"type": "sphere", "center": [0, 0.5, -4.0], "radius": 0.3}])
    for sc, redrawn in ((scene(), True), (small, False)):
        renderer.draw(sc)
        moved = dataclasses.replace(sc, camera=dataclasses.replace(
            sc.camera, position=(0.02, 3.0, 0.0)))
        why = {p.name: p.why for p in renderer.graph(moved).passes}
        assert (why["shadow0"] != "inputs unchanged") == redrawn, why["shadow0"]
