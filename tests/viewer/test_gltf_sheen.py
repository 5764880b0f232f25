"""glTF KHR_materials_sheen end to end: a Charlie sheen (Estevez & Kulla 2017) layered over the
base by the spec's albedo scaling (shaders/lib/layers.glsl, relight/reference/sheen.py). The
loader (factors, both textures, one-line errors, no "ignored" warning), the G-buffer channel only
a scene using it allocates, the albedo table (never above 1) and a white furnace of the layered
BSDF, and a grid of spheres (gltf_spheres.py) rasterised against ``relight reference`` (Mitsuba,
our BSDF plugin) within stated tolerances, beside the file without the extension, which the
same bounds reject; the path tracer and ggx_mc on the same grid."""
import json
import math

import numpy as np
import pytest
from gltf_builder import load_warnings
from gltf_spheres import (
    extension_materials,
    grid_scene,
    grid_truth,
    mc_runs,
    per_sphere,
    sphere_grid,
)

TEXEL = (128, 230, 100, 128)  # the sheen texture: colour RGB (sRGB), roughness A


@pytest.fixture(scope="module")
def renderer(ctx):
    from viewer.renderer import Renderer

    return Renderer(ctx=ctx)


def _sheen_materials(with_extension: bool = True) -> list[dict]:
    """A blue plastic without sheen (the control); velvet: a red rough base under a pink sheen
    of roughness 0.3; a dark base under a bright grey sheen of roughness 0.8; a grey base under
    a sheen whose colour and roughness come from a texture (TEXEL: colour (0.22, 0.79, 0.13),
    roughness 0.5)."""
    def pbr(rgb, rough):
        return {"baseColorFactor": [*rgb, 1.0], "metallicFactor": 0.0, "roughnessFactor": rough}
    sheens = [(pbr((0.05, 0.05, 0.3), 0.8), None),
              (pbr((0.3, 0.02, 0.05), 0.8), {"sheenColorFactor": [1.0, 0.6, 0.6],
                                             "sheenRoughnessFactor": 0.3}),
              (pbr((0.1, 0.1, 0.1), 0.6), {"sheenColorFactor": [0.8, 0.8, 0.8],
                                           "sheenRoughnessFactor": 0.8}),
              (pbr((0.5, 0.5, 0.5), 0.5), {"sheenColorFactor": [1.0, 1.0, 1.0],
                                           "sheenColorTexture": {"index": 0},
                                           "sheenRoughnessFactor": 1.0,
                                           "sheenRoughnessTexture": {"index": 0}})]
    return extension_materials(sheens, "KHR_materials_sheen", with_extension)


def _sheen_grid(path, with_extension: bool = True):
    return sphere_grid(path, _sheen_materials(with_extension),
                       ["KHR_materials_sheen"] if with_extension else (), texel=TEXEL)


def test_sheen_loads_and_fills_its_channel_only_where_used(tmp_path, renderer):
    from viewer.errors import InputError
    from viewer.geometry.loaders import load_mesh
    from viewer.specialize import analyse, specialise

    path = _sheen_grid(tmp_path / "sheen.gltf")
    meshes, messages = load_warnings(path)
    assert messages == []
    assert [m.material.has_sheen for m in meshes] == [False, True, True, True]
    assert meshes[1].material.sheen_color == (1.0, 0.6, 0.6)
    assert meshes[1].material.sheen_roughness == 0.3
    assert {"sheen_color", "sheen_roughness"} <= set(meshes[3].textures)
    srgb = np.asarray(TEXEL[:3]) / 255.0
    linear = np.where(srgb <= 0.04045, srgb / 12.92, ((srgb + 0.055) / 1.055) ** 2.4)
    np.testing.assert_allclose(meshes[3].textures["sheen_color"][0, 0, :3], linear, atol=2e-3)
    np.testing.assert_allclose(meshes[3].textures["sheen_roughness"][0, 0, 3], 128 / 255,
                               atol=1e-6)
    scene = grid_scene(path, 4)
    layout = specialise(analyse(renderer, scene), scene.render).layout
    plain = grid_scene(_sheen_grid(tmp_path / "plain.gltf", False), 4)
    plain_layout = specialise(analyse(renderer, plain), plain.render).layout
    assert layout.with_sheen and not plain_layout.with_sheen
    assert layout.bytes_per_pixel() == plain_layout.bytes_per_pixel() + 16  # one attachment
    import warnings

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        renderer.render(scene.with_render(model="blinn_phong"))
    assert any("ignores the KHR_materials_sheen sheen" in str(w.message) for w in caught)
    doc = json.loads(path.read_text())
    doc["materials"][1]["extensions"]["KHR_materials_sheen"]["sheenColorFactor"] = [2.0, 0, 0]
    bad = tmp_path / "bad.gltf"
    bad.write_text(json.dumps(doc))
    with pytest.raises(InputError, match="sheenColorFactor = 2.0 must be a number in"):
        load_mesh(bad)


def test_the_sheen_albedo_table_never_exceeds_one():
    """The shipped table (lib/sheen_table.glsl) is the albedo of the normalised lobe: its
    largest value 1 (bound 1 + 1e-6), and recomputed entries agree with it to 1e-5 (float64
    quadrature, printed to 7 digits). The spec's lobe itself (before N) reflects 1.64 at
    r = 0.07, n.v = 0.001: what the normalisation is for; N = 1 from r = 0.215."""
    from relight.reference.sheen import (
        normalization,
        read_table,
        sheen_albedo_quadrature,
        table_axes,
    )

    table, norm = read_table(), read_table(normalization=True)
    assert table.max() <= 1.0 + 1e-6 and table.min() >= 0.0
    mus, rs = table_axes()
    for j, i in ((0, 3), (5, 10), (16, 0), (32, 32)):
        assert sheen_albedo_quadrature(mus[i], rs[j]) / norm[j] == pytest.approx(
            table[j, i], abs=1e-5)
    assert sheen_albedo_quadrature(0.001, 0.07) > 1.5
    assert normalization(0.07) > 1.5 and normalization(0.22) == 1.0


@pytest.mark.parametrize("roughness", [0.07, 0.15, 0.3, 0.6, 1.0])
def test_white_furnace_the_sheen_keeps_energy(roughness):
    """A white sheen (max3 C = 1) over a white Lambertian base (albedo exactly 1, the strictest
    base): sheen + (1 - max(E(v), E(l))) x base never reflects more than 1 (float64 quadrature
    of the reference's sheen, 256 x 128 cells; measured max 1.0019 over the 25 cases, bound
    1 + 3e-3: the table's interpolation error and the quadrature's), and without the scaling
    the same sum exceeds 1 wherever the sheen reflects anything (by E; asserted > 1 + E/2)."""
    from relight.reference.sheen import read_table, sheen_albedo_lookup, sheen_cos_numpy

    table = read_table()
    mu = (np.arange(256) + 0.5) / 256
    phi = (np.arange(128) + 0.5) / 128 * 2.0 * math.pi
    m, p = np.meshgrid(mu, phi, indexing="ij")
    s = np.sqrt(1.0 - m * m)
    wo = np.stack([s * np.cos(p), s * np.sin(p), m], -1).reshape(-1, 3)
    for nov in (0.02, 0.1, 0.3, 0.6, 1.0):
        base = np.repeat(wo[:, 2:3] / math.pi, 3, axis=1)
        sheen = sheen_cos_numpy((1.0, 1.0, 1.0), roughness, nov, wo)
        scale = 1.0 - np.maximum(sheen_albedo_lookup(table, nov, roughness),
                                 sheen_albedo_lookup(table, wo[:, 2], roughness))
        total = (sheen + scale[:, None] * base).mean(0) * 2.0 * math.pi
        assert np.all(total <= 1.0 + 3e-3), (nov, total)
        e = sheen.mean(0)[0] * 2.0 * math.pi
        unscaled = (sheen + base).mean(0) * 2.0 * math.pi
        assert e < 1e-3 or np.all(unscaled > 1.0 + e / 2.0), (nov, e, unscaled)


@pytest.fixture(scope="module")
def sheen_truth(mitsuba_llvm, tmp_path_factory):
    """The sheen grid (with and without the extension) and its reference (128 spp, direct)."""
    return grid_truth(tmp_path_factory, "sheen", _sheen_grid)


# per sphere (|bias|, median per-pixel error) bounds. Measured: bias -0.2, +7.2, +1.6, +3.2 %,
# median 5.9, 10.9, 9.5, 7.2 %. The velvet's +7.2 % is the spec's cheaper scaling the split sum
# keeps for the environment's light (1 - max3(C) E(n.v), where the truth's base keeps
# 1 - max3(C) max(E(n.v), E(n.l)): grazing sky reaches its diffuse base too brightly; the sun is
# scaled light by light, exactly); the sheen's environment term is the irradiance at n, where
# the Charlie lobe reads grazing light (the median errors)
SPLIT_SUM_BOUNDS = ((0.10, 0.10), (0.10, 0.13), (0.06, 0.12), (0.06, 0.10))


def test_sheen_spheres_match_the_reference(sheen_truth, renderer):
    """The spheres of :func:`_sheen_materials` (64 x 64), ggx_split_sum against ``relight
    reference`` (128 spp, direct light): per sphere bias and median per-pixel error within
    SPLIT_SUM_BOUNDS (measured beside them). The same file without the sheen fails on the
    bright sheen (bias -46.6 %) and the textured one (+12.4 %, median 12.3 %: the base the
    sheen darkens); on the velvet it is off by -8.0 % (median 11.0 %), inside the bounds the
    split sum's own +7.2 % needs: the path tracer's test below tells that one apart."""
    ext, plain, ref = sheen_truth
    ref = ref.radiance
    ours = per_sphere(renderer.render(ext.with_render(model="ggx_split_sum")).radiance, ref, 4)
    base = per_sphere(renderer.render(plain.with_render(model="ggx_split_sum")).radiance, ref, 4)
    for k, (s, (b, med)) in enumerate(zip(ours, SPLIT_SUM_BOUNDS)):
        assert abs(s[0]) <= b and s[1] <= med, (k, s)
    assert all(abs(s[0]) > b or s[1] > med
               for s, (b, med) in zip(base[2:], SPLIT_SUM_BOUNDS[2:])), base


def test_the_monte_carlo_models_converge_to_the_reference_with_the_sheen(sheen_truth, renderer):
    """``path`` (direct light as the reference's max_depth 2) integrates the layered BSDF: the
    per-block z-test (8 seeds x 16 spp) passes with the sheen (measured max |z| 2.5, threshold
    11.8) and rejects the file without it (39 of 144 blocks fail). ``ggx_mc`` (no visibility:
    the neighbours' shadows are missing) is within 8 % per sphere (measured +1.0, +3.6, +5.4,
    +4.3 %). The traced material rows carry the sheen's factors (ROW["sheen"])
    for secondary hits."""
    from relight.bench.path import block_test
    from viewer.raytrace.scene import MATERIAL_VEC4S, ROW, material_rows

    ext, plain, ref = sheen_truth

    result = block_test(mc_runs(renderer, ext, "path", max_depth=2), ref)
    assert result.count > 20 and result.passed, result
    assert not block_test(mc_runs(renderer, plain, "path", max_depth=2), ref).passed
    mc = per_sphere(mc_runs(renderer, ext, "ggx_mc")[:4].mean(0), ref.radiance, 4)
    assert all(abs(s[0]) <= 0.08 for s in mc), mc
    meshes = renderer.geometry(ext.objects[0])
    rows = material_rows(meshes, [{} for _ in meshes])
    for k, mesh in enumerate(meshes):
        np.testing.assert_allclose(rows[k * MATERIAL_VEC4S + ROW["sheen"]],
                                   (*mesh.material.sheen_color, mesh.material.sheen_roughness))


def test_a_scene_file_material_takes_a_sheen(renderer):
    """A scene file's material names the sheen as the loader's (``sheen_color``,
    ``sheen_roughness``): a primitive sphere takes it (the velvet above lifts its mean radiance:
    measured 0.0685 -> 0.0745 at 32 x 32), the written scene names it only where set, and a
    colour outside [0, 1] is one line naming the field."""
    import tomllib

    from viewer.errors import SceneError
    from viewer.scene.description import scene_from_dict
    from viewer.scene.files import scene_toml

    def scene(material):
        return scene_from_dict({
            "camera": {"position": [0, 0, 3], "target": [0, 0, 0], "fov_y": 30, "size": [32, 32]},
            "environment": {"procedural": "sky", "width": 64}, "render": {"tonemap": "none"},
            "objects": [{"type": "sphere", "material": material}]})

    base = {"albedo": [0.3, 0.02, 0.05], "roughness": 0.8}
    velvet = scene({**base, "sheen_color": [1.0, 0.6, 0.6], "sheen_roughness": 0.3})
    plain = renderer.render(scene(base)).radiance[..., :3].mean()
    assert renderer.render(velvet).radiance[..., :3].mean() > plain * 1.05
    written = tomllib.loads(scene_toml(velvet))["objects"][0]["material"]
    assert written["sheen_color"] == [1.0, 0.6, 0.6] and written["sheen_roughness"] == 0.3
    assert "sheen_color" not in tomllib.loads(scene_toml(scene(base)))["objects"][0]["material"]
    with pytest.raises(SceneError, match="sheen_color") as err:
        scene({**base, "sheen_color": [2.0, 0.0, 0.0]})
    assert "\n" not in str(err.value)
