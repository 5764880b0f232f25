"""A shadow pass draws a solid's faces turned towards the light only (viewer/passes/shadow.py):
which meshes bound a solid (viewer/geometry/solid.py), and that the culled map is the map drawn
with both faces, for orthographic, perspective and cube maps."""
import dataclasses

import numpy as np
import pytest

from viewer.geometry import primitives
from viewer.geometry import simplify as simplify_module
from viewer.geometry.solid import INWARD, OPEN, OUTWARD, solid_orientation, weld
from viewer.graph.resources import ShadowMapDesc
from viewer.lighting.shadow_frames import cube_frames, directional_frame, spot_frame
from viewer.passes import shadow as shadow_module
from viewer.renderer import Renderer
from viewer.scene.bounds import Bounds

CULLED_FACES = shadow_module.culled_faces  # the pass's rule, before a test replaces it


def _sphere(center=(0.0, 1.0, 0.0), radius=0.5, **kw):
    return primitives.sphere(center=center, radius=radius, segments=48, rings=24, **kw)


def test_a_sphere_bounds_a_solid_and_a_plane_does_not():
    s = _sphere()
    assert solid_orientation(s.positions, s.indices) == OUTWARD
    flipped = s.indices.reshape(-1, 3)[:, ::-1]
    assert solid_orientation(s.positions, flipped) == INWARD
    p = primitives.plane()
    assert solid_orientation(p.positions, p.indices) == OPEN


def test_a_hole_or_one_flipped_triangle_makes_a_mesh_open():
    s = _sphere()
    tri = s.indices.reshape(-1, 3)
    middle = len(tri) // 2  # away from the poles' degenerate triangles
    assert solid_orientation(s.positions, np.delete(tri, middle, axis=0)) == OPEN
    one_flipped = tri.copy()
    one_flipped[middle] = one_flipped[middle, ::-1]
    assert solid_orientation(s.positions, one_flipped) == OPEN
    bad = s.positions.copy()
    bad[0, 0] = np.nan
    assert solid_orientation(bad, s.indices) == OPEN


def test_seams_an_ulp_apart_are_welded():
    """The UV sphere's seam and poles repeat vertices whose copies round differently (sin 2 pi
    is not 0): more distinct positions than the sphere has points, and still a solid, also moved
    far from the origin in float32."""
    s = _sphere(center=(0.0, 0.0, 0.0))
    points = 48 * 23 + 2  # segments x (rings - 1) + the poles
    assert len(np.unique(s.positions, axis=0)) > points
    assert solid_orientation(s.positions, s.indices) == OUTWARD
    far = (s.positions.astype(np.float64) * 1.0001 + np.array([1234.567, -89.1, 4321.2])
           ).astype(np.float32)
    assert solid_orientation(far, s.indices) == OUTWARD


def test_weld_joins_points_closer_than_half_a_cell_on_every_axis():
    rng = np.random.default_rng(3)
    base = rng.uniform(-10.0, 10.0, size=(500, 3))
    near = base + rng.uniform(-0.49, 0.49, size=base.shape) * 1e-3  # within half a cell of 1e-3
    labels = weld(np.concatenate([base, near]), 1e-3)
    assert np.array_equal(labels[:500], labels[500:])
    assert len(np.unique(labels)) == 500  # points 1e-3 x many cells apart stay apart


def _maps(renderer, frame, meshes, cull=None):
    """The depth map of ``meshes`` in ``frame``; ``cull``: replaces the pass's choice of faces."""
    spass = renderer.resources.shadow_pass()
    cube = hasattr(frame, "faces")
    target = ShadowMapDesc(frame.resolution, 6 if cube else 1).create(renderer.ctx)
    try:
        if cull is not None:
            shadow_module.culled_faces = cull
        spass.draw(target, frame, meshes, [])
        w, h = target.texture.size
        return np.frombuffer(target.texture.read(), np.float32).reshape(h, w).copy()
    finally:
        shadow_module.culled_faces = CULLED_FACES
        target.release()


@pytest.fixture(scope="module")
def renderer(ctx):
    r = Renderer(ctx=ctx)
    yield r
    r.release()


SCENE_BOUNDS = Bounds((-2.0, 0.0, -2.0), (2.0, 2.0, 2.0))
FRAMES = {
    "directional": lambda: directional_frame(SCENE_BOUNDS, (0.4, 1.0, -0.3), 256),
    "spot": lambda: spot_frame(SCENE_BOUNDS, (0.8, 4.0, 0.5), (0.8, 4.0, 0.5), 40.0, 256),
    "point": lambda: cube_frames(SCENE_BOUNDS, (1.5, 2.5, -1.0), 128),
}


@pytest.mark.parametrize("kind", sorted(FRAMES))
def test_culled_maps_are_the_maps_of_both_faces(renderer, kind):
    """The culled map equals the double-sided one (texels where the rasteriser's coverage of
    the silhouette edges differs aside: at most 0.2 % of the sphere's texels); culling the other
    faces instead would store the sphere's far side, so the comparison can fail."""
    frame = FRAMES[kind]()
    sphere, floor = _sphere(), primitives.plane(center=(0.0, 0.0, 0.0), size=(4.0, 4.0))
    faces = frame.faces if hasattr(frame, "faces") else (frame,)
    box = sphere.bounds()
    chosen = {shadow_module.culled_faces(OUTWARD, f.facing_winding(), box, f.origin)
              for f in faces}
    assert None not in chosen  # the light is outside the sphere: every face culls
    both = _maps(renderer, frame, [sphere, floor], cull=lambda *a: None)
    culled = _maps(renderer, frame, [sphere, floor])
    floor_only = _maps(renderer, frame, [floor])
    covered = both < floor_only - 1e-4  # texels where the sphere is the nearest occluder
    assert covered.sum() > 100
    differ = np.abs(culled - both) > 1e-6
    assert differ.sum() <= max(2, 0.002 * covered.sum()), differ.sum()

    def opposite(orientation, facing, bounds, origin):
        c = CULLED_FACES(orientation, facing, bounds, origin)
        return None if c is None else {"back": "front", "front": "back"}[c]
    wrong = _maps(renderer, frame, [sphere, floor], cull=opposite)
    assert (np.abs(wrong - both) > 1e-4).sum() > 0.5 * covered.sum()


def test_a_light_inside_a_solid_draws_both_faces():
    """A point light inside a closed room (an inward-wound box seen from within is still a
    solid): rays leave through the faces nearest the light, so nothing is culled."""
    room = _sphere(center=(0.0, 0.0, 0.0), radius=3.0)
    room = dataclasses.replace(room, indices=room.indices.reshape(-1, 3)[:, ::-1].reshape(-1))
    frame = cube_frames(Bounds((-3.0,) * 3, (3.0,) * 3), (0.2, 0.1, 0.0), 64)
    assert solid_orientation(room.positions, room.indices) == INWARD
    for f in frame.faces:
        assert shadow_module.culled_faces(INWARD, f.facing_winding(), room.bounds(),
                                          f.origin) is None


def test_an_inward_solid_keeps_its_faces_turned_towards_the_light():
    """The same winding rule turned round: an inward-wound solid keeps the faces whose
    (inward) normal turns away from the light, the ones a ray from outside enters by."""
    f = directional_frame(SCENE_BOUNDS, (0.0, 1.0, 0.0), 64)
    s = _sphere()
    out = shadow_module.culled_faces(OUTWARD, f.facing_winding(), s.bounds(), None)
    inward = shadow_module.culled_faces(INWARD, f.facing_winding(), s.bounds(), None)
    assert {out, inward} == {"front", "back"}


def test_a_mesh_is_tested_once_for_every_kind_of_map(ctx, monkeypatch):
    """A directional and a point light draw the same sphere with two programs (orthographic,
    cube faces); whether it bounds a solid is the mesh's, found once."""
    from shadow_scenes import CAMERA, DARK, FLOOR, SPHERE

    from viewer.scene.description import scene_from_dict

    calls = []

    def counted(positions, indices):
        calls.append(id(positions))
        return solid_orientation(positions, indices)

    monkeypatch.setattr(simplify_module, "solid_orientation", counted)
    r = Renderer(ctx=ctx)
    try:
        r.render(scene_from_dict({
            "camera": CAMERA, "environment": DARK, "objects": [FLOOR, SPHERE],
            "lights": [{"type": "directional", "direction": [0.3, 1.0, 0.2]},
                       {"type": "point", "position": [1.0, 3.0, 0.5], "intensity": 20.0}],
            "render": {"tonemap": "none"}}))
    finally:
        r.release()
    # the floor and the whole sphere once each, and each level of detail the maps drew once
    # (the caster arrays stay cached, so their ids are not reused)
    assert len(calls) == len(set(calls)) >= 2, calls
