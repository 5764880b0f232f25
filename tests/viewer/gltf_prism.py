"""A glass prism before a striped emissive backdrop (KHR_materials_dispersion's test asset):
a wedge of glass (a right triangle in x-z extruded along y) whose front face is tilted about
the vertical so that light through it is deviated sideways, the more the larger the IOR, in
front of a black quad emitting vertical white stripes. A dispersive prism splits each stripe's
edges into colour fringes; built with :class:`gltf_builder.GltfBuilder`."""
import numpy as np
from gltf_builder import GltfBuilder, quad

from viewer.scene.description import scene_from_dict

HALF_WIDTH = 0.5   # the prism spans x in [-0.5, 0.5], y in [-0.5, 0.5]
DEPTH = 0.5        # its thickness along z at x = +0.5 (0 at x = -0.5): the front face's slope
GAP = 0.15         # from the prism's flat back face (z = 0) to the backdrop
STRIPES = 8        # white stripes across the backdrop's 2 units (texture 256 wide)


def _prism():
    """``(positions, normals, indices)`` of the closed wedge, flat-shaded (a vertex per face)."""
    w, d = HALF_WIDTH, DEPTH
    a, b, c = (-w, 0.0), (w, 0.0), (w, d)  # the cross-section in (x, z): back, side, front faces
    faces = []
    for (x0, z0), (x1, z1) in ((a, b), (b, c), (c, a)):  # the three sides, outward normals
        n = np.array([z0 - z1, 0.0, x1 - x0])
        n = -n if np.dot(n, [x0 + x1 - (a[0] + b[0] + c[0]) * 2 / 3,
                             0.0, z0 + z1 - (a[1] + b[1] + c[1]) * 2 / 3]) < 0 else n
        quad_ = [(x0, -w, z0), (x1, -w, z1), (x1, w, z1), (x0, w, z0)]
        faces.append((quad_, n / np.linalg.norm(n)))
    for y in (-w, w):  # the end caps
        faces.append(([(a[0], y, a[1]), (b[0], y, b[1]), (c[0], y, c[1])], np.array([0, y, 0])))
    pos, nrm, idx = [], [], []
    for verts, n in faces:
        base = len(pos)
        tri_n = np.cross(np.subtract(verts[1], verts[0]), np.subtract(verts[2], verts[0]))
        order = list(range(len(verts))) if np.dot(tri_n, n) > 0 else list(range(len(verts)))[::-1]
        for k in order:
            pos.append(verts[k])
            nrm.append(n / np.linalg.norm(n))
        idx += [base + k for k in ((0, 1, 2) if len(verts) == 3 else (0, 1, 2, 0, 2, 3))]
    return (np.asarray(pos, np.float32), np.asarray(nrm, np.float32),
            np.asarray(idx, np.uint16))


def prism_file(path, dispersion: float | None = 30.0, backdrop: bool = True, ior: float = 1.5):
    """The prism (smooth glass, KHR_materials_transmission 1 and _volume, ``ior``; with
    KHR_materials_dispersion ``dispersion`` unless None) and, :data:`GAP` behind it, the striped
    emissive backdrop (2 x 2 units, emissive strength 1, :data:`STRIPES` white stripes)."""
    b = GltfBuilder()
    ext = {"KHR_materials_transmission": {"transmissionFactor": 1.0},
           "KHR_materials_volume": {"thicknessFactor": DEPTH / 2},
           "KHR_materials_ior": {"ior": ior}}
    if dispersion is not None:
        ext["KHR_materials_dispersion"] = {"dispersion": dispersion}
    glass = b.material(pbrMetallicRoughness={"baseColorFactor": [1, 1, 1, 1], "metallicFactor": 0.0,
                                             "roughnessFactor": 0.0}, extensions=ext)
    pos, nrm, idx = _prism()
    b.mesh({"POSITION": b.accessor(pos, minmax=True), "NORMAL": b.accessor(nrm)},
           b.accessor(idx), glass)
    if backdrop:
        stripe = (np.arange(256) * STRIPES // 256) % 2 == 0
        level = np.where(stripe, 255, 0)[None, :].repeat(256, 0)
        rgba = np.stack([level, level, level, np.full_like(level, 255)], -1).astype(np.uint8)
        tex = b.image(rgba, {"magFilter": 9728, "minFilter": 9728})
        m = b.material(pbrMetallicRoughness={"baseColorFactor": [0, 0, 0, 1],
                                             "metallicFactor": 0.0, "roughnessFactor": 1.0},
                       emissiveFactor=[1.0, 1.0, 1.0], emissiveTexture={"index": tex})
        quad(b, m, node={"translation": [0.0, 0.0, -GAP]})
    b.doc["extensionsUsed"] = sorted(ext)
    return b.save(path)


def prism_scene(path, width: int = 64, height: int = 48, **render):
    """The prism seen from +z (narrow field of view: the prism fills ~70 % of the width)."""
    return scene_from_dict({
        "camera": {"position": [0.0, 0.0, 6.0], "target": [0.0, 0.0, 0.0], "fov_y": 11.0,
                   "size": [width, height]},
        "environment": {"procedural": "sky", "width": 64, "sun_azimuth_deg": 40.0},
        "render": {"multiscatter": False, "ao": False, "tonemap": "none",
                   "background": "transparent", **render},
        "objects": [{"type": "mesh", "path": str(path)}]})
