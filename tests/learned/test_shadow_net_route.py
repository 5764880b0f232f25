"""The shadow estimator's visibility in place of SSAO (``[render] shadow_net_use =
"visibility"``, viewer/graph/shadow_net.py): the passes it declares for each model that can take
it, a model that cannot is one line, and what the lighting pass reads is the estimator's V - for
the classical models in place of O(x), for the student in place of S(x) - checked with estimators
whose V is a known constant."""
import dataclasses
import math

import numpy as np
import pytest
import torch
from safetensors.numpy import save_file

from learned.export import load_model
from learned.neural.lighting import lighting_from_gl
from learned.parity.checks import shadow_net as check_module
from learned.parity.checks.models import gl_gbuffer, gl_texture
from learned.twins.neural import shade_neural
from viewer.errors import SceneError
from viewer.neural import default_weights, reads_occlusion, reads_visibility, required_settings
from viewer.neural.shadow_net import DEFAULT_ARCHITECTURE, metadata, random_tensors
from viewer.passes.shade import shade_defines
from viewer.renderer import Renderer
from viewer.scene.description import scene_from_dict

SIZE = [32, 24]


def _scene(**render):
    doc = {**check_module.PARITY_SCENE, "camera": {**check_module.PARITY_SCENE["camera"],
                                                   "size": SIZE}}
    return scene_from_dict(doc).with_render(**render)


def constant_weights(folder, v: tuple[float, float, float]):
    """An estimator whose visibility is ``v`` (per colour) on every pixel: zero weights,
    sigmoid(bias) = v."""
    tensors = {k: np.zeros_like(t) for k, t in random_tensors(DEFAULT_ARCHITECTURE, 0).items()}
    tensors["out.bias"][:] = [math.log(c / (1.0 - c)) if c < 1.0 else 40.0  # sigmoid(40) = 1.0f
                              for c in v]
    path = folder / f"constant_{'_'.join(map(str, v))}.safetensors"
    save_file(tensors, str(path), metadata=metadata(DEFAULT_ARCHITECTURE, tensors))
    return path


@pytest.mark.parametrize("model", ["blinn_phong", "ggx_split_sum", "neural"])
def test_every_rasterised_model_renders_with_the_estimators_visibility(tmp_path, model):
    """The lighting drawn twice: unshadowed with SSAO into the estimator's input, then with V;
    no product pass. A finite frame that differs from the product form's."""
    path = check_module.parity_weights(tmp_path)
    scene = _scene(model=model, shadow_net=str(path), shadow_net_use="visibility")
    renderer = Renderer()
    try:
        names = [p.name for p in renderer.graph(scene).passes]
        i = names.index("shadow_net:shade")
        assert names[i + 1:i + 16] == [f"shadow_net:{n}" for n in (
            "down1", "enc1", "down2", "enc2", "down3", "enc3", "down4", "enc4", "down5", "enc5",
            "dec4", "dec3", "dec2", "dec1", "visibility")], names
        assert names[i + 16] == "shade" and "shadow_net" not in names
        routed = gl_texture(renderer.draw(scene).radiance)
        product = gl_texture(renderer.draw(scene.with_render(shadow_net_use="product")).radiance)
    finally:
        renderer.release()
    assert np.isfinite(routed).all() and routed[..., :3].max() > 0.05
    assert np.abs(routed - product)[..., :3].max() > 1e-2


def test_a_model_that_reads_no_ssao_is_one_line(tmp_path):
    path = check_module.parity_weights(tmp_path)
    scene = _scene(model="ggx_mc", shadow_net=str(path), shadow_net_use="visibility")
    renderer = Renderer()
    try:
        with pytest.raises(SceneError, match="model 'ggx_mc' does not read it"):
            renderer.graph(scene)
    finally:
        renderer.release()
    with pytest.raises(SceneError, match="render.shadow_net_use = 'shade' is not one of"):
        scene_from_dict({"render": {"shadow_net_use": "shade"}})


def test_a_visibility_of_one_is_no_occlusion_for_the_classical_models(tmp_path):
    """V = 1 everywhere: split-sum's frame is its frame without SSAO (the route reads V where it
    read O(x)); the same frame through SSAO is darker (the route is not reading SSAO)."""
    path = constant_weights(tmp_path, (1.0, 1.0, 1.0))
    scene = _scene(model="ggx_split_sum", ssao=False)
    renderer = Renderer()
    try:
        plain = gl_texture(renderer.draw(scene).radiance)
        one = gl_texture(renderer.draw(scene.with_render(
            shadow_net=str(path), shadow_net_use="visibility")).radiance)
        ssao = gl_texture(renderer.draw(scene.with_render(ssao=True)).radiance)
    finally:
        renderer.release()
    # the same program but for a multiplication by 1.0 and the same inputs: equal to float32
    # rounding of the unchanged sums
    np.testing.assert_allclose(one, plain, atol=1e-6, rtol=1e-6)
    assert np.abs(ssao - plain).max() > 1e-2


@pytest.mark.parametrize("student", ["shipped", "sx"])
def test_the_students_visibility_input_is_the_estimators(tmp_path, student):
    """V = (0.2, 0.5, 0.35) everywhere: the student's lighting pass equals its torch twin given
    their mean, 0.35, as its O(x) (the shipped student, whose diffuse factor it scales) or as its
    S(x) and O(x) inputs (the S(x) student shipped before), within the parity check's envelope,
    and not its twin on the frame's SSAO."""
    from relight.bench.real_assets_cases import sx_student_file

    weights = default_weights("student") if student == "shipped" else sx_student_file()
    path = constant_weights(tmp_path, (0.2, 0.5, 0.35))
    scene = _scene(model="neural", shadow_net=str(path), shadow_net_use="visibility",
                   weights=str(weights))
    scene = dataclasses.replace(scene, render=required_settings(scene.render))
    assert reads_occlusion(scene.render)
    assert reads_visibility(scene.render) == (student == "sx")
    renderer = Renderer()
    try:
        targets = renderer.draw(scene)
        # a student with a learned indirect factor: the lighting pass's output is ``direct``
        glsl = gl_texture(targets.direct if targets.indirect_factor is not None
                          else targets.radiance)
        gb = gl_gbuffer(targets)
        ssao = torch.from_numpy(gl_texture(targets.ssao))  # the frame's SSAO, which V replaced
        defines = dict(shade_defines("neural", scene.render))
        for k in ("SUN_LIGHT", "ENV_LIGHTS"):  # the frame's specialisation (check_model)
            if targets.variant.defines.get(k, 0):
                defines[k] = targets.variant.defines[k]
        lighting = lighting_from_gl(renderer, scene.environment,
                                    sun=bool(defines.get("SUN_LIGHT", 0)))
        net = load_model(str(weights), "student")
        twin = {}
        for name, occ in (("estimator", torch.full_like(ssao, 0.35)), ("ssao", ssao)):
            envelope = {"weight_bits": 8}
            with torch.enable_grad():
                twin[name] = shade_neural("neural", net, gb, targets.camera, lighting, defines,
                                          (0, 1), 0, envelope=envelope,
                                          ssao=occ).detach().numpy()
            twin[name + ":bound"] = envelope["bound"].numpy()
    finally:
        renderer.release()
    # the parity check's per-pixel bound (learned/parity/checks/neural.py check_model: atol
    # 1e-4 + rtol 5e-4 + the lookups' filtering envelope through the network)
    bound = 1e-4 + 5e-4 * np.abs(twin["estimator"][..., :3]) + twin["estimator:bound"]
    err = np.abs(glsl[..., :3] - twin["estimator"][..., :3])
    assert (err <= bound).all(), float((err - bound).max())
    off = (np.abs(glsl[..., :3] - twin["ssao"][..., :3]) > 10 * bound).any(-1)
    assert off.mean() > 0.3, off.mean()  # most pixels: the sky is the same either way


@pytest.mark.parametrize("name", ["shadow_net.safetensors", "shadow_net_mesh.safetensors"])
def test_the_shipped_estimators_multiply_the_viewers_default_frame(name):
    """A shipped file records the frame it was trained on (indirect light, specular occlusion);
    with the viewer's defaults and SSAO on (what shadow_net needs) that frame is the one drawn, so
    the frame check says nothing. A file trained on other frames would warn on every use."""
    import warnings

    from assets import ASSET_ROOT
    from viewer.graph.shadow_net import check_frame
    from viewer.neural.shadow_net import frame_settings, read_shadow_net
    from viewer.scene.settings import RenderSettings

    net = read_shadow_net(ASSET_ROOT / "weights" / name)
    default = RenderSettings().with_flat(raytrace=False, ssao=True, indirect=True)
    frame = frame_settings(net.training)
    assert frame["indirect"] is True
    assert frame["specular_occlusion"] is default.specular_occlusion is True
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        check_frame(net, default)
