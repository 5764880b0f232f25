"""Materials as authored at a secondary hit (passes/raytrace.glsl rt_surface; the map-slot table
of viewer/raytrace/scene.py MAP_SLOTS): a row of textured spheres - specular, clearcoat, sheen,
anisotropy and iridescence, each lobe's maps a checker - stands behind the camera, seen ONLY in
a mirror, so every pixel of them is a traced hit (and a thin-walled glass whose
transmissionTexture is a checker); ``path`` against ``relight reference`` with the
per-block z-test, and the same scene with the lobes' maps left out of the table (what secondary
hits read before: the factors only) fails it."""
import numpy as np
import pytest
from gltf_builder import QUAD_IDX, GltfBuilder
from gltf_spheres import uv_sphere

from viewer.scene.description import scene_from_dict

SIZE = (160, 32)
CHECKER = 8  # squares a side of the 256^2 maps (the traced maps' own size: no resampling)
RADIUS = 0.45
LOBE_MAPS = ("specular", "specular_color", "clearcoat", "clearcoat_roughness", "sheen_color",
             "sheen_roughness", "anisotropy", "iridescence", "iridescence_thickness",
             "transmission")


def _checker(on, off) -> np.ndarray:
    """256 x 256 RGBA8: ``on`` and ``off`` (RGBA) in CHECKER x CHECKER squares."""
    k = (np.arange(256) * CHECKER // 256)
    mask = ((k[:, None] + k[None, :]) % 2 == 0)[..., None]
    return np.where(mask, np.uint8(on), np.uint8(off)).astype(np.uint8)


def _materials(b: GltfBuilder) -> list[dict]:
    """One material per lobe, its maps a checker between the lobe on and (nearly) off."""
    def pbr(rgb, rough, metal=0.0):
        return {"pbrMetallicRoughness": {"baseColorFactor": [*rgb, 1.0], "metallicFactor": metal,
                                         "roughnessFactor": rough}}
    spec = b.image(_checker((255, 60, 0, 255), (255, 255, 255, 0)))  # colour RGB, factor A
    coat = b.image(_checker((255, 38, 0, 255), (0, 255, 0, 255)))     # factor R, roughness G
    sheen = b.image(_checker((255, 255, 255, 80), (0, 0, 0, 255)))    # colour RGB, roughness A
    aniso = b.image(_checker((255, 128, 255, 255), (128, 255, 0, 255)))  # RG direction, B
    film = b.image(_checker((255, 40, 0, 255), (0, 255, 0, 255)))     # factor R, thickness G
    glass = b.image(_checker((255, 255, 255, 255), (0, 0, 0, 255)))   # transmission R
    out = [pbr((0.02, 0.02, 0.02), 0.15), pbr((0.1, 0.01, 0.01), 0.6),
           pbr((0.05, 0.05, 0.3), 0.8), pbr((0.9, 0.9, 0.9), 0.3, 1.0),
           pbr((0.02, 0.02, 0.02), 0.25), pbr((0.8, 0.3, 0.1), 0.3)]
    out[0]["extensions"] = {"KHR_materials_ior": {"ior": 1.5}, "KHR_materials_specular": {
        "specularFactor": 1.0, "specularTexture": {"index": spec},
        "specularColorFactor": [1.0, 1.0, 1.0], "specularColorTexture": {"index": spec}}}
    out[1]["extensions"] = {"KHR_materials_clearcoat": {
        "clearcoatFactor": 1.0, "clearcoatTexture": {"index": coat},
        "clearcoatRoughnessFactor": 1.0, "clearcoatRoughnessTexture": {"index": coat}}}
    out[2]["extensions"] = {"KHR_materials_sheen": {
        "sheenColorFactor": [1.0, 1.0, 1.0], "sheenColorTexture": {"index": sheen},
        "sheenRoughnessFactor": 1.0, "sheenRoughnessTexture": {"index": sheen}}}
    out[3]["extensions"] = {"KHR_materials_anisotropy": {
        "anisotropyStrength": 1.0, "anisotropyTexture": {"index": aniso}}}
    out[4]["extensions"] = {"KHR_materials_iridescence": {
        "iridescenceFactor": 1.0, "iridescenceTexture": {"index": film},
        "iridescenceIor": 1.8, "iridescenceThicknessMinimum": 100.0,
        "iridescenceThicknessMaximum": 800.0, "iridescenceThicknessTexture": {"index": film}}}
    out[5]["extensions"] = {"KHR_materials_transmission": {
        "transmissionFactor": 1.0, "transmissionTexture": {"index": glass}}}
    return out


def mirror_scene(path):
    """The glTF file and the scene: a mirror quad (z = 0, facing +z) and the six spheres at
    z = 3.5 behind the camera (z = 2, looking at -z): the mirror shows them, the camera does not."""
    b = GltfBuilder()
    mats = _materials(b)
    mirror = b.material(pbrMetallicRoughness={"baseColorFactor": [0.95, 0.95, 0.95, 1.0],
                                              "metallicFactor": 1.0, "roughnessFactor": 0.0})
    quad = np.float32([[-4, 2, 0], [-4, -2, 0], [4, -2, 0], [4, 2, 0]])
    b.mesh({"POSITION": b.accessor(quad, minmax=True),
            "NORMAL": b.accessor(np.tile(np.float32([0, 0, 1]), (4, 1)))},
           b.accessor(QUAD_IDX), mirror)
    pos, nrm, uv, idx = uv_sphere()
    for k, m in enumerate(mats):
        attrs = {"POSITION": b.accessor(pos * RADIUS, minmax=True), "NORMAL": b.accessor(nrm),
                 "TEXCOORD_0": b.accessor(uv)}
        b.mesh(attrs, b.accessor(idx), b.material(**m),
               node={"translation": [1.1 * (k - 2.5), 0.0, 3.5]})
    b.doc["extensionsUsed"] = ["KHR_materials_ior", "KHR_materials_specular",
                               "KHR_materials_clearcoat", "KHR_materials_sheen",
                               "KHR_materials_anisotropy", "KHR_materials_iridescence",
                               "KHR_materials_transmission"]
    b.save(path)
    return scene_from_dict({
        "camera": {"position": [0.0, 0.0, 2.0], "target": [0.0, 0.0, 0.0], "fov_y": 15.0,
                   "size": list(SIZE)},
        # the sun beyond the mirror, high enough to pass over it: it lights the side the mirror
        # shows
        "environment": {"procedural": "sky", "width": 128, "sun_azimuth_deg": 15.0,
                        "sun_elevation_deg": 40.0},
        "render": {"multiscatter": False, "ao": False, "tonemap": "none",
                   "background": "transparent"},
        "objects": [{"type": "mesh", "path": str(path)}]})


@pytest.fixture(scope="module")
def renderer(ctx):
    from viewer.renderer import Renderer

    return Renderer(ctx=ctx)


@pytest.fixture(scope="module")
def mirror_truth(mitsuba_llvm, tmp_path_factory):
    """The mirror scene and its reference (128 spp; max_depth 3: camera, mirror, sphere, light)."""
    from relight.reference import ReferenceOptions, render_reference

    scene = mirror_scene(tmp_path_factory.mktemp("traced_maps") / "mirror.gltf")
    with pytest.warns(UserWarning, match="single-sided culling"):
        ref = render_reference(scene, ReferenceOptions(spp=128, max_depth=3), progress=False)
    return scene, ref


def test_textured_lobes_seen_only_in_a_mirror_converge_to_the_reference(mirror_truth, renderer,
                                                                        monkeypatch):
    """``path`` (16 seeds x 4 spp, max_depth 3) passes the per-block z-test against the reference
    on the mirror scene (measured max |z| 3.3, threshold 7.9, 960 blocks). Secondary hits as they
    were - the lobes' maps left out of the slot table and no film - fail it; so does leaving out
    any one lobe's maps (measured: specular 13 blocks, clearcoat 6, sheen 57, anisotropy 19,
    iridescence 8, transmission 45 with max |z| 45)."""
    from relight.bench.path import block_test
    from viewer.raytrace import scene as traced
    from viewer.scene.material import Material

    scene, ref = mirror_truth

    def runs():
        renderer.resources.trace.release()  # the traced scene is rebuilt with the table as it is
        return np.asarray([renderer.render(scene.with_render(
            model="path", samples=4, seed=s, sampling="mis", max_depth=3)).radiance
            for s in range(16)], np.float64)

    result = block_test(runs(), ref)
    assert result.count > 800 and result.passed, result
    for key in LOBE_MAPS:
        monkeypatch.setitem(traced.MAP_SLOTS, key, lambda m: False)
    film = Material.iridescence_row
    monkeypatch.setattr(Material, "iridescence_row",
                        lambda m, thickness_map=False: (0.0, *film(m)[1:]))
    before = block_test(runs(), ref)
    assert not before.passed, before
    renderer.resources.trace.release()


def test_the_slot_table_is_the_shaders_and_shared_images_are_one_layer(renderer, tmp_path):
    """raytrace.glsl's RT_MAP_* and RT_ROW_* are viewer/raytrace/scene.py's MAP_SLOTS and ROW;
    the mirror scene's ten lobe maps (six images, four of them shared by a lobe's two maps) take
    eight layers of the map array (MAP_LAYER_BYTES = 512 KiB each: 4 MiB): a map the loader decodes
    once for two slots (the coat's R and G, the film's R and G) is one layer; the specular and
    sheen colours are sRGB-decoded apart from their linear alpha, so they are two."""
    import re
    from pathlib import Path

    from viewer.raytrace.scene import (
        MAP_LAYER_BYTES,
        MAP_SLOTS,
        MATERIAL_VEC4S,
        ROW,
        build_trace_geometry,
        material_rows,
    )

    glsl = (Path(__file__).parents[2] / "shaders/passes/raytrace.glsl").read_text()
    slots = {m[0].lower(): int(m[1]) for m in re.findall(r"#define RT_MAP_(\w+) (\d+)", glsl)}
    assert slots.pop("slots") == len(MAP_SLOTS)
    assert slots == {k: j for j, k in enumerate(MAP_SLOTS)}
    rows = {m[0].lower(): int(m[1]) for m in re.findall(r"#define RT_ROW_(\w+) (\d+)", glsl)}
    assert rows == ROW
    scene = mirror_scene(tmp_path / "mirror.gltf")
    meshes = renderer.geometry(scene.objects[0])
    geo = build_trace_geometry(meshes)
    assert geo.maps.shape[0] == 8
    assert geo.maps.shape[0] * MAP_LAYER_BYTES == 8 * 512 * 1024
    table = material_rows(meshes, geo.layers)
    lobes = [dict(zip(MAP_SLOTS, table[k * MATERIAL_VEC4S + ROW["slots"]::2][:len(MAP_SLOTS), 3]))
             for k in range(len(meshes))]
    assert all(v == -1.0 for v in lobes[0].values())  # the mirror: no maps
    assert lobes[2]["clearcoat"] == lobes[2]["clearcoat_roughness"] >= 0.0
    assert lobes[5]["iridescence"] == lobes[5]["iridescence_thickness"] >= 0.0
    assert lobes[1]["specular"] != lobes[1]["specular_color"]
    assert lobes[6]["transmission"] >= 0.0 and lobes[5]["transmission"] == -1.0
    assert sorted({v for d in lobes for v in d.values()} - {-1.0}) == list(range(8))
