"""An estimator that does not read S(x) (architecture ``"env_visibility": false``; issue 38: the
students that read the SSAO pass's visibility of the environment's light turned its noise and
stretch into invented shadows on real assets): its S(x) input holds 1 in the pass
(``SN_ENV_VIS`` 0) and in the torch twin, and the frame marches no S(x) for it."""
import numpy as np
import torch
from safetensors.numpy import save_file

from learned.neural.shadow_net import ShadowNet
from learned.parity.checks import shadow_net as pc
from learned.twins.shadow_net import shadow_net
from viewer.neural import needs_env_visibility
from viewer.neural.shadow_net import SOURCE_FRAME, metadata, random_tensors, read_shadow_net
from viewer.renderer import Renderer

ARCH = {**pc.PARITY_ARCHITECTURE, "env_visibility": False, "demodulate": False}


def test_the_estimator_without_s_of_x_ignores_it_in_gl_and_torch(programs, tmp_path):
    tensors = random_tensors(ARCH, seed=7, scale=0.8)
    path = tmp_path / "no_sx.safetensors"
    save_file(tensors, str(path), metadata=metadata(ARCH, tensors, {"test": True}))
    net = read_shadow_net(path)
    frame = [layer for layer in net.layers if SOURCE_FRAME in (layer.a_source, layer.b_source)]
    assert [layer.name for layer in frame] == ["down1", "out"]
    assert not any(layer.env_vis for layer in frame)
    assert not needs_env_visibility(pc._scene(path).render)
    assert needs_env_visibility(pc._scene(pc.parity_weights(tmp_path)).render)
    renderer = Renderer(ctx=programs.ctx)
    try:
        plain = renderer.draw(pc._scene(None))
        radiance, inputs, surface, ssao = pc.frame_inputs(renderer, pc._scene(None), plain)
        assert ssao[..., 1].min() < 0.5  # the frame's S(x) is not 1: the check can fail
        _, vis_gl = pc.run_gl_layers(programs, net, plain, ssao)
        other = ssao.copy()
        other[..., 1] = 0.1
        _, vis_other = pc.run_gl_layers(programs, net, plain, other)
    finally:
        renderer.release()
    np.testing.assert_array_equal(vis_gl, vis_other)  # GL never reads S(x)
    layers = [layer.as_dict() for layer in net.layers]
    reading = [d | {"env_vis": True} for d in layers]  # the same weights, reading S(x)
    with torch.no_grad():
        vis = shadow_net(inputs, layers, pc.params_of(net))[0].permute(1, 2, 0).numpy()
        vis_sx = shadow_net(inputs, reading, pc.params_of(net))[0].permute(1, 2, 0).numpy()
    np.testing.assert_allclose(vis_gl[..., :3], vis, atol=pc.NET_ATOL, rtol=pc.NET_RTOL)
    assert np.abs(vis_sx - vis).max() > 100 * pc.NET_ATOL  # reading S(x) would differ


def test_the_torch_model_holds_s_of_x_at_one():
    """The trained model (what training fits) gives the same V for any S(x)."""
    model = ShadowNet(ARCH)
    tensors = random_tensors(ARCH, seed=3, scale=0.8)
    with torch.no_grad():
        for name in model.weights:
            model.weights[name].copy_(torch.from_numpy(tensors[f"{name}.weight"]))
            model.biases[name].copy_(torch.from_numpy(tensors[f"{name}.bias"]))
        args = [torch.rand(1, c, 24, 32) for c in (3, 1, 3, 1)]
        v0 = model.visibility(*args, torch.zeros(1, 1, 24, 32))
        v1 = model.visibility(*args, torch.ones(1, 1, 24, 32))
        sx = ShadowNet({k: v for k, v in ARCH.items() if k != "env_visibility"})
        sx.load_state_dict(model.state_dict())
        assert torch.equal(v0, v1)
        assert (sx.visibility(*args, torch.zeros(1, 1, 24, 32)) - v1).abs().max() > 1e-4
