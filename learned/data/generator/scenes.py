"""The generator's scene dicts (``viewer.scene.description.scene_from_dict`` format, without an environment):
random materials and placements, bodies resting on a floor, and one builder per scene kind
(:func:`random_scene`, :func:`kind_scene`)."""
from __future__ import annotations

import functools
import math
from pathlib import Path

import numpy as np

from viewer.geometry.loaders import load_mesh

from ..reader import DatasetError
from .config import BLOCK_SHAPES, CONCAVE_SHAPES, GLTF_MODELS, SCENE_KINDS, GeneratorConfig
from .shapes import _nested_spot


def _material(rng) -> dict:
    metal = rng.random() < 0.25
    return {"albedo": [float(x) for x in rng.uniform(0.05, 0.95, 3)],
            "roughness": float(rng.uniform(0.05, 1.0)),
            "metallic": 1.0 if metal else float(rng.uniform(0.0, 0.1)),
            "specular": float(rng.uniform(0.2, 1.0)),
            "ao": float(rng.uniform(0.6, 1.0))}


def _rotation(rng) -> list[list[float]]:
    a, b = rng.uniform(0, 2 * math.pi, 2)
    ca, sa, cb, sb = math.cos(a), math.sin(a), math.cos(b), math.sin(b)
    ry = np.array([[ca, 0, sa], [0, 1, 0], [-sa, 0, ca]])
    rx = np.array([[1, 0, 0], [0, cb, -sb], [0, sb, cb]])
    return (ry @ rx).tolist()


def _yaw(a: float) -> np.ndarray:
    """Rotation about +Y by ``a`` radians."""
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])


def _pitch(a: float) -> np.ndarray:
    """Rotation about +X by ``a`` radians."""
    c, s = math.cos(a), math.sin(a)
    return np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])


# resting poses of the random scenes' trimesh meshes, as pitches (about x) before a yaw: the box
# on a face; the torus (axis z) lying flat or standing on its rim; the capsule (axis z) standing
# or lying
_POSES = {"box": (0.0,), "torus": (-math.pi / 2, 0.0), "capsule": (-math.pi / 2, 0.0)}


@functools.lru_cache(maxsize=32)
def _vertices(path: str) -> np.ndarray:
    """The positions of mesh file ``path`` as the renderer loads them (float64 ``[N, 3]``)."""
    return np.concatenate([m.positions for m in load_mesh(path)]).astype(np.float64)


def _footprint(body: dict) -> tuple[float, float, float, float]:
    """``(cx, cz, radius, lowest y)`` of a body (``{"radius"}``: a sphere about the origin;
    ``{"path", "linear"}``: a mesh file under a 3 x 3 map): the centre and radius of the circle
    bounding its floor-plane projection, and its lowest point."""
    if "radius" in body:
        return 0.0, 0.0, float(body["radius"]), -float(body["radius"])
    v = _vertices(str(body["path"])) @ np.asarray(body["linear"]).T
    lo, hi = v.min(0), v.max(0)
    cx, cz = (lo[0] + hi[0]) / 2, (lo[2] + hi[2]) / 2
    return float(cx), float(cz), float(np.hypot(v[:, 0] - cx, v[:, 2] - cz).max()), float(lo[1])


def _resting(body: dict, x: float, z: float, floor_y: float, material: dict | None) -> dict:
    """The scene object of ``body`` resting on the floor ``y = floor_y`` (its lowest point on
    it), its footprint centred on ``(x, z)``; a mesh without ``material`` keeps its file's own
    materials (glTF textures)."""
    if "radius" in body:
        r = float(body["radius"])
        return {"type": "sphere", "center": [float(x), floor_y + r, float(z)], "radius": r,
                "material": material}
    cx, cz, _, low = _footprint(body)
    m = np.eye(4)
    m[:3, :3] = body["linear"]
    m[:3, 3] = [x - cx, floor_y - low, z - cz]
    obj = {"type": "mesh", "path": str(body["path"]), "transform": m.tolist()}
    if material is not None:
        obj["material"] = material
    return obj


def _touching_distance(a: dict, b: dict) -> float:
    """The horizontal centre distance at which two resting bodies touch: two spheres on one floor
    (radii r, s) at 2 sqrt(r s); otherwise where their bounding footprint circles touch."""
    if "radius" in a and "radius" in b:
        return 2.0 * math.sqrt(a["radius"] * b["radius"])
    return _footprint(a)[2] + _footprint(b)[2]


def _place(rng, bodies: list[dict], cx: float, cz: float) -> list[tuple[float, float] | None]:
    """Floor positions for ``bodies``: the first at ``(cx, cz)``, each next one beside a placed
    one, touching it (half the time) or a little apart, overlapping none, within 1.3 of the first
    (up to 64 tries; a body that finds no room is left out: None)."""
    placed: list[tuple[int, float, float]] = []
    out: list[tuple[float, float] | None] = [None] * len(bodies)
    for k, b in enumerate(bodies):
        if not placed:
            x, z = cx, cz
        else:
            rho = _footprint(b)[2]
            for _ in range(64):
                j, xj, zj = placed[int(rng.integers(0, len(placed)))]
                a = float(rng.uniform(0.0, 2 * math.pi))
                gap = 0.0 if rng.random() < 0.5 else float(rng.uniform(0.02, 0.3)) * rho
                d = _touching_distance(bodies[j], b) + gap
                x, z = xj + d * math.cos(a), zj + d * math.sin(a)
                if z < -2.6 and math.hypot(x - cx, z - cz) < 1.3 and all(math.hypot(x - xi, z - zi) >= _touching_distance(bodies[i], b)
                                    - 1e-9 for i, xi, zi in placed):
                    break
            else:
                continue
        placed.append((k, x, z))
        out[k] = (x, z)
    return out


def _camera(fov: float, size: int) -> dict:
    return {"position": [0, 0, 0], "target": [0, 0, -1], "up": [0, 1, 0], "fov_y": fov,
            "size": [size, size]}


def _floor(y: float, material: dict) -> dict:
    return {"type": "plane", "center": [0.0, y, -4.0], "size": [12.0, 12.0], "material": material}


def _cluster_scene(kind: str, rng, config: GeneratorConfig, meshes: dict[str, Path],
                   shapes: dict[str, Path]) -> dict:
    """"cluster": 3-6 spheres and meshes; "gltf": 1-3 bodies, the first a glTF model, the others
    glTF models or spheres; all resting on a floor, touching or close to each other."""
    floor_y = float(rng.uniform(-1.1, -0.7))
    cx, cz = float(rng.uniform(-0.4, 0.4)), float(rng.uniform(-4.4, -3.6))
    fov = float(rng.uniform(35.0, 50.0))
    names = sorted(meshes) if config.meshes else []
    bodies, materials = [], []
    n = int(rng.integers(3, 7)) if kind == "cluster" else int(rng.integers(1, 4))
    for k in range(n):
        if kind == "gltf" and (k == 0 or rng.random() < 0.5):
            name = GLTF_MODELS[int(rng.integers(0, len(GLTF_MODELS)))]
            linear = _yaw(float(rng.uniform(0, 2 * math.pi))) * float(rng.uniform(0.8, 1.3))
            bodies.append({"path": shapes[name], "linear": linear})
            materials.append(None)  # the file's textured material
            continue
        if kind == "cluster" and names and rng.random() < 0.45:
            name = names[int(rng.integers(0, len(names)))]
            poses = _POSES.get(name, (0.0,))
            pitch = poses[int(rng.integers(0, len(poses)))]
            linear = (_yaw(float(rng.uniform(0, 2 * math.pi))) @ _pitch(pitch)
                      * float(rng.uniform(0.4, 0.7)))
            bodies.append({"path": meshes[name], "linear": linear})
        else:
            bodies.append({"radius": float(rng.uniform(0.2, 0.45))})
        materials.append(_material(rng))
    where = _place(rng, bodies, cx, cz)
    objects = [_resting(b, *xz, floor_y, m) for b, xz, m in zip(bodies, where, materials)
               if xz is not None]
    objects.append(_floor(floor_y, _material(rng)))
    return {"camera": _camera(fov, config.size), "objects": objects}


def _concave_scene(kind: str, rng, config: GeneratorConfig, shapes: dict[str, Path]) -> dict:
    """"concave": one concave shape (CONCAVE_SHAPES) resting on a floor; "nested": the same with a
    sphere resting inside it (:func:`_nested_spot`). A corner opens towards the camera."""
    shape = CONCAVE_SHAPES[int(rng.integers(0, len(CONCAVE_SHAPES)))]
    scale = float(rng.uniform(0.8, 1.15))
    yaw = (-math.pi / 4 + float(rng.uniform(-0.5, 0.5)) if shape == "corner"
           else float(rng.uniform(0, 2 * math.pi)))
    floor_y = float(rng.uniform(-1.35, -1.0))  # seen from above: the inside shows
    x, z = float(rng.uniform(-0.3, 0.3)), float(rng.uniform(-3.4, -2.8))
    fov = float(rng.uniform(50.0, 60.0))
    mesh = _resting({"path": shapes[shape], "linear": _yaw(yaw) * scale}, x, z, floor_y,
                    _material(rng))
    objects = [mesh]
    if kind == "nested":
        local, rs = _nested_spot(shape, rng)
        t = np.asarray(mesh["transform"])
        c = t[:3, :3] @ local + t[:3, 3]
        objects.append({"type": "sphere", "center": [float(v) for v in c],
                        "radius": rs * scale, "material": _material(rng)})
    objects.append(_floor(floor_y, _material(rng)))
    return {"camera": _camera(fov, config.size), "objects": objects}


def _block_body(rng, shapes: dict[str, Path]) -> dict:
    """One body of the "blocks" kind: a unit shape of :data:`BLOCK_SHAPES` under a random yaw
    and scale. A box is a cube, a slab, a post or a thin panel standing on an edge (half its
    bodies); a pipe lies or stands (a third); an arch stands."""
    shape = BLOCK_SHAPES[int(rng.choice(len(BLOCK_SHAPES), p=(0.5, 0.25, 0.25)))]
    yaw = _yaw(float(rng.uniform(0, 2 * math.pi)))
    u = rng.uniform
    if shape == "box":
        form = int(rng.integers(0, 4))
        if form == 0:  # a cube-ish block
            dims = u(0.3, 0.8, 3)
        elif form == 1:  # a slab lying
            dims = (u(0.5, 1.3), u(0.04, 0.2), u(0.5, 1.3))
        elif form == 2:  # a post
            dims = (u(0.08, 0.3), u(0.6, 1.4), u(0.08, 0.3))
        else:  # a thin panel standing on its long edge
            dims = (u(0.4, 1.2), u(0.4, 1.0), u(0.02, 0.08))
        linear = yaw @ np.diag([float(d) for d in dims])
    elif shape == "tube":
        r, length = float(u(0.3, 0.7)), float(u(0.6, 1.8))
        lie = np.eye(3) if rng.random() < 2 / 3 else _pitch(-math.pi / 2)
        linear = yaw @ lie @ np.diag([r, r, length * r])
    else:
        linear = yaw @ np.diag([float(u(0.6, 1.2)), float(u(0.5, 1.0)), float(u(0.3, 1.0))])
    return {"path": shapes[f"block_{shape}"], "linear": linear}


def _blocks_scene(rng, config: GeneratorConfig, shapes: dict[str, Path]) -> dict:
    """"blocks": 2-5 bodies of :func:`_block_body` (a sixth of them spheres) resting on a floor,
    touching or close to each other."""
    floor_y = float(rng.uniform(-1.1, -0.7))
    cx, cz = float(rng.uniform(-0.4, 0.4)), float(rng.uniform(-4.4, -3.6))
    fov = float(rng.uniform(35.0, 50.0))
    bodies = [{"radius": float(rng.uniform(0.15, 0.4))} if k and rng.random() < 1 / 6
              else _block_body(rng, shapes) for k in range(int(rng.integers(2, 6)))]
    where = _place(rng, bodies, cx, cz)
    objects = [_resting(b, *xz, floor_y, _material(rng)) for b, xz in zip(bodies, where)
               if xz is not None]
    objects.append(_floor(floor_y, _material(rng)))
    return {"camera": _camera(fov, config.size), "objects": objects}


def random_scene(rng, config: GeneratorConfig, meshes: dict[str, Path]) -> dict:
    """A scene dict (``viewer.scene.description.scene_from_dict`` format) without its environment."""
    objects = []
    for k in range(int(rng.integers(1, 4))):
        center = [float(rng.uniform(-1.0, 1.0)), float(rng.uniform(-0.4, 0.6)),
                  float(rng.uniform(-4.5, -3.0))]
        radius = float(rng.uniform(0.4, 0.8))
        if meshes and config.meshes and rng.random() < 0.4:
            name = sorted(meshes)[int(rng.integers(0, len(meshes)))]
            rot = np.array(_rotation(rng)) * radius * 1.2
            m = np.eye(4)
            m[:3, :3] = rot
            m[:3, 3] = center
            objects.append({"type": "mesh", "path": str(meshes[name]), "transform": m.tolist(),
                            "material": _material(rng)})
        else:
            objects.append({"type": "sphere", "center": center, "radius": radius,
                            "material": _material(rng)})
    if rng.random() < 0.75:
        objects.append({"type": "plane", "center": [0.0, float(rng.uniform(-1.2, -0.7)), -4.0],
                        "size": [12.0, 12.0], "material": _material(rng)})
    fov = float(rng.uniform(30.0, 50.0))
    return {"camera": {"position": [0, 0, 0], "target": [0, 0, -1], "up": [0, 1, 0],
                       "fov_y": fov, "size": [config.size, config.size]},
            "objects": objects}


def kind_scene(kind: str, rng, config: GeneratorConfig, meshes: dict[str, Path],
               shapes: dict[str, Path] | None = None) -> dict:
    """The scene dict of sample kind ``kind`` (:data:`SCENE_KINDS`), without its environment.
    ``shapes``: the concave shapes, block shapes and glTF models (:func:`.shapes._shape_files`)
    the kinds cluster, concave, gltf, nested and blocks draw from."""
    if kind == "random":
        return random_scene(rng, config, meshes)
    if kind in ("cluster", "gltf", "concave", "nested", "blocks"):
        if kind != "cluster" and not shapes:
            raise DatasetError(f"scene kind {kind!r} needs the generator's shape files "
                               "(_shape_files)", where="scene_kinds")
        if kind == "blocks":
            return _blocks_scene(rng, config, shapes)
        if kind in ("cluster", "gltf"):
            return _cluster_scene(kind, rng, config, meshes, shapes or {})
        return _concave_scene(kind, rng, config, shapes)
    fov = float(rng.uniform(30.0, 45.0))
    camera = {"position": [0, 0, 0], "target": [0, 0, -1], "up": [0, 1, 0], "fov_y": fov,
              "size": [config.size, config.size]}
    if kind == "convex":
        objects = [{"type": "sphere", "center": [float(rng.uniform(-0.3, 0.3)),
                                                 float(rng.uniform(-0.3, 0.3)),
                                                 float(rng.uniform(-4.0, -3.0))],
                    "radius": float(rng.uniform(0.5, 0.8)), "material": _material(rng)}]
        return {"camera": camera, "objects": objects}
    floor_y = float(rng.uniform(-1.0, -0.6))
    z = float(rng.uniform(-4.0, -3.2))
    if kind == "sphere_on_plane":
        r = float(rng.uniform(0.4, 0.7))
        spheres = [([float(rng.uniform(-0.5, 0.5)), floor_y + r, z], r)]
    elif kind == "touching_spheres":
        r1, r2 = (float(x) for x in rng.uniform(0.3, 0.6, 2))
        a = float(rng.uniform(-0.6, 0.6))  # the second sphere's direction in the floor plane
        d = r1 + r2
        dx, dz = math.cos(a), math.sin(a)
        c1 = [-0.5 * d * dx, floor_y + r1, z - 0.5 * d * dz]
        # touching: centres d apart, both on the floor (offset in y by r2 - r1)
        h = math.sqrt(max(d * d - (r2 - r1) ** 2, 0.0))
        c2 = [c1[0] + h * dx, floor_y + r2, c1[2] + h * dz]
        spheres = [(c1, r1), (c2, r2)]
    else:
        raise DatasetError(f"unknown scene kind {kind!r} (known: {', '.join(SCENE_KINDS)})",
                           where="scene_kinds")
    objects = [{"type": "sphere", "center": c, "radius": r, "material": _material(rng)}
               for c, r in spheres]
    objects.append({"type": "plane", "center": [0.0, floor_y, -4.0], "size": [12.0, 12.0],
                    "material": _material(rng)})
    return {"camera": camera, "objects": objects}
