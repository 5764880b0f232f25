"""glTF KHR_materials_transmission and KHR_materials_volume end to end, in the path tracer and
the reference (exact), and in the rasterising models' forward pass (refracting a copy of the
opaque frame: an approximation, measured against the path tracer): the loader (values, one-line
errors, no "ignored" warning), the G-buffer channel only a scene using it allocates, white
furnaces (a numpy quadrature of the BTDFs, and the path tracer's glass in a white environment),
the plugin's BTDF against the numpy formula, and a grid of glass spheres in front of a checker
backdrop: ``path`` converges to ``relight reference`` (the per-block z-test) and the same file
without the extensions fails it; the split-sum's refraction of it against ``path``."""
import json
import math
import warnings

import numpy as np
import pytest
from gltf_builder import GltfBuilder, load_warnings, quad
from gltf_spheres import RADIUS, _place, grid_scene, sphere_masks, uv_sphere

GLASS = [  # thin smooth wall; tinted volume; rough volume; rough thin wall, partly transmissive
    {"transmission": {"transmissionFactor": 1.0}, "rough": 0.0, "color": [1.0, 1.0, 1.0]},
    {"transmission": {"transmissionFactor": 1.0}, "rough": 0.0, "color": [1.0, 1.0, 1.0],
     "volume": {"thicknessFactor": 0.8, "attenuationColor": [0.9, 0.5, 0.3],
                "attenuationDistance": 0.5}},
    {"transmission": {"transmissionFactor": 1.0}, "rough": 0.3, "color": [1.0, 1.0, 1.0],
     "volume": {"thicknessFactor": 0.8}},
    {"transmission": {"transmissionFactor": 0.6}, "rough": 0.4, "color": [0.8, 0.9, 0.5]},
]
EXTENSIONS = ["KHR_materials_transmission", "KHR_materials_volume"]


def glass_grid(path, with_extensions: bool = True, backdrop: bool = True):
    """The spheres of :data:`GLASS` in a 2 x 2 grid (gltf_spheres' placement) and, 1 behind
    them, a diffuse checker quad (8 x 8 squares of 0.9 and 0.1) filling the view: a 256 x 256
    map, the ray tracer's own size (viewer.raytrace.scene.MAP_SIZE), so that secondary hits see
    it unfiltered (a smaller map is resampled bilinearly: 8 x 8 texels become ramps)."""
    b = GltfBuilder()
    pos, nrm, uv, idx = uv_sphere()
    for k, g in enumerate(GLASS):
        ext = {"KHR_materials_transmission": g["transmission"]}
        if "volume" in g:
            ext["KHR_materials_volume"] = g["volume"]
        m = b.material(pbrMetallicRoughness={"baseColorFactor": g["color"] + [1.0],
                                             "metallicFactor": 0.0, "roughnessFactor": g["rough"]},
                       **({"extensions": ext} if with_extensions else {}))
        attrs = {"POSITION": b.accessor(pos * RADIUS, minmax=True),
                 "NORMAL": b.accessor(nrm), "TEXCOORD_0": b.accessor(uv)}
        x, y = _place(k, len(GLASS))
        b.mesh(attrs, b.accessor(idx), m, node={"translation": [x, y, 0.0]})
    if backdrop:
        checker = ((np.arange(256)[:, None] // 32 + np.arange(256)[None] // 32) % 2).astype(float)
        level = np.where(checker > 0, 0.9, 0.1) ** (1 / 2.2) * 255  # sRGB texture
        rgba = np.concatenate([np.repeat(level[..., None], 3, -1),
                               np.full((256, 256, 1), 255.0)], -1).round().astype(np.uint8)
        tex = b.image(rgba, {"magFilter": 9728, "minFilter": 9728})
        m = b.material(pbrMetallicRoughness={"baseColorTexture": {"index": tex},
                                             "metallicFactor": 0.0, "roughnessFactor": 1.0})
        quad(b, m, node={"translation": [0.0, 0.0, -1.0], "scale": [1.7, 1.7, 1.0]})
    if with_extensions:
        b.doc["extensionsUsed"] = list(EXTENSIONS)
    return b.save(path)


@pytest.fixture(scope="module")
def renderer(ctx):
    from viewer.renderer import Renderer

    return Renderer(ctx=ctx)


def test_transmission_and_volume_load_without_a_warning(tmp_path, renderer):
    from viewer.specialize import analyse, specialise

    meshes, messages = load_warnings(glass_grid(tmp_path / "glass.gltf"))
    assert messages == []
    m = [mesh.material for mesh in meshes]
    assert [x.transmission for x in m[:4]] == [1.0, 1.0, 1.0, 0.6] and m[4].transmission == 0.0
    assert [x.volume for x in m[:4]] == [False, True, True, False]
    assert m[1].attenuation_color == (0.9, 0.5, 0.3) and m[1].attenuation_distance == 0.5
    np.testing.assert_allclose(m[1].attenuation_coefficient(),
                               [-math.log(c) / 0.5 for c in (0.9, 0.5, 0.3)])
    assert m[2].attenuation_coefficient() == (0.0, 0.0, 0.0)  # infinite distance: clear
    assert m[1].transmission_row()[:2] == (1.0, 1.5) and m[0].transmission_row()[:2] == (1.0, 0.0)
    scene = grid_scene(glass_grid(tmp_path / "g2.gltf"), 4)
    spec = specialise(analyse(renderer, scene), scene.render)
    assert spec.layout.with_transmission and not spec.layout.with_clearcoat
    plain = grid_scene(glass_grid(tmp_path / "plain.gltf", with_extensions=False), 4)
    layout = specialise(analyse(renderer, plain), plain.render).layout
    assert not layout.with_transmission
    # T fills the base layout's free component (ao is omitted), the IOR takes a new attachment
    assert layout.bytes_per_pixel() + 16 == spec.layout.bytes_per_pixel() == 64
    from viewer.models import ignored_lobes, model_info  # the renderer warns these once

    for model in ("blinn_phong", "ggx_split_sum", "path"):  # refracted forward, or traced
        assert ignored_lobes(model_info(model), spec.layout) == []
    for model in ("ggx_mc", "neural"):  # no forward pass of their own: split-sum's, and a warning
        ((lobe, message),) = ignored_lobes(model_info(model), spec.layout)
        assert lobe == "transmission" and "shaded by ggx_split_sum" in message


@pytest.mark.parametrize("bad, message", [
    ({"KHR_materials_transmission": {"transmissionFactor": 1.5}}, "transmissionFactor = 1.5"),
    ({"KHR_materials_volume": {"thicknessFactor": -1}}, "thicknessFactor = -1"),
    ({"KHR_materials_volume": {"attenuationColor": [1, 2]}}, "attenuationColor"),
    ({"KHR_materials_volume": {"attenuationDistance": 0}}, "attenuationDistance = 0"),
])
def test_bad_transmission_values_are_one_line_errors(tmp_path, bad, message):
    from viewer.errors import InputError
    from viewer.geometry.loaders import load_mesh

    b = GltfBuilder()
    quad(b, b.material(extensions=bad))
    path = b.save(tmp_path / "bad.gltf")
    with pytest.raises(InputError, match=message) as err:
        load_mesh(path)
    assert "\n" not in str(err.value) and "bad.gltf" in str(err.value)


def _hemispheres(n_mu: int = 512, n_phi: int = 256):
    mu = (np.arange(n_mu) + 0.5) / n_mu
    phi = (np.arange(n_phi) + 0.5) / n_phi * 2.0 * math.pi
    m, p = np.meshgrid(mu, phi, indexing="ij")
    s = np.sqrt(1.0 - m * m)
    return np.stack([s * np.cos(p), s * np.sin(p), -m], -1).reshape(-1, 3)  # below


@pytest.mark.parametrize("eta", [None, 1.5, 1.0 / 1.5])
def test_white_furnace_the_btdf_keeps_energy(eta):
    """The BTDF's directional albedo (its f |n.l| over the lower hemisphere; thin wall, and a
    volume seen from outside and from inside) never exceeds 1, so the layered surface
    E_spec + (1 - E_spec) [(1 - T) + T B] stays <= 1: quadrature (512 x 256 cells, float64)
    below 1 + 3e-3 at every view and roughness (measured max 0.9995: a smooth thin wall at
    normal incidence; a refraction into glass at r 0.05 loses nothing but the quadrature's
    error); from inside, total internal reflection leaves less (0.38 at n.v 0.2, r 0.5)."""
    from relight.reference.transmission import btdf_cos_numpy

    wo = _hemispheres()
    got = []
    for rough in (0.05, 0.3, 0.7):
        for nov in (0.2, 0.6, 1.0):
            albedo = btdf_cos_numpy(rough, nov, wo, eta).mean() * 2.0 * math.pi
            got.append(albedo)
            assert albedo <= 1.0 + 3e-3, (rough, nov, albedo)
    assert max(got) > 0.5  # the lobe is not empty


@pytest.mark.parametrize("thickness, inside", [(0.0, False), (1.0, True)])
def test_the_plugin_btdf_is_the_numpy_formula(mitsuba_llvm, thickness, inside):
    """The Dr.Jit plugin's eval below the surface against relight.reference.transmission's
    float64 numpy BTDF times kd T (kd = 1 - E_spec for a white dielectric): a thin wall from
    outside, a volume from inside (eta 1 / 1.5, the frame mirrored, attenuated by exp(-sigma t)
    over si.t = 0.5 with sigma = ln 2; from outside the convergence test covers it): float32
    rounding only (2e-3)."""
    mi, dr, _ = mitsuba_llvm
    from relight.reference.bsdf import bsdf_class
    from relight.reference.quadrature import _bilinear, directional_albedo_table
    from relight.reference.transmission import btdf_cos_numpy
    from viewer.scene.material import Material

    mat = Material(albedo=(1.0, 1.0, 1.0), roughness=0.4, transmission=0.7, thickness=thickness,
                   attenuation_color=(0.5, 0.5, 0.5), attenuation_distance=1.0)
    bsdf = bsdf_class(mi, dr)().configure(mat, {}, multiscatter=False)
    rng = np.random.default_rng(5)
    wo = rng.normal(size=(512, 3))
    wo[:, 2] = -np.abs(wo[:, 2])  # the other side
    wo /= np.linalg.norm(wo, axis=1, keepdims=True)
    nov = 0.7
    sign = -1.0 if inside else 1.0
    si = dr.zeros(mi.SurfaceInteraction3f, 512)
    si.wi = mi.Vector3f(float(np.sqrt(1 - nov * nov)), 0.0, sign * nov)
    si.sh_frame = mi.Frame3f(mi.Vector3f(0.0, 0.0, 1.0))
    si.t = 0.5
    wo_mi = mi.Vector3f(np.ascontiguousarray((wo * [1, 1, sign]).T, np.float32))
    got = np.array(bsdf.eval(mi.BSDFContext(), si, wo_mi)).T
    x, y = _bilinear(directional_albedo_table(), nov, 0.4)
    kd = 1.0 - (0.04 * (y - x) + 1.0 * x)
    eta = None if thickness == 0.0 else (1.0 / 1.5 if inside else 1.5)
    want = kd * 0.7 * btdf_cos_numpy(0.4, nov, wo, eta) * (0.5 ** 0.5 if inside else 1.0)
    assert want.max() > 0.05
    np.testing.assert_allclose(got, np.repeat(want[:, None], 3, 1), rtol=2e-3, atol=1e-5)


DEPTH = 10  # path segments, both renderers: see the convergence test


@pytest.fixture(scope="module")
def glass_truth(mitsuba_llvm, tmp_path_factory):
    """The glass grid (with and without the extensions, 48 x 48) and its reference (128 spp)."""
    from relight.reference import ReferenceOptions, render_reference

    d = tmp_path_factory.mktemp("glass")
    ext = grid_scene(glass_grid(d / "glass.gltf"), 4, cell=24)
    plain = grid_scene(glass_grid(d / "plain.gltf", with_extensions=False), 4, cell=24)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the backdrop's single-sided culling
        ref = render_reference(ext, ReferenceOptions(spp=128, max_depth=DEPTH), progress=False)
    return ext, plain, ref


def _runs(renderer, scene, seeds, spp=16, **render):
    return np.asarray([renderer.render(scene.with_render(
        model="path", samples=spp, seed=s, sampling="mis", max_depth=DEPTH, **render)).radiance
        for s in range(seeds)], np.float64)


def test_the_path_tracer_converges_to_the_reference_through_glass(glass_truth, renderer):
    """``path`` through thin walls and refracting, absorbing volumes against ``relight
    reference`` (128 spp; both max_depth 10): the per-block z-test (8 seeds x 16 spp) passes
    (measured max |z| 3.3, threshold 13.9) and rejects the same file without the extensions
    (opaque white spheres: max |z| 62, 80 of 432 blocks fail). Depth 10, not 6: the path tracer counts an escaping continuation up to segment
    max_depth - 1 where Mitsuba counts it at max_depth too, and through glass that last segment
    carries a lot (the backdrop lit by the sky through a sphere is 6 segments from the camera:
    at depth 6 the spheres read 15-24 % low, max |z| 14.9; at 10 the difference is noise). The
    traced material rows carry the factors (rows 11, 12)."""
    from relight.bench.path import block_test
    from viewer.raytrace.scene import MATERIAL_VEC4S, ROW, material_rows

    ext, plain, ref = glass_truth
    result = block_test(_runs(renderer, ext, 8), ref)
    assert result.count > 20 and result.passed, result
    assert not block_test(_runs(renderer, plain, 8, spp=4), ref).passed
    meshes = renderer.geometry(ext.objects[0])
    rows = material_rows(meshes, [{} for _ in meshes])
    for k, mesh in enumerate(meshes):
        np.testing.assert_allclose(rows[k * MATERIAL_VEC4S + ROW["transmission"]][:2],
                                   mesh.material.transmission_row()[:2])
        np.testing.assert_allclose(rows[k * MATERIAL_VEC4S + ROW["volume"]][:3],
                                   mesh.material.attenuation_coefficient(), rtol=1e-6)


def test_glass_in_a_white_furnace_creates_no_energy(tmp_path, renderer):
    """The glass spheres (no backdrop, no attenuation: the tinted volume's colour set white)
    under a uniform white environment, ``path`` to depth 10: no sphere returns more than the
    environment's 1 (4 seeds x 16 spp, per sphere mean <= 1 + 4 standard errors; measured
    0.9992, 0.9996 for the smooth wall and volume, 0.883 and 0.927 for the rough ones, whose
    single-scattering GGX lobes lose energy at every crossing), nor loses it wholesale (>= 0.8)."""
    path = glass_grid(tmp_path / "furnace.gltf", backdrop=False)
    doc = json.loads(path.read_text())
    doc["materials"][1]["extensions"]["KHR_materials_volume"]["attenuationColor"] = [1, 1, 1]
    doc["materials"][3]["pbrMetallicRoughness"]["baseColorFactor"] = [1, 1, 1, 1]
    path.write_text(json.dumps(doc))
    scene = grid_scene(path, 4, cell=16).with_environment(procedural="white", path=None)
    runs = _runs(renderer, scene, 4)
    cov = runs[..., 3].min(0) > 0.999
    for k in range(4):
        cell = np.zeros(cov.shape, bool)
        cell[(k // 2) * 16:(k // 2 + 1) * 16, (k % 2) * 16:(k % 2 + 1) * 16] = True
        per_seed = runs[:, cell & cov, :3].mean(axis=(1, 2))
        mean, se = per_seed.mean(), per_seed.std(ddof=1) / 2.0
        assert mean <= 1.0 + 4.0 * se + 1e-3, (k, mean, se)
        assert mean >= 0.8, (k, mean)


def _checker_parity(scene, size):
    """``[H, W]`` bool: whether the pixel's view ray meets a light square of
    :func:`glass_grid`'s backdrop (z = -1, 1.7 a side, 8 x 8 squares); its orientation does
    not matter to :func:`_contrast` (a flip inverts every square)."""
    cam = scene.camera
    w, h = size
    t = math.tan(math.radians(cam.fov_y) / 2.0)
    j, i = np.meshgrid(np.arange(w) + 0.5, np.arange(h) + 0.5)
    depth = cam.position[2] + 1.0
    x = (j / w * 2.0 - 1.0) * t * (w / h) * depth
    y = (1.0 - i / h * 2.0) * t * depth
    u, v = np.floor((x / 1.7 + 1.0) * 4.0), np.floor((y / 1.7 + 1.0) * 4.0)
    return (u + v) % 2 == 0


def _contrast(img, mask, light):
    """|mean luminance over the light squares' pixels - over the dark ones'| within ``mask``."""
    lum = img[..., :3].mean(-1)
    return abs(lum[mask & light].mean() - lum[mask & ~light].mean())


def _passes(renderer):
    return [p["name"] for p in renderer.last_graph.describe()["passes"]]


def test_raster_glass_refracts_the_opaque_frame(tmp_path, renderer):
    """The default model (split-sum) draws the glass grid in the forward pass, refracting a
    mip-mapped copy of the opaque frame (the graph's ``transmission_copy``), against the path
    tracer (48 x 48, 64 spp, depth 10): the mean colour over each sphere within the envelope
    measured for the approximation (one refraction at the front face, no inner reflections, the
    volume's thickness for the chord), per channel ratio raster / path:
    - thin smooth wall: 0.99-1.00 (bound 0.93-1.07): both see the checker straight through;
    - tinted volume: 1.24-1.38 (bound 0.9-1.6: the exit point converges near the sphere's
      middle, where a light square lies, while the ball lens shows an inverted, wider image),
      and its tint, each channel over the mean, within 0.92-1.03 (bound 0.8-1.2);
    - rough volume: 1.05-1.07 (bound 0.9-1.2; the mip level blurs as its BTDF does);
    - rough thin wall, T = 0.6, tinted base: 0.85-1.18 (bound 0.75-1.3).
    The thin sphere is no longer opaque: the checker's contrast through it (light squares' mean
    luminance minus dark ones') is 0.33 (Blinn-Phong 0.33, path 0.30; bound > 0.2), the same
    sphere without the extensions 0.058 (its shading's own variation; bound < 0.12). No pixel
    is NaN or negative; no transmission warning for split-sum or Blinn-Phong; the scene without
    the extensions gets no copy of its frame."""
    ext = grid_scene(glass_grid(tmp_path / "glass.gltf"), 4, cell=24)
    plain = grid_scene(glass_grid(tmp_path / "plain.gltf", with_extensions=False), 4, cell=24)
    alone = grid_scene(glass_grid(tmp_path / "alone.gltf", backdrop=False), 4, cell=24)
    cov = renderer.render(alone).radiance[..., 3] > 0.999
    inner = cov.copy()  # one pixel in from each silhouette
    inner[1:-1, 1:-1] &= cov[2:, 1:-1] & cov[:-2, 1:-1] & cov[1:-1, 2:] & cov[1:-1, :-2]
    masks = [m & inner for m in sphere_masks(4, 24)]
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        raster = renderer.render(ext).radiance
        assert "transmission_copy" in _passes(renderer)
        phong = renderer.render(ext.with_render(model="blinn_phong")).radiance
    assert not [w for w in caught if "transmission" in str(w.message)]
    opaque = renderer.render(plain).radiance
    assert "transmission_copy" not in _passes(renderer)
    path = renderer.render(ext.with_render(model="path", samples=64, seed=0, sampling="mis",
                                           max_depth=DEPTH)).radiance
    for img in (raster, phong):
        assert np.isfinite(img).all() and img[..., :3].min() >= 0.0
    means = [[img[m, :3].mean(0) for m in masks] for img in (raster, path)]
    ratio = [r / p for r, p in zip(*means)]
    bounds = [(0.93, 1.07), (0.9, 1.6), (0.9, 1.2), (0.75, 1.3)]
    tint = [m[1] / m[1].mean() for m in means]
    light = _checker_parity(ext, (48, 48))
    for k, (lo, hi) in enumerate(bounds):
        assert (lo <= ratio[k]).all() and (ratio[k] <= hi).all(), (k, ratio[k])
    assert ((0.8 <= tint[0] / tint[1]) & (tint[0] / tint[1] <= 1.2)).all()
    for img in (raster, phong, path):
        assert _contrast(img, masks[0], light) > 0.2
    assert _contrast(opaque, masks[0], light) < 0.12
