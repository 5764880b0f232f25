"""The inputs the parity checks hand both sides, against geometry computed here.

``shadow:lights`` (learned/parity/checks/shadow_lights.py) gives the GLSL and its twin the same
``light_shadow_frame`` and ``shadow_lens``, and the model checks (checks/models.py) the same
``ibl.sun`` / ``ibl.lights``: a wrong frame or a wrong sun would pass parity, both sides agreeing
on it. Here the frames of the parity scenes are held to the scene's box (its extent written from
the scene's objects, not from ``Renderer.bounds``) and to the light's position and direction
(the sun: tests/learned/test_parity_inputs_sun.py). Each check also runs against a deliberately
broken input and fails.
"""
import math

import numpy as np
import pytest

from learned.parity.checks.shadow_lights import CASCADED, LIGHTS, _scene
from viewer.graph.frame import light_shadow_frame
from viewer.lighting.cascades import ShadowCascades
from viewer.lighting.shadow_frames import ShadowCube
from viewer.renderer import Renderer

EPS = 1e-9  # projections of points on the box's faces: float64 rounding


@pytest.fixture(scope="module")
def renderer(ctx):
    r = Renderer(ctx=ctx)
    yield r
    r.release()


def _box(floor: float) -> tuple[np.ndarray, np.ndarray]:
    """The parity scene's extent from its objects: the floor (``floor`` m square at y = 0) and
    the sphere of radius 0.5 at (0, 1, 0)."""
    return np.array([-floor / 2, 0.0, -floor / 2]), np.array([floor / 2, 1.5, floor / 2])


def _corners(lo, hi) -> np.ndarray:
    return np.array([[(hi if i >> k & 1 else lo)[k] for k in range(3)] for i in range(8)])


def _grid(lo, hi, n: int = 9) -> np.ndarray:
    """``n^3`` points filling the box, its faces and corners included."""
    axes = [np.linspace(lo[k], hi[k], n) for k in range(3)]
    return np.stack(np.meshgrid(*axes, indexing="ij"), -1).reshape(-1, 3)


def _uvw(frame, points) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(u, v, w) of ``points`` through a frame's matrix (world -> (u w, v w, depth, w))."""
    h = np.concatenate([points, np.ones((len(points), 1))], 1) @ frame.matrix.T
    with np.errstate(divide="ignore", invalid="ignore"):  # w = 0 at a perspective frame's apex
        return h[:, 0] / h[:, 3], h[:, 1] / h[:, 3], h[:, 3]


def _inside(values) -> bool:
    return bool(((values >= -EPS) & (values <= 1.0 + EPS)).all())


def frame_failures(kind: str, light, frame, lo, hi, camera=None) -> list[str]:
    """What is wrong with a light's shadow frame, by geometry computed here: every corner of the
    scene's box (``lo``, ``hi``) projects into the map ([0, 1] in u, v and depth; a spot light's
    u, v only for the points inside its outer cone, which is all it lights), nearer the light
    is smaller depth, the map looks along the light (from its position, along its axis), and a
    cascaded light's cascades hold every floor point the camera sees."""
    bad = []
    corners, grid = _corners(lo, hi), _grid(lo, hi)
    to_light = np.asarray(light.direction, np.float64)
    to_light = to_light / np.linalg.norm(to_light)
    if kind in ("directional", "cascaded"):
        faces = frame.faces if isinstance(frame, ShadowCascades) else (frame,)
        for k, f in enumerate(faces):
            u, v, _ = _uvw(f, corners)
            depth = f.project(corners)[:, 2]
            if kind == "directional" and not (_inside(u) and _inside(v)):
                bad.append(f"a box corner outside the map: u {u.min():.3f}..{u.max():.3f}, "
                           f"v {v.min():.3f}..{v.max():.3f}")
            if not _inside(depth):
                bad.append(f"face {k}: depth {depth.min():.3f}..{depth.max():.3f}")
            # a step towards the light: same texel, smaller depth
            c = 0.5 * (lo + hi)
            a, b = f.project(np.stack([c, c + 0.1 * to_light]))
            if not (np.allclose(a[:2], b[:2], atol=1e-9) and b[2] < a[2]):
                bad.append(f"face {k} does not look along the light: {a} -> {b}")
        if kind == "cascaded":
            d = camera.view_rays_ws().reshape(-1, 3).astype(np.float64)
            o = np.asarray(camera.position, np.float64)
            seen = o + (-o[1] / d[:, 1:2]) * d  # where each pixel's ray meets the floor
            held = np.zeros(len(seen), bool)
            for f in faces:
                uvd = f.project(seen)
                held |= ((uvd >= -EPS) & (uvd <= 1.0 + EPS)).all(1)
            if not held.all() or len(faces) < 2:
                bad.append(f"{int((~held).sum())} of {len(seen)} seen floor points in no "
                           f"cascade ({len(faces)} cascades)")
    elif kind == "spot":
        pos = np.asarray(light.position, np.float64)
        axis = -to_light  # the spot shines away from "direction" (towards the light)
        u, v, w = _uvw(frame, pos[None] + np.array([[0.0, 0.0, 0.0]]))
        if abs(w[0]) > 1e-9:
            bad.append(f"the frustum's apex is not the light: w = {w[0]} there")
        u, v, _ = _uvw(frame, (pos + 2.0 * axis)[None])
        if not np.allclose([u[0], v[0]], 0.5, atol=1e-9):
            bad.append(f"the light's axis maps to ({u[0]:.3f}, {v[0]:.3f}), not the centre")
        rel = grid - pos
        cos = rel @ axis / np.linalg.norm(rel, axis=1)
        lit = grid[cos >= math.cos(math.radians(light.outer_cone_deg))]
        u, v, w = _uvw(frame, lit)
        if len(lit) < 20 or not (_inside(u) and _inside(v) and (w > 0).all()):
            bad.append(f"a point inside the outer cone outside the map ({len(lit)} points: "
                       f"u {u.min():.3f}..{u.max():.3f}, v {v.min():.3f}..{v.max():.3f})")
        depth = frame.project(corners)[:, 2]
        if not _inside(depth):
            bad.append(f"box corners' depth {depth.min():.3f}..{depth.max():.3f}")
    elif kind == "point":
        pos = np.asarray(light.position, np.float64)
        axes = np.array([f.matrix[3, :3] / np.linalg.norm(f.matrix[3, :3]) for f in frame.faces])
        if not np.allclose(np.sort(np.round(axes, 9).tolist(), axis=0),
                           np.sort(np.vstack([np.eye(3), -np.eye(3)]).tolist(), axis=0)):
            bad.append(f"the faces do not look along +-x, +-y, +-z: {axes.round(3).tolist()}")
        for f in frame.faces:
            w = _uvw(f, pos[None])[2]
            if abs(w[0]) > 1e-9:
                bad.append(f"a face's apex is not the light: w = {w[0]} there")
        held = np.zeros(len(grid), bool)
        for f in frame.faces:
            u, v, w = _uvw(f, grid)
            held |= (w > 0) & (u >= -EPS) & (u <= 1 + EPS) & (v >= -EPS) & (v <= 1 + EPS)
        if not held.all():
            bad.append(f"{int((~held).sum())} box points in no cube face")
        depth = (np.linalg.norm(grid - pos, axis=1) - frame.near) / frame.depth_range
        mapped = frame.faces[0].project(grid)[:, 2]
        if not (_inside(depth) and np.allclose(mapped, depth, atol=1e-9)):
            bad.append(f"depth is not the distance from the light within the range: "
                       f"{depth.min():.3f}..{depth.max():.3f}")
    return bad


def _parity_frame(renderer, kind):
    scene = _scene(LIGHTS[kind], **(CASCADED if kind == "cascaded" else {}))
    light = scene.lights[0]
    frame = light_shadow_frame(light, renderer.bounds(scene), scene.render.shadow, scene.camera)
    return scene, light, frame


@pytest.mark.parametrize("kind", list(LIGHTS))
def test_parity_shadow_frames_hold_the_scene(renderer, kind):
    """The frames shadow:lights hands both sides, for each of its lights."""
    scene, light, frame = _parity_frame(renderer, kind)
    expected_type = {"point": ShadowCube, "cascaded": ShadowCascades}.get(kind)
    if expected_type is not None:
        assert isinstance(frame, expected_type)
    lo, hi = _box(CASCADED["floor"] if kind == "cascaded" else 8.0)
    bounds = renderer.bounds(scene)  # what the frames were fitted to: the same box (float32 mesh)
    np.testing.assert_allclose(bounds.lo, lo, atol=1e-5)
    np.testing.assert_allclose(bounds.hi, hi, atol=1e-5)
    assert frame_failures(kind, light, frame, lo, hi, scene.camera) == []


def test_the_frame_checks_fail_on_broken_frames(renderer):
    """The checks above against deliberately broken frames: a spot frustum of the inner cone's
    angle (points between the cones fall outside), a directional frame of the box shrunk by 10 %
    (corners outside), a directional frame looking away from the light (depth grows towards it),
    a cube with one face turned to repeat another (directions uncovered)."""
    import dataclasses

    from viewer.lighting import shadow_frames as sf
    from viewer.scene.bounds import Bounds

    scene, light, _ = _parity_frame(renderer, "spot")
    lo, hi = _box(8.0)
    inner = sf.spot_frame(renderer.bounds(scene), light.position, light.direction,
                          light.inner_cone_deg, 64)
    assert any("outer cone" in b for b in frame_failures("spot", light, inner, lo, hi))

    scene, light, _ = _parity_frame(renderer, "directional")
    c = 0.5 * (lo + hi)
    small = sf.directional_frame(Bounds(c + 0.9 * (lo - c), c + 0.9 * (hi - c)), light.direction)
    assert any("corner outside" in b for b in frame_failures("directional", light, small, lo, hi))
    away = sf.directional_frame(Bounds(lo, hi), -np.asarray(light.direction))
    assert any("look along" in b for b in frame_failures("directional", light, away, lo, hi))

    scene, light, cube = _parity_frame(renderer, "point")
    faces = list(cube.faces)
    faces[1] = faces[0]  # -x repeats +x
    broken = dataclasses.replace(cube, faces=tuple(faces))
    assert any("+-x" in b for b in frame_failures("point", light, broken, lo, hi))
    assert any("no cube face" in b for b in frame_failures("point", light, broken, lo, hi))


def _gradient_norm(f, point, index: int, h: float = 1e-4) -> float:
    """|d (u, v or depth) / d world| of ``f.project`` at ``point``, by central differences."""
    g = [(f.project(point + h * e)[0, index] - f.project(point - h * e)[0, index]) / (2 * h)
         for e in np.eye(3)]
    return float(np.linalg.norm(g))


def lens_failures(kind: str, spec: dict, frame, lens, lo, hi) -> list[str]:
    """What is wrong with the ``shadow_lens`` parity hands both sides, against the light's size
    as its table gives it (a directional light's angular diameter / 2, a point or spot light's
    radius; softness 1) and the frame's scale measured here by finite differences: an
    orthographic map's penumbra grows tan(angle) x distance in world units, so its scale is
    tan(angle) over the map's world width; a perspective map's is the radius over the frustum's
    width at unit distance; near and the depth range bracket the box's distances from the
    light."""
    bad = []
    corners = _corners(lo, hi)
    faces = frame.faces if isinstance(frame, (ShadowCube, ShadowCascades)) else (frame,)
    if kind in ("directional", "cascaded"):
        base = frame.base if isinstance(frame, ShadowCascades) else frame
        c = 0.5 * (lo + hi)[None]
        width = 1.0 / min(_gradient_norm(base, c, 0), _gradient_norm(base, c, 1))
        want = math.tan(math.radians(spec["angular_diameter_deg"]) / 2.0) / width
        depth_range = 1.0 / _gradient_norm(base, c, 2)
        if not (math.isclose(lens[1], want, rel_tol=1e-6) and lens[2] == 0.0
                and math.isclose(lens[3], depth_range, rel_tol=1e-6)):
            bad.append(f"lens {lens} vs scale {want:.6g}, near 0, range {depth_range:.6g}")
        return bad
    pos = np.asarray(spec["position"], np.float64)
    f = faces[0]
    axis = f.matrix[3, :3] / np.linalg.norm(f.matrix[3, :3])
    q = (pos + axis)[None]  # unit distance along the face's axis
    per_unit = min(_gradient_norm(f, q, 0), _gradient_norm(f, q, 1))  # 1 / frustum width
    want = spec["radius"] * per_unit
    if kind == "spot":
        dist = (corners - pos) @ axis
        nearest, farthest = dist.min(), dist.max()
    else:
        nearest = np.linalg.norm(np.clip(pos, lo, hi) - pos)
        farthest = np.linalg.norm(corners - pos, axis=1).max()
    if not math.isclose(lens[1], want, rel_tol=1e-6):
        bad.append(f"lens scale {lens[1]:.6g}, the radius over the width at unit distance is "
                   f"{want:.6g}")
    if not (0.98 * nearest <= lens[2] <= nearest
            and farthest <= lens[2] + lens[3] <= 1.02 * farthest):
        bad.append(f"near {lens[2]:.4g} .. far {lens[2] + lens[3]:.4g} vs the box's "
                   f"{nearest:.4g} .. {farthest:.4g}")
    return bad


def _parity_lens(scene, light, frame):
    """shadow:lights' lens, as its _twin_visibility forms it."""
    from viewer.passes.shadow_bindings import shadow_lens

    settings = scene.render.shadow
    size = light.radius if light.positional else np.radians(light.angular_diameter_deg) / 2.0
    return shadow_lens(frame, size * settings.softness)


@pytest.mark.parametrize("kind", list(LIGHTS))
def test_parity_shadow_lens_matches_the_light(renderer, kind):
    """The lens shadow:lights hands both sides: scale, near and depth range from the light's
    table and the frame measured here (central differences in float64: measured within 1e-7
    relative, bound 1e-6; a 1e-5 change of the scale fails)."""
    scene, light, frame = _parity_frame(renderer, kind)
    assert scene.render.shadow.softness == 1.0
    lo, hi = _box(CASCADED["floor"] if kind == "cascaded" else 8.0)
    lens = _parity_lens(scene, light, frame)
    assert lens_failures(kind, LIGHTS[kind], frame, lens, lo, hi) == []


def test_the_lens_check_fails_on_a_broken_lens(renderer):
    """The check above against deliberately broken lenses: a diameter where the radius belongs
    (the scale doubled), an orthographic scale not divided by the map's width, a perspective
    near plane taken as 0."""
    for kind in LIGHTS:
        scene, light, frame = _parity_frame(renderer, kind)
        lo, hi = _box(CASCADED["floor"] if kind == "cascaded" else 8.0)
        lens = _parity_lens(scene, light, frame)
        doubled = (lens[0], 2.0 * lens[1], lens[2], lens[3])
        assert lens_failures(kind, LIGHTS[kind], frame, doubled, lo, hi) != [], kind
        if kind == "directional":
            raw = (lens[0], lens[1] * max(frame.extent), lens[2], lens[3])
            assert lens_failures(kind, LIGHTS[kind], frame, raw, lo, hi) != []
        if kind in ("spot", "point"):
            zero = (lens[0], lens[1], 0.0, lens[3])
            assert lens_failures(kind, LIGHTS[kind], frame, zero, lo, hi) != [], kind
