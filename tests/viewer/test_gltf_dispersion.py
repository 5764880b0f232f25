"""glTF KHR_materials_dispersion end to end: the loader (the value, one-line errors, no
"ignored" warning, no effect and no G-buffer channel without a volume), the path tracer against
``relight reference`` through a dispersive glass prism before emissive stripes (the per-block
z-test; the same file without dispersion fails it), the rasteriser's per-channel refraction (the
colour fringes' direction and size against the path tracer's) and a white furnace (dispersion
creates no energy). The asset: gltf_prism.py."""
import json
import warnings

import numpy as np
import pytest
from gltf_builder import load_warnings
from gltf_prism import prism_file, prism_scene

DEPTH = 10  # path segments, both renderers (as test_gltf_transmission.py's glass)
SIZE = (48, 32)


@pytest.fixture(scope="module")
def renderer(ctx):
    from viewer.renderer import Renderer

    return Renderer(ctx=ctx)


def test_a_scene_file_material_takes_a_dispersion():
    """A scene file's material names it as the loader's (``dispersion``, with ``transmission``
    and ``thickness`` for a volume); the written scene names it only where set; a negative one is
    one line naming the field."""
    import tomllib

    from viewer.errors import SceneError
    from viewer.scene.description import scene_from_dict
    from viewer.scene.files import scene_toml

    def scene(material):
        return scene_from_dict({"camera": {"size": [16, 16]},
                                "objects": [{"type": "sphere", "material": material}]})

    glass = {"transmission": 1.0, "thickness": 1.0}  # (the volume IOR: 1.5)
    s = scene({**glass, "dispersion": 20.0})
    assert s.objects[0].material.has_dispersion
    assert tomllib.loads(scene_toml(s))["objects"][0]["material"]["dispersion"] == 20.0
    assert "dispersion" not in tomllib.loads(scene_toml(scene(glass)))["objects"][0]["material"]
    # a material that sets ior (a field whose default is None) is written too (it was a KeyError)
    flint = tomllib.loads(scene_toml(scene({**glass, "ior": 1.7, "dispersion": 20.0})))
    assert flint["objects"][0]["material"]["ior"] == 1.7
    with pytest.raises(SceneError, match="dispersion") as err:
        scene({**glass, "dispersion": -1.0})
    assert "\n" not in str(err.value)


def test_dispersion_loads_without_a_warning(tmp_path, renderer):
    """The prism's material reads dispersion 30 (a dispersive volume: the G-buffer's dispersion
    channel and the mesh's USE_DISPERSION define, the traced row's z); the same material as a
    thin wall (no volume) keeps the value but disperses nothing (the spec), so no channel and no
    define, and renders bit-identically to the same wall without the extension (split-sum and
    path); a negative or non-numeric dispersion is one line naming the file."""
    from viewer.errors import InputError
    from viewer.passes.mesh_uploads import mesh_defines
    from viewer.specialize import analyse, specialise

    path = prism_file(tmp_path / "prism.gltf")
    (glass, _), messages = load_warnings(path)
    assert messages == []
    assert glass.material.dispersion == 30.0 and glass.material.has_dispersion
    assert glass.material.transmission_row()[2] == 30.0
    assert mesh_defines(glass).get("USE_DISPERSION") == 1
    scene = prism_scene(path, *SIZE)
    assert specialise(analyse(renderer, scene), scene.render).layout.with_dispersion
    doc = json.loads(path.read_text())
    del doc["materials"][0]["extensions"]["KHR_materials_volume"]
    thin = tmp_path / "thin.gltf"
    thin.write_text(json.dumps(doc))
    (wall, _), messages = load_warnings(thin)
    assert messages == [] and wall.material.dispersion == 30.0
    assert not wall.material.has_dispersion and "USE_DISPERSION" not in mesh_defines(wall)
    assert wall.material.transmission_row()[2] == 0.0
    assert not specialise(analyse(renderer, prism_scene(thin, *SIZE)),
                          scene.render).layout.with_dispersion
    del doc["materials"][0]["extensions"]["KHR_materials_dispersion"]
    plain = tmp_path / "plain.gltf"
    plain.write_text(json.dumps(doc))
    for render in ({"raytrace": False}, {"model": "path", "samples": 1, "max_depth": 4}):
        pair = [renderer.render(prism_scene(p, *SIZE, **render)).radiance for p in (thin, plain)]
        assert np.array_equal(*pair), render  # no effect, no cost: the same programs
    for bad in (-1.0, "x"):
        doc["materials"][0]["extensions"]["KHR_materials_dispersion"] = {"dispersion": bad}
        thin.write_text(json.dumps(doc))
        with pytest.raises(InputError, match="dispersion") as err:
            load_warnings(thin)
        assert "\n" not in str(err.value) and str(thin) in str(err.value)


@pytest.fixture(scope="module")
def prism_paths(tmp_path_factory, renderer):
    """The dispersive prism's scene (48 x 32) and ``path`` runs with it (8 seeds x 8 spp) and
    without dispersion (8 seeds x 4 spp)."""
    d = tmp_path_factory.mktemp("prism")
    ext = prism_scene(prism_file(d / "prism.gltf"), *SIZE)
    plain = prism_scene(prism_file(d / "plain.gltf", dispersion=None), *SIZE)
    return ext, _runs(renderer, ext, 8, 8), _runs(renderer, plain, 8, 4)


@pytest.fixture(scope="module")
def prism_reference(mitsuba_llvm, prism_paths):
    """``relight reference`` of the dispersive prism (32 spp)."""
    from relight.reference import ReferenceOptions, render_reference

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the backdrop's single-sided culling
        return render_reference(prism_paths[0], ReferenceOptions(spp=32, max_depth=DEPTH),
                                progress=False)


def _runs(renderer, scene, seeds, spp):
    return np.asarray([renderer.render(scene.with_render(
        model="path", samples=spp, seed=s, sampling="mis", max_depth=DEPTH)).radiance
        for s in range(seeds)], np.float64)


def test_the_path_tracer_converges_to_the_reference_through_a_dispersive_prism(prism_paths,
                                                                              prism_reference):
    """``path`` (per-channel BTDF, a channel drawn at each crossing by the path's throughput)
    against ``relight reference`` (the channel drawn uniformly: as unbiased; 8 seeds x 8 spp
    against 32 spp): the per-block z-test passes (measured max |z| 4.3, threshold 13.1, 288
    blocks; 5.7 when path drew uniformly too) and rejects the file
    without dispersion (its stripes' edges are white: 2 of 288 blocks fail, max |z| 23)."""
    from relight.bench.path import block_test

    _, runs, plain = prism_paths
    ref = prism_reference
    result = block_test(runs, ref)
    assert result.count > 200 and result.passed, result
    assert not block_test(plain, ref).passed


def _channel_shifts(img, rows, cols):
    """(red, blue) horizontal shift in pixels that best lays each channel's profile (the mean
    over ``rows``, within ``cols``) onto green's: least squares over shifts of 0.05 px, linear
    interpolation. A stripe seen through a dispersive prism moves by a different amount in each
    channel; without dispersion every channel's shift is 0."""
    prof = img[rows][:, cols, :3].mean(0)
    x = np.arange(len(prof), dtype=np.float64)
    out = []
    for c in (0, 2):
        err = [(((np.interp(x + d, x, prof[:, c]) - prof[:, 1])[4:-4]) ** 2).mean()
               for d in np.arange(-4.0, 4.001, 0.05)]
        out.append(-4.0 + 0.05 * int(np.argmin(err)))
    return np.array(out)


def test_the_raster_prism_shows_the_colour_fringes_the_path_tracer_shows(tmp_path, prism_paths,
                                                                         renderer):
    """The split-sum's forward pass refracts each channel by its own IOR (three lookups of the
    transmission copy): through the prism red and blue stripes shift apart from green in the
    directions the path tracer's do (red to one side, blue to the other; path: mean of its 8 x 8
    spp), by a spread (red's shift minus blue's) of 1.25 px (measured red +0.80, blue -0.45;
    path +1.35, -1.25: 2.6 px, ratio 0.48): the raster's single
    refraction over the thickness factor's chord, without the back face's second refraction and
    the gap to the backdrop, shows about half of it (bound: 0.3-1.0 of the path's). Without
    dispersion the raster's channels do not move (|shift| < 0.1 px) and no warning is given."""
    ext, runs, _ = prism_paths
    rows, cols = slice(10, 24), slice(9, 39)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        raster = renderer.render(ext.with_render(raytrace=False)).radiance
    assert not caught, [str(w.message) for w in caught]
    plain = renderer.render(prism_scene(prism_file(tmp_path / "plain.gltf", dispersion=None),
                                        *SIZE, raytrace=False)).radiance
    r_shift = _channel_shifts(raster, rows, cols)
    p_shift = _channel_shifts(runs.mean(0), rows, cols)
    assert np.all(np.sign(r_shift) == np.sign(p_shift)) and r_shift[0] != r_shift[1]
    spread = (r_shift[0] - r_shift[1]) / (p_shift[0] - p_shift[1])
    assert 0.3 <= spread <= 1.0, (r_shift, p_shift)
    assert np.abs(_channel_shifts(plain, rows, cols)).max() < 0.1


def test_dispersion_creates_no_energy_in_a_white_furnace(tmp_path, renderer):
    """The prism alone under a uniform white environment, ``path`` to depth 10 (4 seeds x 16
    spp, 32 x 24): the dispersive prism's mean over its pixels is at most the environment's 1
    and the non-dispersive prism's, each within 4 standard errors (measured 0.925 +- 0.0006
    against 0.929 +- 0.0003: a little less, the dispersive prism's blue, of IOR 1.875, meeting
    total internal reflection more often, which the BTDF, without a Fresnel factor of its own,
    does not return; ``relight reference`` of the same, 256 spp: 0.921 +- 0.005; ``path``
    drawing the channels uniformly: 0.906 +- 0.006, its 4 seeds' spread being 10x wider), and
    loses no more than 20 %."""
    means = []
    for disp in (30.0, None):
        path = prism_file(tmp_path / f"furnace{disp}.gltf", dispersion=disp, backdrop=False)
        scene = prism_scene(path, 32, 24).with_environment(procedural="white", path=None)
        runs = _runs(renderer, scene, 4, 16)
        cov = runs[..., 3].min(0) > 0.999
        per_seed = runs[:, cov, :3].mean(axis=(1, 2))
        means.append((per_seed.mean(), per_seed.std(ddof=1) / 2.0))
    (m_disp, se_disp), (m_plain, se_plain) = means
    assert m_disp <= 1.0 + 4.0 * se_disp + 1e-3
    assert m_disp <= m_plain + 4.0 * np.hypot(se_disp, se_plain) + 1e-3
    assert m_disp >= 0.8
