"""KHR_materials_transmission's transmissionTexture (R x transmissionFactor) and
KHR_materials_volume's thicknessTexture (G x thicknessFactor) end to end, on the test file of
:mod:`gltf_transmission_maps` (a striped thin-walled pane, two glass boxes whose thickness map
says their depths, an emissive backdrop): the loader reads both maps without a warning, only a
mesh with a map gets the map's program variant, and per region the rasteriser's forward pass
(split-sum) agrees with the path tracer, which agrees with ``relight reference``; the same file
without the two maps fails the rasteriser's comparison."""
import json
import warnings

import numpy as np
import pytest
from gltf_builder import load_warnings
from gltf_transmission_maps import mapped_glass, mapped_scene, region_masks

DEPTH = 10  # path segments, as test_gltf_transmission's


@pytest.fixture(scope="module")
def renderer(ctx):
    from viewer.renderer import Renderer

    return Renderer(ctx=ctx)


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    d = tmp_path_factory.mktemp("maps")
    return mapped_glass(d / "mapped.gltf"), mapped_glass(d / "plain.gltf", maps=False)


def test_the_maps_load_without_a_warning(files, tmp_path):
    """Both maps are read (the pane's transmission map, the boxes' thickness and transmission
    maps packed in one image; their samplers) and nothing is warned about them; only a mesh
    that has a map gets its define (the same file without them compiles the variants it always
    did). A KHR_texture_transform on either map is read as on every other map."""
    from viewer.passes.mesh_uploads import mesh_defines

    mapped, plain = files
    meshes, messages = load_warnings(mapped)
    assert messages == []
    assert [sorted(m.textures) for m in meshes] == [["transmission"],
                                                    ["thickness", "transmission"],
                                                    ["thickness", "transmission"], []]
    assert meshes[0].sampling["transmission"].mag_filter == "nearest"
    np.testing.assert_array_equal(np.unique(meshes[0].textures["transmission"][..., 0]), [0, 1])
    defines = [mesh_defines(m) for m in meshes]
    assert "USE_TRANSMISSION_MAP" in defines[0] and "USE_THICKNESS_MAP" not in defines[0]
    assert {"USE_THICKNESS_MAP", "USE_TRANSMISSION_MAP"} <= set(defines[1])
    doc = json.loads(mapped.read_text())
    transform = {"KHR_texture_transform": {"offset": [0.5, 0.0], "scale": [2.0, 1.0]}}
    doc["materials"][0]["extensions"]["KHR_materials_transmission"]["transmissionTexture"][
        "extensions"] = transform
    doc["materials"][1]["extensions"]["KHR_materials_volume"]["thicknessTexture"] = {
        "index": 1, "extensions": transform}
    (tmp_path / "moved.gltf").write_text(json.dumps(doc))
    moved, messages = load_warnings(tmp_path / "moved.gltf")
    assert messages == []
    for mesh, key in ((moved[0], "transmission"), (moved[1], "thickness")):
        assert (mesh.sampling[key].offset, mesh.sampling[key].scale) == ((0.5, 0.0), (2.0, 1.0))
    assert moved[1].sampling["transmission"].offset == (0.0, 0.0)
    bare, messages = load_warnings(plain)
    assert messages == [] and not any(m.textures for m in bare)
    for m in bare:
        assert not {"USE_TRANSMISSION_MAP", "USE_THICKNESS_MAP", "USE_UV0"} & set(mesh_defines(m))


def _means(img, masks):
    return {k: img[m, :3].astype(np.float64).mean(0) for k, m in masks.items()}


def _within(got, want, bounds):
    """Whether every region's per-channel ratio got / want lies in its bounds."""
    return all(((lo <= got[k] / want[k]) & (got[k] / want[k] <= hi)).all()
               for k, (lo, hi) in bounds.items())


# the rasteriser / the path tracer per region and channel: measured, then the bound it guards
RASTER_BOUNDS = {
    "clear": (0.97, 1.03),    # 1.000: both see the backdrop straight through a smooth wall
    "opaque": (0.95, 1.05),   # 0.997: white diffuse under the sky (the map's T = 0)
    # 1.037 and 1.067: the rasteriser's one refraction loses one interface's Fresnel share
    # (1 - E_spec ~ 0.96), the path tracer's two, and inner reflections
    "shallow": (0.97, 1.10),
    "deep": (0.97, 1.12),
}


def test_raster_reads_the_maps_as_the_path_tracer(files, renderer, mitsuba_llvm):
    """96 x 48. Per region, the split-sum's forward pass over the path tracer (32 spp, depth
    10) within :data:`RASTER_BOUNDS` (measured 1.000, 0.997, 1.037, 1.067), and the deep box
    over the shallow one, exp(-sigma 0.6) with sigma = ln 2 / 0.4 (0.354), within 0.93-1.08 of
    the path tracer's (measured raster 0.361, path 0.351). The path tracer sees both maps at
    its primary hit: per region and channel within 2 % of ``relight reference`` (16 spp; measured
    at most 0.64 %), whose opaque stripes are opaque (below 0.3 of the clear ones': measured
    0.12-0.20 per channel). The same file without the maps fails the bounds (measured: opaque
    stripes 5.0-8.3, shallow box 0.37 of the path tracer's). 17.6 s alone, 3-4.5 s after the
    session's first Mitsuba render."""
    from relight.reference import ReferenceOptions, render_reference

    mapped, plain = files
    masks = region_masks()
    scene = mapped_scene(mapped)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        raster = _means(renderer.render(scene).radiance, masks)
    assert not [w for w in caught if "transmission" in str(w.message)
                or "thickness" in str(w.message)]
    path = _means(renderer.render(scene.with_render(
        model="path", samples=32, seed=0, sampling="mis", max_depth=DEPTH)).radiance, masks)
    assert _within(raster, path, RASTER_BOUNDS), (raster, path)
    depth_ratio = (raster["deep"] / raster["shallow"]) / (path["deep"] / path["shallow"])
    assert ((0.93 <= depth_ratio) & (depth_ratio <= 1.08)).all(), depth_ratio
    bare = _means(renderer.render(mapped_scene(plain)).radiance, masks)
    assert not _within(bare, path, {"opaque": RASTER_BOUNDS["opaque"]})
    assert not _within(bare, path, {"shallow": RASTER_BOUNDS["shallow"]})
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the backdrop's single-sided culling
        ref = _means(render_reference(scene, ReferenceOptions(spp=16, max_depth=DEPTH),
                                      progress=False).radiance, masks)
    assert _within(path, ref, {k: (0.98, 1.02) for k in masks}), (path, ref)
    assert (ref["opaque"] < 0.3 * ref["clear"]).all()
