"""A glTF test file for KHR_materials_transmission's transmissionTexture and KHR_materials_volume's
thicknessTexture (:func:`mapped_glass`) and the scene that views it (:func:`mapped_scene`), with
the pixel masks of its regions (:func:`region_masks`).

Left, a thin-walled smooth quad whose transmissionTexture (R) alternates 1 and 0 in four vertical
stripes (transmissionFactor 1): half of it is clear glass, half white diffuse. Right, two smooth
glass boxes of one material (transmissionFactor 1, a volume of thicknessFactor 0.8 absorbing
towards grey over 0.4) 0.2 and 0.8 deep: their thicknessTexture (G) is 0.25 on the shallow box's
faces and 1 on the deep one's, so the map says each box's real depth; the same texture's R is
their transmissionTexture (1: both maps on one volume material, packed in one image). Behind them, an emissive
black backdrop (its radiance does not depend on the light, so what is seen through the glass is
the same for every renderer). ``maps=False``: the same file without the two textures."""
import math

import numpy as np
from gltf_builder import NEAREST, GltfBuilder, quad

from viewer.scene.description import scene_from_dict

QUAD = (-1.1, -0.1, -0.5, 0.5)  # x0, x1, y0, y1 of the striped quad (z = 0)
BOXES = ((0.1, 0.5, 0.2), (0.6, 1.0, 0.8))  # x0, x1, depth of each box (y in [-0.5, 0.5])
THICKNESS = 0.8  # thicknessFactor: the deep box's depth
ATTENUATION = (0.5, 0.4)  # attenuationColor (grey) and attenuationDistance
EMISSION = 3.0  # the backdrop's emissiveFactor (z = -1.5)
SIZE = (96, 48)
FOV_Y = 30.0
DISTANCE = 2.6  # the camera on +z, looking at the origin


def _box(b: GltfBuilder, x0: float, x1: float, depth: float, uv: tuple[float, float],
         material: int) -> None:
    """A closed box [x0, x1] x [-0.5, 0.5] x [-depth, 0], flat faces, every vertex at ``uv``."""
    lo, hi = np.float32([x0, -0.5, -depth]), np.float32([x1, 0.5, 0.0])
    pos, nrm, idx = [], [], []
    for axis in range(3):
        for sign in (-1.0, 1.0):
            n = np.zeros(3, np.float32)
            n[axis] = sign
            u, v = (axis + 1) % 3, (axis + 2) % 3
            corners = []
            for a, c in ((0, 0), (1, 0), (1, 1), (0, 1)):
                p = lo.copy()
                p[axis] = hi[axis] if sign > 0 else lo[axis]
                p[u] = (lo[u], hi[u])[a]
                p[v] = (lo[v], hi[v])[c]
                corners.append(p)
            base = len(pos)
            e1, e2 = corners[1] - corners[0], corners[3] - corners[0]
            order = [0, 1, 2, 0, 2, 3] if np.dot(np.cross(e1, e2), n) > 0 else [0, 2, 1, 0, 3, 2]
            pos += corners
            nrm += [n] * 4
            idx += [base + k for k in order]
    count = len(pos)
    attrs = {"POSITION": b.accessor(np.float32(pos), minmax=True),
             "NORMAL": b.accessor(np.float32(nrm)),
             "TEXCOORD_0": b.accessor(np.tile(np.float32(uv), (count, 1)))}
    b.mesh(attrs, b.accessor(np.uint16(idx)), material)


def mapped_glass(path, maps: bool = True):
    """Write the file (module docstring) to ``path``; returns ``path``."""
    b = GltfBuilder()
    stripes = np.zeros((8, 8, 4), np.uint8)
    stripes[..., 3] = 255
    stripes[:, [0, 1, 4, 5], 0] = 255  # R: clear in stripes 1 and 3 of 4 (u from the left)
    depth = np.zeros((8, 8, 4), np.uint8)
    depth[..., 0] = depth[..., 3] = 255  # R: the boxes' transmission map, 1 (packed, as glTF allows)
    depth[:, :4, 1] = 64  # G: 0.25 (u < 0.5), 1 (u > 0.5)
    depth[:, 4:, 1] = 255
    glass = {"transmissionFactor": 1.0}
    if maps:
        glass["transmissionTexture"] = {"index": b.image(stripes, NEAREST)}
    pane = b.material(pbrMetallicRoughness={"baseColorFactor": [1, 1, 1, 1], "metallicFactor": 0.0,
                                            "roughnessFactor": 0.0},
                      extensions={"KHR_materials_transmission": glass})
    volume = {"thicknessFactor": THICKNESS, "attenuationColor": [ATTENUATION[0]] * 3,
              "attenuationDistance": ATTENUATION[1]}
    solid = {"transmissionFactor": 1.0}
    if maps:
        volume["thicknessTexture"] = solid["transmissionTexture"] = {"index": b.image(depth,
                                                                                      NEAREST)}
    block = b.material(pbrMetallicRoughness={"baseColorFactor": [1, 1, 1, 1],
                                             "metallicFactor": 0.0, "roughnessFactor": 0.0},
                       extensions={"KHR_materials_transmission": solid,
                                   "KHR_materials_volume": volume})
    x0, x1, y0, y1 = QUAD
    quad(b, pane, positions=np.float32([[x0, y1, 0], [x0, y0, 0], [x1, y0, 0], [x1, y1, 0]]))
    for (bx0, bx1, d), u in zip(BOXES, (0.25, 0.75)):
        _box(b, bx0, bx1, d, (u, 0.5), block)
    backdrop = b.material(pbrMetallicRoughness={"baseColorFactor": [0, 0, 0, 1],
                                                "metallicFactor": 0.0, "roughnessFactor": 1.0},
                          emissiveFactor=[1.0, 1.0, 1.0],
                          extensions={"KHR_materials_emissive_strength":
                                      {"emissiveStrength": EMISSION}})
    quad(b, backdrop, uv=None, node={"translation": [0.0, 0.0, -1.5], "scale": [3.0, 2.0, 1.0]})
    b.doc["extensionsUsed"] = ["KHR_materials_transmission", "KHR_materials_volume",
                               "KHR_materials_emissive_strength"]
    return b.save(path)


def mapped_scene(path, **render):
    """The scene viewing :func:`mapped_glass`'s file from +z under the procedural sky (its sun a
    light), :data:`SIZE` pixels, linear radiance."""
    return scene_from_dict({
        "camera": {"position": [0.0, 0.0, DISTANCE], "target": [0.0, 0.0, 0.0], "fov_y": FOV_Y,
                   "size": list(SIZE)},
        "environment": {"procedural": "sky", "width": 128, "sun_azimuth_deg": 40.0},
        "render": {"multiscatter": False, "ao": False, "tonemap": "none",
                   "background": "transparent", **render},
        "objects": [{"type": "mesh", "path": str(path)}]})


def _rays() -> tuple[np.ndarray, np.ndarray]:
    """``(x, y)`` ``[H, W]``: where each pixel centre's view ray meets the z = 0 plane."""
    w, h = SIZE
    t = math.tan(math.radians(FOV_Y) / 2.0) * DISTANCE
    j, i = np.meshgrid(np.arange(w) + 0.5, np.arange(h) + 0.5)
    return (j / w * 2.0 - 1.0) * t * (w / h), (1.0 - i / h * 2.0) * t


def _erode(inside: np.ndarray, margin: int) -> np.ndarray:
    inside = inside.copy()
    for _ in range(margin):
        inside[1:-1, 1:-1] &= (inside[2:, 1:-1] & inside[:-2, 1:-1] & inside[1:-1, 2:]
                               & inside[1:-1, :-2])
        inside[[0, -1], :] = False
        inside[:, [0, -1]] = False
    return inside


def _pixels(x0: float, x1: float, y0: float, y1: float, margin: int = 2) -> np.ndarray:
    """``[H, W]`` bool: the pixels whose centres see the rectangle [x0, x1] x [y0, y1] of the z = 0
    plane, ``margin`` pixels in from its edges."""
    x, y = _rays()
    return _erode((x > x0) & (x < x1) & (y > y0) & (y < y1), margin)


def _through_the_back(x0: float, x1: float, depth: float, ior: float = 1.5) -> np.ndarray:
    """``[H, W]`` bool: the pixels of a box's front face (2 in from its edges) whose view ray,
    refracted by Snell's law, leaves through the box's back face (0.03 in from its edges), not
    a side: where the box's depth is the chord the map describes."""
    x, y = _rays()
    d = np.stack([x, y, np.full_like(x, -DISTANCE)], -1)
    d /= np.linalg.norm(d, axis=-1, keepdims=True)
    cos_i = -d[..., 2]
    sin_t2 = (1.0 - cos_i ** 2) / ior ** 2
    t = d / ior + (cos_i / ior - np.sqrt(1.0 - sin_t2))[..., None] * np.float64([0, 0, 1])
    ex, ey = x + t[..., 0] * depth / -t[..., 2], y + t[..., 1] * depth / -t[..., 2]
    m = 0.03
    exits = (ex > x0 + m) & (ex < x1 - m) & (np.abs(ey) < 0.5 - m)
    return _pixels(x0, x1, -0.5, 0.5) & exits


def region_masks() -> dict[str, np.ndarray]:
    """``[H, W]`` bool per region, each 2 pixels in from its edges: ``clear`` and ``opaque``
    (the quad's stripes of transmission 1 and 0), ``shallow`` and ``deep`` (the boxes' front
    faces where the refracted view ray leaves through the back face)."""
    x0, x1, y0, y1 = QUAD
    step = (x1 - x0) / 4.0
    stripes = [_pixels(x0 + k * step, x0 + (k + 1) * step, y0, y1) for k in range(4)]
    return {"clear": stripes[0] | stripes[2], "opaque": stripes[1] | stripes[3],
            "shallow": _through_the_back(*BOXES[0]), "deep": _through_the_back(*BOXES[1])}
