"""Grids of spheres per glTF material extension, like the Khronos test models
(``CompareIor``, ``CompareSpecular``, ``UnlitTest``): one UV sphere per material in a row along +x,
built with :class:`gltf_builder.GltfBuilder`, and the scene that views them under the procedural
sky (the camera on +z, the row filling the frame)."""
import math

import numpy as np
from gltf_builder import GltfBuilder

from viewer.scene.description import scene_from_dict

RADIUS = 0.4
SPACING = 1.25  # centre to centre: the neighbours hide little of each other's sky


def uv_sphere(rings: int = 24, segments: int = 48):
    """``(positions, normals, uvs, indices)`` of a unit UV sphere (float32, uint16)."""
    theta = np.linspace(0.0, math.pi, rings + 1)
    phi = np.linspace(0.0, 2.0 * math.pi, segments + 1)
    t, p = np.meshgrid(theta, phi, indexing="ij")
    n = np.stack([np.sin(t) * np.cos(p), np.cos(t), -np.sin(t) * np.sin(p)], -1).reshape(-1, 3)
    uv = np.stack([p / (2.0 * math.pi), t / math.pi], -1).reshape(-1, 2)
    idx = []
    for i in range(rings):
        for j in range(segments):
            a, b = i * (segments + 1) + j, (i + 1) * (segments + 1) + j
            if i > 0:  # at the poles one of the two triangles is degenerate
                idx += [a, b, a + 1]
            if i < rings - 1:
                idx += [a + 1, b, b + 1]
    return (n.astype(np.float32), n.astype(np.float32), uv.astype(np.float32),
            np.asarray(idx, np.uint16))


def _place(k: int, count: int) -> tuple[float, float]:
    """(x, y) of sphere k of ``count`` in the grid: rows of :func:`grid_columns`, top row first."""
    cols = grid_columns(count)
    rows = -(-count // cols)
    return SPACING * (k % cols - (cols - 1) / 2.0), SPACING * ((rows - 1) / 2.0 - k // cols)


def grid_columns(count: int) -> int:
    return math.ceil(math.sqrt(count))


def extension_materials(spheres, extension: str, with_extension: bool = True) -> list[dict]:
    """glTF materials of ``spheres``, each ``(pbrMetallicRoughness, the extension's dict or
    None)``: the extension on those that have one (none with ``with_extension`` False: the
    negative control's file)."""
    out = []
    for base, ext in spheres:
        m = {"pbrMetallicRoughness": base}
        if ext is not None and with_extension:
            m["extensions"] = {extension: ext}
        out.append(m)
    return out


def sphere_grid(path, materials: list[dict], extensions_used=(), tangents: bool = False,
                texel=None):
    """A glTF file with one sphere of radius :data:`RADIUS` per material, in a square grid
    (:func:`grid_columns` per row) of pitch :data:`SPACING` centred on the origin, z = 0;
    ``tangents``: with TANGENT attributes (along increasing u, w = +1: the UVs' own frame);
    ``texel``: texture 0 is a 2 x 2 image of this RGBA8 colour (the materials' maps)."""
    b = GltfBuilder()
    if texel is not None:
        b.image(np.full((2, 2, 4), texel, np.uint8))
    pos, nrm, uv, idx = uv_sphere()
    phi = uv[:, 0] * 2.0 * math.pi
    tan = np.stack([-np.sin(phi), np.zeros_like(phi), -np.cos(phi), np.ones_like(phi)],
                   -1).astype(np.float32)
    count = len(materials)
    for k, m in enumerate(materials):
        mat = b.material(**m)
        attrs = {"POSITION": b.accessor(pos * RADIUS, minmax=True),
                 "NORMAL": b.accessor(nrm), "TEXCOORD_0": b.accessor(uv)}
        if tangents:
            attrs["TANGENT"] = b.accessor(tan)
        x, y = _place(k, count)
        b.mesh(attrs, b.accessor(idx), mat, node={"translation": [x, y, 0.0]})
    if extensions_used:
        b.doc["extensionsUsed"] = list(extensions_used)
    return b.save(path)


def grid_scene(path, count: int, cell: int = 32, **render):
    """The scene viewing a :func:`sphere_grid` of ``count`` spheres from +z, ``cell`` pixels per
    grid cell (a narrow field of view: little perspective stretch); linear radiance, the sky's
    sun extracted and shaded as a light (the split-sum's default)."""
    cols = grid_columns(count)
    rows = -(-count // cols)
    fov_y = 20.0
    distance = (SPACING * rows / 2.0) / math.tan(math.radians(fov_y / 2.0))
    return scene_from_dict({
        "camera": {"position": [0.0, 0.0, distance], "target": [0.0, 0.0, 0.0], "fov_y": fov_y,
                   "size": [cell * cols, cell * rows]},
        "environment": {"procedural": "sky", "width": 128, "sun_azimuth_deg": 40.0},
        "render": {"multiscatter": False, "ao": False, "tonemap": "none",
                   "background": "transparent", **render},
        "objects": [{"type": "mesh", "path": str(path)}]})


def sphere_masks(count: int, cell: int = 32) -> list[np.ndarray]:
    """``[H, W]`` bool per sphere of :func:`grid_scene`: its own grid cell."""
    cols = grid_columns(count)
    rows = -(-count // cols)
    r, c = np.meshgrid(np.arange(cell * rows) // cell, np.arange(cell * cols) // cell,
                       indexing="ij")
    return [(r == k // cols) & (c == k % cols) for k in range(count)]


def albedo_quadrature(dielectric, roughness, n_dot_v, multiscatter, albedo=(1.0, 1.0, 1.0),
                       metallic=0.0):
    """Directional albedo of the reference BSDF (relight.reference.bsdf.brdf_cos_numpy): a
    float64 midpoint rule over the hemisphere in (cos theta, phi), 512 x 256 cells."""
    from relight.reference.bsdf import brdf_cos_numpy

    mu = (np.arange(512) + 0.5) / 512
    phi = (np.arange(256) + 0.5) / 256 * 2.0 * math.pi
    m, p = np.meshgrid(mu, phi, indexing="ij")
    s = np.sqrt(1.0 - m * m)
    wo = np.stack([s * np.cos(p), s * np.sin(p), m], -1).reshape(-1, 3)
    f = brdf_cos_numpy(albedo, roughness, metallic, 0.5, n_dot_v, wo, multiscatter=multiscatter,
                       dielectric=dielectric)
    return f.reshape(512, 256, 3).mean(axis=(0, 1)) * 2.0 * math.pi


def per_sphere(image, ref, count):
    """Per sphere (its grid cell, pixels both cover): total bias sum(image) / sum(ref) - 1, the
    median per-pixel relative error |image - ref|_1 / |ref|_1, and the mean colour."""
    out = []
    for m in sphere_masks(count):
        cov = m & (image[..., 3] > 0.999) & (ref[..., 3] > 0.999)
        a, b = image[cov][:, :3].astype(np.float64), ref[cov][:, :3].astype(np.float64)
        out.append((a.sum() / b.sum() - 1.0,
                    float(np.median(np.abs(a - b).sum(-1) / np.maximum(b.sum(-1), 1e-9))),
                    a.mean(0)))
    return out


def grid_truth(tmp_path_factory, name: str, grid, spp: int = 128):
    """``(ext, plain, reference)``: :func:`grid_scene` of ``grid(path)`` (four spheres, with the
    extension) and of ``grid(path, False)`` (without), and ``relight reference`` of the first
    (``spp`` samples, max_depth 2: direct light)."""
    import pytest

    from relight.reference import ReferenceOptions, render_reference

    d = tmp_path_factory.mktemp(name)
    ext = grid_scene(grid(d / f"{name}.gltf"), 4)
    plain = grid_scene(grid(d / "plain.gltf", False), 4)
    with pytest.warns(UserWarning, match="single-sided culling"):
        ref = render_reference(ext, ReferenceOptions(spp=spp, max_depth=2), progress=False)
    return ext, plain, ref


def mc_runs(renderer, scene, model: str, seeds: int = 8, **extra) -> np.ndarray:
    """``[seeds, H, W, 4]`` float64: ``model`` at 16 MIS samples per pixel, one render per seed
    (the block z-test's independent runs)."""
    return np.asarray([renderer.render(scene.with_render(
        model=model, samples=16, seed=s, sampling="mis", **extra)).radiance
        for s in range(seeds)], np.float64)
