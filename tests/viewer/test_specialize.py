"""Scene specialisation: only the channels and lobes a scene needs, with identical output."""
import numpy as np
import pytest

from relight.bench.scenes import bench_scene
from viewer.renderer import Renderer
from viewer.scene.description import scene_from_dict


@pytest.fixture(scope="module")
def renderer(ctx):
    r = Renderer(ctx=ctx)
    yield r
    r.release()


def diffuse_scene():
    return bench_scene("diffuse_only").with_camera(size=(96, 64))


def test_diffuse_only_scene_drops_specular_channels_and_lobe(renderer):
    scene = diffuse_scene()
    spec = renderer.specialization(scene)
    assert spec.defines["SPECULAR_LOBE"] == 0
    # the sky's sun casts a shadow map: its lookups need the surface position, so depth stays
    assert "depth" not in spec.layout.omit and spec.defines.get("SUN_SHADOW") == 1
    assert {"roughness", "metallic", "specular", "ao"} <= spec.layout.omit
    spec = renderer.specialization(scene.with_render(shadows=False))
    assert {"roughness", "metallic", "specular", "depth", "ao"} <= spec.layout.omit
    assert len(spec.layout.attachments) == 1 + 1  # albedo+alpha, normal
    general = renderer.specialization(scene.with_render(specialize=False))
    # all features: 4 attachments + the emission channel (3 components, a fifth) + the glTF
    # dielectric lobe's, clearcoat's and sheen's (4 components each, a sixth to an eighth: GL's
    # guaranteed minimum of draw buffers)
    assert general.defines["SPECULAR_LOBE"] == 1 and len(general.layout.attachments) == 8


@pytest.mark.parametrize("model", ["ggx_split_sum", "blinn_phong", "unlit"])
@pytest.mark.parametrize("which", ["diffuse", "demo"])
def test_specialised_output_equals_the_all_features_path(renderer, model, which):
    from assets import ASSET_ROOT
    from viewer.scene.description import load_scene

    scene = diffuse_scene() if which == "diffuse" else \
        load_scene(ASSET_ROOT / "scenes" / "demo.toml").with_camera(size=(96, 60))
    scene = scene.with_render(model=model)
    a = renderer.render(scene.with_render(specialize=False)).radiance
    b = renderer.render(scene.with_render(specialize=True)).radiance
    # measured: 0 (diffuse: the skipped lobe is exactly zero; demo: same variant)
    np.testing.assert_allclose(b, a, atol=1e-4, rtol=0)


def test_specular_scene_keeps_the_lobe(renderer):
    scene = scene_from_dict({"objects": [{"type": "sphere", "material": {"specular": 0.5}}]})
    spec = renderer.specialization(scene)
    assert spec.defines["SPECULAR_LOBE"] == 1
    assert not ({"roughness", "metallic", "specular"} & spec.layout.omit)


def test_requested_aovs_are_allocated(renderer):
    scene = diffuse_scene()
    frame = renderer.render(scene, aovs=("depth", "roughness"))
    assert frame.aovs["depth"].max() > 1.0  # real depth, not the background value
    assert frame.aovs["roughness"].max() == pytest.approx(1.0)  # the authored values


def test_ssao_needs_depth(renderer):
    spec = renderer.specialization(diffuse_scene().with_render(ssao=True))
    assert "depth" not in spec.layout.omit and "normal" not in spec.layout.omit


def test_lone_stack_is_shaded_in_place_with_identical_output(renderer, tmp_path):
    """A stack-only scene skips the G-buffer copy: the lighting pass reads the stack's textures."""
    from relight.bench.specialize import _diffuse_stack

    scene = _diffuse_stack(renderer, tmp_path)
    spec = renderer.specialization(scene)
    assert spec.direct_stack and spec.defines["SPECULAR_LOBE"] == 0
    general = renderer.render(scene.with_render(specialize=False), aovs=("albedo",))
    special = renderer.render(scene, aovs=("albedo", "normal"))
    np.testing.assert_allclose(special.radiance, general.radiance, atol=1e-4, rtol=0)
    np.testing.assert_array_equal(special.aovs["albedo"], general.aovs["albedo"])


def test_a_layout_beyond_the_draw_buffers_is_one_line_naming_its_channels():
    """Every material extension at once needs more G-buffer attachments than GL guarantees draw
    buffers (8): one SceneError naming them, before anything is allocated; a scene with all
    but one lobe fits."""
    from viewer.errors import SceneError
    from viewer.gbuffer import MAX_ATTACHMENTS, GBufferLayout

    every = dict(with_emission=True, with_dielectric=True, with_clearcoat=True,
                 with_transmission=True, with_sheen=True, with_anisotropy=True,
                 with_iridescence=True)
    with pytest.raises(SceneError) as err:
        GBufferLayout(**every).check_draw_buffers()
    text = str(err.value)
    assert "\n" not in text and "anisotropy" in text and "iridescence" in text
    fits = GBufferLayout(**{**every, "with_iridescence": False})
    assert len(fits.attachments) <= MAX_ATTACHMENTS
    fits.check_draw_buffers()
