"""A scene's triangles as rays see them, on the CPU: every mesh and tessellated primitive of the
scene (the rasteriser's own triangles, so a difference against it is shading, never geometry)
gathered into one vertex and triangle array, their materials in a table and their maps in one
texture array, and the BVH (:mod:`.bvh`) over them.

What rays see, and what they do not (the reference's choices, :mod:`relight.reference.scene`):

* meshes and primitives; **splat clouds** as their Gaussians, each inside a closed proxy: shadow
  rays pass them with the light their opacity leaves, bounce rays stop at their opaque cores
  (:mod:`.splat_proxies`); **image-space stacks**
  have no geometry off-screen and are not traced (their shadows stay contact shadows');
* alphaMode MASK surfaces are cut where the base colour's alpha is below the cutoff; **BLEND**
  surfaces are left out (they cast no shadow in the shadow maps either);
* at a secondary hit: the material's factors and every map the rasteriser reads for them
  (:data:`MAP_SLOTS`: base colour, metallic-roughness, emissive, ``KHR_materials_specular``'s two,
  ``_clearcoat``'s factor and roughness, ``_sheen``'s two, ``_anisotropy``'s, ``_iridescence``'s
  factor and thickness, ``_transmission``'s; ``TEXCOORD_0``, ``KHR_texture_transform``, wrap modes;
  resampled to :data:`MAP_SIZE`), the ``KHR_materials_ior`` / ``specular`` lobe
  (:meth:`Material.dielectric`), the ``KHR_materials_clearcoat`` coat (on the vertex normal: its
  normal map is not traced), the ``KHR_materials_transmission`` / ``_volume`` factors (a
  transmissive surface is seen from both sides whatever its doubleSided: a thin wall, or a volume's
  inside), ``KHR_materials_sheen``, ``KHR_materials_anisotropy`` (in the triangle's UV frame),
  ``KHR_materials_iridescence``'s film, the interpolated vertex normal; normal maps, occlusion maps,
  vertex colours and ``TEXCOORD_1`` are read only at the first hit (the G-buffer's: a map on
  ``TEXCOORD_1`` is read at ``TEXCOORD_0`` by rays);
* degenerate (zero-area) and non-finite triangles are left out with a warning naming the mesh.
"""
from __future__ import annotations

import math
import warnings
from dataclasses import dataclass

import numpy as np

from .bvh import BVH, build_bvh, child_pairs, triangle_boxes

MAP_SIZE = 256  # every map of a traced material, resampled to this square size
MAP_LAYER_BYTES = MAP_SIZE * MAP_SIZE * 8  # one layer of the map array (RGBA16F): 512 KiB
# a material's cutoff (surface row, w) marking a closed proxy counted only where a ray enters it
# (a splat's proxy, :mod:`.splat_proxies`; raytrace.glsl finds its faces by their edge texel,
# rt_entered_splat, and compiles the splats in where a material has it, RT_SPLATS); -1: no mask
ENTERED_ONLY = -2.0


def _always(material) -> bool:
    return True


# The map-slot table: every map a secondary hit reads, in slot order (raytrace.glsl RT_MAP_<KEY>
# is the slot's index), each with when the rasteriser reads it
# (viewer.passes.mesh_uploads.mesh_defines): a map the rasteriser ignores is not traced either.
# A slot is two rows of a material (:func:`material_rows`): a new map is one entry here and its
# RT_MAP_ define and lookup in raytrace.glsl.
MAP_SLOTS = {
    "base_color": _always,
    "metallic_roughness": _always,
    "emissive": _always,
    "specular": lambda m: m.ior is not None,  # KHR_materials_specular: A; with the glTF lobe
    "specular_color": lambda m: m.ior is not None,  # RGB
    "clearcoat": lambda m: m.clearcoat > 0.0,  # KHR_materials_clearcoat: R
    "clearcoat_roughness": lambda m: m.clearcoat > 0.0,  # G
    "sheen_color": lambda m: m.has_sheen,  # KHR_materials_sheen: RGB
    "sheen_roughness": lambda m: m.has_sheen,  # A
    "anisotropy": lambda m: m.has_anisotropy,  # KHR_materials_anisotropy: RG direction, B
    "iridescence": lambda m: m.has_iridescence,  # KHR_materials_iridescence: R
    "iridescence_thickness": lambda m: m.has_iridescence,  # G
    "transmission": lambda m: m.transmission > 0.0,  # KHR_materials_transmission: R
}
MAPS = tuple(MAP_SLOTS)
# a material's rows (raytrace.glsl reads them at these offsets): the factors, then the slots
ROW = {"base": 0, "surface": 1, "emission": 2, "dielectric": 3, "clearcoat": 4,
       "transmission": 5, "volume": 6, "sheen": 7, "anisotropy": 8, "iridescence": 9,
       "specular": 10, "slots": 11}
MATERIAL_VEC4S = ROW["slots"] + 2 * len(MAP_SLOTS)  # raytrace.glsl RT_MATERIAL_ROWS
_WRAP_CODES = {"repeat": 0, "clamp": 1, "mirror": 2}


@dataclass
class TraceGeometry:
    """The traced triangles of a set of meshes (their geometry only: materials are
    :func:`material_rows`, set every frame)."""

    vertices: np.ndarray   # [V, 8] float32: position xyz, u, normal xyz, v (TEXCOORD_0)
    triangles: np.ndarray  # [N, 4] uint32: vertex indices, mesh index; in BVH leaf order
    nodes: np.ndarray      # [K, 16] float32: interior nodes' child pairs (bvh.child_pairs)
    # [N, 12] float32: p0, p1 - p0, p2 - p0 (xyz), as triangles; the first w: 1 + the splat a
    # splat proxy's face belongs to (its row in ``splats``), 0 for any other triangle
    edges: np.ndarray
    maps: np.ndarray       # [L, MAP_SIZE, MAP_SIZE, 4] float32: every distinct map, a layer each
    layers: list           # per mesh: {map key: layer}
    bvh: BVH
    skipped: int           # triangles left out (degenerate or non-finite)
    # [S, 16] float32: every splat proxy mesh's splat_rows (splat_proxies.splat_rows), in mesh
    # order (the edges' w says which a face belongs to)
    splats: np.ndarray = None

    @property
    def nbytes(self) -> int:
        return int(self.vertices.nbytes + self.triangles.nbytes + self.nodes.nbytes
                   + self.edges.nbytes + self.maps.nbytes // 2)  # maps are uploaded as half floats

    @property
    def triangle_count(self) -> int:
        return int(self.triangles.shape[0])


def build_trace_geometry(meshes) -> TraceGeometry:
    """Gather ``meshes`` (world space) and build the BVH over their triangles."""
    verts, tris, layers, maps, owners, rows = [], [], [], [], [], []
    base, skipped, splat_base = 0, 0, 0
    seen = {}  # id(image) -> (layer, image): the image kept alive while its id is a key
    for k, mesh in enumerate(meshes):
        p = np.asarray(mesh.positions, np.float32)
        idx = np.asarray(mesh.indices, np.int64).reshape(-1, 3)
        keep = _good_triangles(p, idx)
        if not keep.all():
            bad = int((~keep).sum())
            skipped += bad
            warnings.warn(f"{mesh.source or mesh.name or 'a mesh'}: {bad} of {len(idx)} "
                          f"triangles are degenerate or not finite; rays do not see them",
                          stacklevel=3)
        idx = idx[keep]
        uv = (np.asarray(mesh.uvs, np.float32) if mesh.uvs is not None
              else np.zeros((len(p), 2), np.float32))
        nrm = np.asarray(mesh.normals, np.float32)
        v = np.concatenate([p, uv[:, :1], nrm, uv[:, 1:2]], axis=1)
        verts.append(np.nan_to_num(v, nan=0.0, posinf=0.0, neginf=0.0))
        tris.append(np.concatenate([idx + base, np.full((len(idx), 1), k)], axis=1))
        splat_rows = (getattr(mesh, "splat_rows", None) if getattr(mesh, "entered_only", False)
                      else None)
        if splat_rows is not None:  # 12 vertices a splat, in splat_rows' order
            owners.append(splat_base + idx[:, 0] // 12 + 1)
            rows.append(splat_rows.reshape(-1, 16))
            splat_base += len(splat_rows)
        else:
            owners.append(np.zeros(len(idx), np.int64))
        base += len(p)
        mine = {}
        for key, read in MAP_SLOTS.items():
            if key in mesh.textures and read(mesh.material):
                image = mesh.textures[key]
                if id(image) not in seen:  # an image several maps share is one layer
                    seen[id(image)] = (len(maps), image)
                    maps.append(resample_map(image, MAP_SIZE))
                mine[key] = seen[id(image)][0]
        layers.append(mine)
    vertices = (np.concatenate(verts).astype(np.float32) if verts
                else np.zeros((0, 8), np.float32))
    triangles = (np.concatenate(tris).astype(np.uint32) if tris
                 else np.zeros((0, 4), np.uint32))
    if len(triangles) == 0:
        warnings.warn("the scene has no triangles for rays to hit: every ray misses",
                      stacklevel=3)
    lo, hi = triangle_boxes(vertices[:, :3], triangles[:, :3].astype(np.int64))
    bvh = build_bvh(lo, hi)
    triangles = triangles[bvh.order]
    owner = (np.concatenate(owners) if owners else np.zeros(0, np.int64))[bvh.order]
    # what the traversal tests a triangle with (float32 differences, as ray_triangle takes them)
    p = vertices[:, :3][triangles[:, :3].astype(np.int64)]  # [N, 3, 3]
    edges = np.zeros((len(triangles), 3, 4), np.float32)
    edges[:, 0, :3] = p[:, 0]
    edges[:, 1, :3] = p[:, 1] - p[:, 0]
    edges[:, 2, :3] = p[:, 2] - p[:, 0]
    edges[:, 0, 3] = owner  # exact in float32 below 2^24 splats (MAX_TRACED is 100 000)
    stack = (np.stack(maps).astype(np.float32) if maps
             else np.zeros((0, MAP_SIZE, MAP_SIZE, 4), np.float32))
    splats = np.concatenate(rows).astype(np.float32) if rows else np.zeros((0, 16), np.float32)
    return TraceGeometry(vertices, triangles, child_pairs(bvh), edges.reshape(-1, 12), stack,
                         layers, bvh, skipped, splats)


def slot_rows(meshes, layers) -> np.ndarray:
    """``[K, 2 * len(MAP_SLOTS), 4]`` float32: each mesh's map slots as :func:`material_rows`
    writes them (layer, uv transform and wrap modes; layer -1 for none). They depend on the
    traced geometry's layers and the meshes' samplers only, not on material sliders, so an
    uploaded scene computes them once (:class:`viewer.raytrace.upload.TraceBuffers`)."""
    out = np.zeros((max(len(meshes), 1), 2 * len(MAPS), 4), np.float32)
    for k, mesh in enumerate(meshes):
        for j, key in enumerate(MAPS):
            layer = layers[k].get(key, -1) if k < len(layers) else -1
            sampling = mesh.sampling.get(key)
            mat = sampling.uv_matrix() if sampling is not None else np.eye(3)
            wrap = sampling.wrap if sampling is not None else ("repeat", "repeat")
            out[k, 2 * j] = (mat[0, 0], mat[0, 1], mat[0, 2], float(layer))
            out[k, 2 * j + 1] = (mat[1, 0], mat[1, 1], mat[1, 2],
                                 float(_WRAP_CODES[wrap[0]] + 3 * _WRAP_CODES[wrap[1]]))
    return out


def material_rows(meshes, layers, slots: np.ndarray | None = None) -> np.ndarray:
    """``[K * MATERIAL_VEC4S, 4]`` float32: each mesh's material as ``raytrace.glsl`` reads it
    (factors, alpha, emission, sidedness at the :data:`ROW` offsets; then each map slot of
    :data:`MAP_SLOTS`: its layer, uv transform and wrap modes, layer -1 for none; ``slots``:
    :func:`slot_rows` of the same meshes and layers, computed here when not given)."""
    if slots is None:
        slots = slot_rows(meshes, layers)
    rows = np.zeros((max(len(meshes), 1) * MATERIAL_VEC4S, 4), np.float32)
    for k, mesh in enumerate(meshes):
        m = mesh.material
        r = rows[k * MATERIAL_VEC4S:(k + 1) * MATERIAL_VEC4S]
        r[ROW["base"]] = (*m.albedo, mesh.base_alpha)
        cutoff = float(mesh.alpha_cutoff) if mesh.alpha_mode == "MASK" else -1.0
        if getattr(mesh, "entered_only", False):
            cutoff = ENTERED_ONLY
        r[ROW["surface"]] = (m.roughness, m.metallic, m.specular, cutoff)
        r[ROW["emission"]] = (*mesh.emissive, float(mesh.double_sided))
        r[ROW["slots"]:] = slots[k]
        r[ROW["dielectric"]] = m.dielectric()  # (F0, F90) of the glTF lobe, (0, 0, 0, -1) for none
        # KHR_materials_specular's maps recompute F0 from these (dielectric_f0_ior)
        r[ROW["specular"]] = (*m.specular_color, 0.0 if m.ior is None else float(m.ior))
        r[ROW["clearcoat"]] = (m.clearcoat, m.clearcoat_roughness, 0.0, 0.0)
        r[ROW["transmission"]] = m.transmission_row()  # factor, volume IOR (0: thin), dispersion
        r[ROW["volume"]] = (*m.attenuation_coefficient(), 0.0)  # sigma per unit length
        r[ROW["sheen"]] = (*m.sheen_color, m.sheen_roughness)  # KHR_materials_sheen
        # KHR_materials_anisotropy: strength, (cos, sin) of the rotation
        r[ROW["anisotropy"]] = (m.anisotropy_strength, math.cos(m.anisotropy_rotation),
                                math.sin(m.anisotropy_rotation), 0.0)
        # KHR_materials_iridescence: factor, thickness (the maximum), IOR, the minimum
        r[ROW["iridescence"]] = m.iridescence_row()
    return rows


def resample_map(image: np.ndarray, size: int) -> np.ndarray:
    """``image [H, W, C]`` (C = 1..4, linear) as ``[size, size, 4]`` float32: box-averaged by
    halves while more than twice the size, then bilinear at the new texel centres; missing
    channels are 0 (alpha: 1), a single channel is repeated into RGB."""
    img = np.asarray(image, np.float32)
    if img.ndim == 2:
        img = img[..., None]
    c = img.shape[-1]
    rgba = np.zeros(img.shape[:2] + (4,), np.float32)
    rgba[..., 3] = 1.0
    if c == 1:
        rgba[..., :3] = img[..., :1]
    else:
        rgba[..., :min(c, 4)] = img[..., :min(c, 4)]
    img = np.nan_to_num(rgba)
    while img.shape[0] >= 2 * size * 2 or img.shape[1] >= 2 * size * 2:
        h, w = img.shape[0] // 2 * 2, img.shape[1] // 2 * 2
        img = img[:h, :w].reshape(h // 2, 2, w // 2, 2, 4).mean(axis=(1, 3))
    h, w = img.shape[:2]
    y = np.clip((np.arange(size) + 0.5) * h / size - 0.5, 0, h - 1)
    x = np.clip((np.arange(size) + 0.5) * w / size - 0.5, 0, w - 1)
    y0, x0 = np.floor(y).astype(int), np.floor(x).astype(int)
    y1, x1 = np.minimum(y0 + 1, h - 1), np.minimum(x0 + 1, w - 1)
    fy, fx = (y - y0)[:, None, None], (x - x0)[None, :, None]
    top = img[y0][:, x0] * (1 - fx) + img[y0][:, x1] * fx
    bot = img[y1][:, x0] * (1 - fx) + img[y1][:, x1] * fx
    return (top * (1 - fy) + bot * fy).astype(np.float32)


def _good_triangles(p: np.ndarray, idx: np.ndarray) -> np.ndarray:
    if len(idx) == 0:
        return np.zeros(0, bool)
    inside = (idx >= 0).all(axis=1) & (idx < len(p)).all(axis=1)
    safe = np.where(inside[:, None], idx, 0)
    v = p[safe].astype(np.float64)
    finite = np.isfinite(v).all(axis=(1, 2))
    area2 = np.linalg.norm(np.cross(v[:, 1] - v[:, 0], v[:, 2] - v[:, 0]), axis=1)
    scale = np.abs(v).max(axis=(1, 2)) + 1e-30
    return inside & finite & (area2 > 1e-12 * scale * scale)
