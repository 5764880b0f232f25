"""What a shadow pass draws of each mesh (viewer/passes/shadow.py): the coarsest level of detail
within ``shadow_lod_error`` texels of the map (viewer/geometry/simplify.py), judged against the
analytic sphere it approximates and against the shadow of the whole mesh; and no flat mesh that
hides nothing from the light (a floor under the scene, lit from above)."""
import numpy as np
import pytest
from shadow_scenes import CAMERA, DARK, FLOOR, SPHERE

from viewer.errors import SceneError
from viewer.geometry import primitives
from viewer.geometry.simplify import lod_level, simplify
from viewer.geometry.solid import OUTWARD, plane_of
from viewer.lighting.shadow_frames import cube_frames, directional_frame, spot_frame
from viewer.passes import shadow as shadow_module
from viewer.renderer import Renderer
from viewer.scene.bounds import Bounds
from viewer.scene.description import load_scene, scene_from_dict

RADIUS = 0.9


def _surface_samples(positions, indices, per_side=6):
    """Points spread over every triangle (a barycentric grid, corners and edges included)."""
    tri = np.asarray(positions, np.float64)[np.asarray(indices).reshape(-1, 3)]
    u, v = np.meshgrid(np.linspace(0, 1, per_side), np.linspace(0, 1, per_side))
    keep = u + v <= 1.0
    u, v = u[keep], v[keep]
    w = 1.0 - u - v
    return (tri[:, None, 0] * w[None, :, None] + tri[:, None, 1] * u[None, :, None]
            + tri[:, None, 2] * v[None, :, None]).reshape(-1, 3)


def test_a_simplified_sphere_stays_within_its_error_of_the_sphere():
    """Every level's surface lies near the analytic sphere: meshoptimizer's error (at most the
    level's size x 2^-level) measures its kept vertices against the planes of the faces they
    replace, not the chord sag inside the larger triangles, which adds to it; measured here,
    1.6-2.1 x the bound beyond the whole mesh's own distance from the sphere at levels 6-10 (a
    deterministic simplifier: 2.5 x holds with margin). Each coarser level keeps fewer
    triangles."""
    mesh = primitives.sphere(center=(0.0, 0.0, 0.0), radius=RADIUS)
    tri = mesh.indices.reshape(-1, 3)

    def off_sphere(pos, idx):
        return np.abs(np.linalg.norm(_surface_samples(pos, idx), axis=1) - RADIUS).max()

    own = off_sphere(mesh.positions, tri)  # the tessellation's own chord error
    size = 2.0 * RADIUS
    counts = []
    for level in (10, 9, 8, 7, 6):
        s = simplify(mesh.positions, tri, level)
        assert s is not None, level
        bound = size * 2.0 ** -level
        assert s.error <= bound * 1.0001, (level, s.error, bound)
        assert off_sphere(s.positions, s.indices) <= own + 2.5 * bound, level
        assert s.orientation == OUTWARD  # still a closed solid: its faces away stay culled
        counts.append(len(s.indices))
    assert all(a > b for a, b in zip(counts, counts[1:])), counts
    assert counts[0] < len(tri)
    assert simplify(mesh.positions, tri[:100], 6) is None  # too small to be worth a copy


def test_levels_follow_the_tolerance():
    assert lod_level(1.8, 1.8 / 512) == 9
    assert lod_level(1.8, 1.8 / 511.0) == 9  # the coarsest level within the tolerance
    assert lod_level(1.8, 1.8 / 513.0) == 10
    assert lod_level(1.8, 10.0) == 0
    assert lod_level(1.8, 0.0) is None and lod_level(1.8, 1e-12) is None  # whole meshes
    assert lod_level(0.0, 0.01) is None


def test_texels_where_a_mesh_lies():
    """An orthographic map's texel is one size; a perspective or cube face's grows with the
    distance along its axis, taken at the box's nearest corner, and at a light inside the box
    is the texel at the frame's near distance."""
    scene = Bounds((-2.0, 0.0, -2.0), (2.0, 2.0, 2.0))
    box = ((-0.5, 0.5, -0.5), (0.5, 1.5, 0.5))
    ortho = directional_frame(scene, (0.3, 1.0, 0.2), 512)
    assert ortho.texel_at(box) == ortho.texel_world
    spot = spot_frame(scene, (0.0, 6.0, 0.0), (0.0, 1.0, 0.0), 40.0, 512)
    assert spot.texel_at(box) == pytest.approx(spot.texel_world * 4.5, rel=1e-6)
    inside = cube_frames(scene, (0.0, 1.0, 0.0), 64)
    for f in inside.faces:
        assert f.texel_at(box) == pytest.approx(f.texel_world * f.near)


def _scene(lights, **render):
    return scene_from_dict({"camera": CAMERA, "environment": DARK, "objects": [FLOOR, SPHERE],
                            "lights": lights,
                            "render": {"tonemap": "none", "shadow_size": 512,
                                       "shadow_cube_size": 256, **render}})


LIGHTS = {
    "sun": [{"type": "directional", "direction": [0.3, 1.0, 0.2]}],
    "wide": [{"type": "directional", "direction": [0.3, 1.0, 0.2], "angular_diameter_deg": 5.0}],
    "point": [{"type": "point", "position": [1.0, 3.0, 0.5], "intensity": 20.0}],
}


@pytest.fixture(scope="module")
def renderer(ctx):
    r = Renderer(ctx=ctx)
    yield r
    r.release()


def _visibility(renderer, scene):
    lit = renderer.render(scene).radiance[..., 0]
    free = renderer.render(scene.with_render(shadows=False)).radiance[..., 0]
    ok = free > 1e-4
    return np.where(ok, lit / np.where(ok, free, 1.0), np.nan)


def _dilate(mask, r):
    out = mask.copy()
    for dy in range(-r, r + 1):
        for dx in range(-r, r + 1):
            out |= np.roll(np.roll(mask, dy, 0), dx, 1)
    return out


@pytest.mark.parametrize("kind", sorted(LIGHTS))
def test_a_simplified_caster_moves_only_the_shadows_edge(renderer, kind):
    """The sphere (12k triangles) drawn at half a texel's error: the map's silhouette moves by at
    most half a texel, so a pixel's filter taps change only within half a texel of the shadow's
    edge. Every pixel whose visibility changes by more than 0.01 lies within two pixels (at this
    camera a 512 map's texel is under a pixel) of the whole mesh's penumbra (0 < v < 1); the
    umbra and the lit floor are untouched. And it is a coarser mesh: the level drawn keeps at
    most half the triangles."""
    whole = _visibility(renderer, _scene(LIGHTS[kind], shadow_lod_error=0.0))
    lod = _visibility(renderer, _scene(LIGHTS[kind]))
    ok = np.isfinite(whole) & np.isfinite(lod)
    assert (whole[ok] < 0.05).sum() > 30  # a shadow is there to compare
    edge = _dilate(ok & (whole > 1e-4) & (whole < 1.0 - 1e-4), 2)
    changed = ok & (np.abs(lod - whole) > 0.01)
    assert not (changed & ~edge).any(), np.argwhere(changed & ~edge)[:5]
    assert np.abs(lod - whole)[ok].mean() < 2e-3
    spass = renderer.resources.shadow_pass()
    counts = [len(c[0].indices) for c in spass.casters.values()
              if isinstance(c, tuple) and len(c) == 1 and c[0] is not None]
    assert counts and min(counts) <= len(primitives.sphere(
        center=SPHERE["center"], radius=SPHERE["radius"]).indices.reshape(-1, 3)) // 2


FLOOR_PLANE = (np.array([0.0, 1.0, 0.0]), 0.0)
FLOOR_BOX = ((-5.0, 0.0, -5.0), (5.0, 0.0, 5.0))
BALL_BOX = ((-0.5, 0.5, -0.5), (0.5, 1.5, 0.5))
SCENE_BOUNDS = Bounds((-5.0, 0.0, -5.0), (5.0, 1.5, 5.0))


@pytest.mark.parametrize("frame, boxes, hides", [
    (directional_frame(SCENE_BOUNDS, (0.3, 1.0, 0.2), 64), [BALL_BOX], False),
    (directional_frame(SCENE_BOUNDS, (0.3, -1.0, 0.2), 64), [BALL_BOX], True),  # lit from below
    (directional_frame(SCENE_BOUNDS, (1.0, 0.0, 0.0), 64), [BALL_BOX], True),  # grazing: drawn
    (directional_frame(SCENE_BOUNDS, (0.3, 1.0, 0.2), 64),
     [((-0.5, -0.2, -0.5), (0.5, 1.0, 0.5))], True),  # a ball sunk through the floor
    (directional_frame(SCENE_BOUNDS, (0.3, 1.0, 0.2), 64),
     [((-0.5, 0.0, -0.5), (0.5, 1.0, 0.5))], False),  # resting on it
    (spot_frame(SCENE_BOUNDS, (1.0, 3.0, 0.5), (0.2, 1.0, 0.1), 50.0, 64), [BALL_BOX], False),
    (spot_frame(SCENE_BOUNDS, (1.0, -3.0, 0.5), (0.2, -1.0, 0.1), 50.0, 64), [BALL_BOX], True),
])
def test_which_flat_meshes_hide_nothing(frame, boxes, hides):
    assert shadow_module.occludes_nothing(FLOOR_PLANE, frame, boxes, FLOOR_BOX) is (not hides)


def test_plane_of_finds_flat_meshes_only():
    floor = primitives.plane(center=(0.0, 2.0, 0.0), size=(4.0, 4.0))
    n, c = plane_of(floor.positions)
    assert abs(abs(n[1]) - 1.0) < 1e-9 and c == pytest.approx(2.0 * n[1])
    assert plane_of(primitives.sphere(center=(0, 0, 0), radius=1.0).positions) is None
    bent = floor.positions.copy()
    bent[0, 1] += 1e-3
    assert plane_of(bent) is None


@pytest.mark.parametrize("kind", ["sun", "point"])
def test_a_floor_left_out_of_the_map_changes_no_pixel(renderer, kind, monkeypatch):
    """The floor under the sphere, lit from above, is left out of the map (the pass asks
    occludes_nothing, which answers yes for it), and the image is the one with the floor drawn,
    bit for bit, but where the drawn floor shadows itself: at most a few pixels near the map's
    far end (a point light's farthest floor), where the receiver's plane, extended over the
    filter's reach, passes the floor's own depth; there the image without it is brighter, never
    darker. (An empty texel never occludes, so the floor left out shadows nothing.)"""
    asked = []

    def spy(plane, frame, boxes, own):
        answer = original(plane, frame, boxes, own)
        asked.append(answer)
        return answer
    original = shadow_module.occludes_nothing
    monkeypatch.setattr(shadow_module, "occludes_nothing", spy)
    left_out = renderer.render(_scene(LIGHTS[kind])).radiance
    assert asked and all(asked)
    monkeypatch.setattr(shadow_module, "occludes_nothing", lambda *a: False)
    drawn = Renderer(ctx=renderer.ctx)
    try:
        with_floor = drawn.render(_scene(LIGHTS[kind])).radiance
    finally:
        drawn.release()
    changed = np.abs(left_out - with_floor).max(axis=-1) > 0.0
    assert changed.sum() <= 4
    assert np.all(left_out[changed] >= with_floor[changed])


def test_lod_error_is_checked(tmp_path):
    path = tmp_path / "s.toml"
    path.write_text("[render]\nshadow_lod_error = 5\n")
    with pytest.raises(SceneError, match="shadow_lod_error"):
        load_scene(path)
    path.write_text("[render]\nshadow_lod_error = 0\n")
    assert load_scene(path).render.shadow.lod_error == 0.0


BATCH_OBJECTS = [FLOOR, SPHERE,
                 {"type": "sphere", "center": [1.6, 0.8, 0.4], "radius": 0.5},
                 {"type": "sphere", "center": [-1.4, 0.6, -0.8], "radius": 0.4},
                 {"type": "plane", "center": [0.0, 1.0, -2.0], "size": [2.0, 2.0],
                  "normal": [0.0, 0.0, 1.0]}]  # an open mesh: both faces drawn


@pytest.mark.parametrize("kind", ["sun", "point"])
def test_a_maps_casters_are_drawn_in_one_call_per_culling(ctx, kind, monkeypatch):
    """A map's casters are joined into one draw per way of culling them (the spheres' faces
    turned from the light culled, the open wall's both faces drawn): the same maps, texel for
    texel, as one draw a mesh; joined once for a set of meshes and levels, and released with
    the meshes' geometry."""
    lights = {"sun": LIGHTS["sun"], "point": LIGHTS["point"]}[kind]
    sc = scene_from_dict({"camera": CAMERA, "environment": DARK, "objects": BATCH_OBJECTS,
                          "lights": lights, "render": {"tonemap": "none", "shadow_size": 512,
                                                        "shadow_cube_size": 256}})
    original = shadow_module.ShadowPass._batch_array
    calls = []

    def spy(self, batch, variant):
        calls.append(len(batch))
        return original(self, batch, variant)

    class Each:  # the vertex arrays of a batch's meshes, drawn one after another
        def __init__(self, arrays):
            self.arrays, self.program = arrays, arrays[0].program

        def render(self, mode):
            for vao in self.arrays:
                vao.render(mode)

    def apart(self, batch, variant):  # one draw a mesh, as before the casters were joined
        arrays = [original(self, [item], variant)[0] for item in batch]
        return Each(arrays), sum(len(c.indices) for _, _, c in batch)

    maps = {}
    for mode, method in (("joined", spy), ("apart", apart)):
        monkeypatch.setattr(shadow_module.ShadowPass, "_batch_array", method)
        r = Renderer(ctx=ctx)
        try:
            frame = r.draw(sc, tuple(CAMERA["size"]))
            tex = frame.targets["shadowmap0"].texture
            maps[mode] = np.frombuffer(tex.read(), np.float32).copy()
            if mode == "joined":
                spass = r.resources.shadow_pass()
                assert len(spass.batches) >= 1
                faces = 6 if kind == "point" else 1
                assert len(calls) <= 2 * faces and max(calls) >= 3, calls
                r.geometry_cache.clear()
                assert len(spass.batches) == 0
        finally:
            r.release()
    assert (maps["joined"] < 1.0).sum() > 1000  # the casters are in it
    assert np.array_equal(maps["joined"], maps["apart"])
