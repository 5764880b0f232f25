"""The neural shadow estimator (viewer/neural/shadow_net.py, passes/shadow_net_conv.comp,
learned/neural/shadow_net.py): GL against the torch twins per layer and for the whole network
(and that a wrong packing fails them), its receptive field, the weights file's one-line errors,
and its specialisation in the frame graph (no pass, no target without the setting)."""
import json

import numpy as np
import pytest
import torch
from safetensors.numpy import save_file

from learned.neural.shadow_net import ShadowNet, load_shadow_net, save_shadow_net
from learned.parity.checks import shadow_net as check_module
from viewer.neural import WeightsError
from viewer.neural import shadow_net as fmt
from viewer.neural.shadow_net import (
    DEFAULT_ARCHITECTURE,
    metadata,
    plan,
    random_tensors,
    read_shadow_net,
    receptive_field,
)


def test_every_layer_and_the_whole_network_match_the_twins(programs):
    layers = check_module.checks()["shadow_net:layers"][1](programs)
    assert [r.name for r in layers] == [f"shadow_net:{layer.name}"
                                        for layer in plan(DEFAULT_ARCHITECTURE)]
    assert all(r.passed for r in layers), [r for r in layers if not r.passed]
    network = check_module.checks()["shadow_net"][1](programs)
    assert [r.name for r in network] == ["shadow_net:network", "shadow_net:frame"]
    assert all(r.passed for r in network), network


def test_a_wrong_weight_layout_fails_the_layer_checks(programs, monkeypatch):
    """Packing the taps of every layer mirrored left-right (a plausible layout bug): the 3 x 3
    and 2 x 2 layers fail, the 1 x 1 ones (one tap) still pass."""
    pack = fmt.pack_layer

    def mirrored(layer, weight, bias):
        return pack(layer, np.ascontiguousarray(weight[..., ::-1]), bias)

    monkeypatch.setattr(fmt, "pack_layer", mirrored)
    results = check_module.checks()["shadow_net:layers"][1](programs)
    failed = {r.name.split(":")[1] for r in results if not r.passed}
    assert failed == {layer.name for layer in plan(DEFAULT_ARCHITECTURE) if layer.kernel > 1}


def test_the_receptive_field_covers_a_100_px_penumbra():
    """One output pixel's gradient reaches the inputs over the field :func:`receptive_field`
    states (220 px for 5 levels), and more than 100 px across; 2 levels reach far less."""
    assert receptive_field(DEFAULT_ARCHITECTURE) == 220
    assert receptive_field({"levels": 2, "widths": [8, 8]}) < 40
    torch.manual_seed(0)
    model = ShadowNet()
    with torch.no_grad():
        model.weights["out"].normal_(0.0, 0.5)
    n = 288
    x = [torch.rand(1, c, n, n, requires_grad=True) for c in (3, 1, 3, 1, 1)]
    model.visibility(*x)[0, :, n // 2, n // 2].sum().backward()
    reach = sum(t.grad.abs().sum(dim=(0, 1)) for t in x) > 0
    cols = torch.nonzero(reach.any(0))[:, 0]
    rows = torch.nonzero(reach.any(1))[:, 0]
    width = int(cols.max() - cols.min() + 1)
    height = int(rows.max() - rows.min() + 1)
    assert 100 < min(width, height) and max(width, height) <= 220, (width, height)


def test_a_gain_scales_the_output_and_starts_at_no_change():
    """``"gain": g``: V = g sigmoid, in (0, g), starting near V = 1 (bias -log(g - 1)); the
    same weights without the gain give V / g."""
    torch.manual_seed(0)
    arch = {"levels": 2, "widths": [4, 4], "gain": 2.0}
    model = ShadowNet(arch)
    x = [torch.rand(1, c, 16, 16) for c in (3, 1, 3, 1, 1)]
    with torch.no_grad():
        v = model.visibility(*x)
        assert 0.98 < float(v.min()) and float(v.max()) < 1.02  # weights 0.01, bias -log 1
        model.weights["out"].normal_(0.0, 3.0)
        v = model.visibility(*x)
        plain = ShadowNet({"levels": 2, "widths": [4, 4]})
        plain.load_state_dict(model.state_dict())
        assert float(v.max()) > 1.2 and float(v.max()) < 2.0
        assert torch.allclose(plain.visibility(*x), v / 2.0, atol=1e-6)


def _ramp_visibility(arch: dict, seed: int) -> torch.Tensor:
    """V of a seeded random estimator of ``arch`` on a smooth 96 x 96 frame (ramps)."""
    torch.manual_seed(seed)
    model = ShadowNet(arch)
    with torch.no_grad():
        model.weights["out"].normal_(0.0, 0.5)
    y, x = torch.meshgrid(torch.linspace(0, 1, 96), torch.linspace(0, 1, 96), indexing="ij")
    ramp = (0.3 + 0.5 * x + 0.2 * y)[None, None]
    normal = torch.stack([x - 0.5, y - 0.5, torch.ones_like(x)])[None]
    with torch.no_grad():
        return model.visibility(ramp.repeat(1, 3, 1, 1), ramp, normal / normal.norm(dim=1),
                                2 + 2 * ramp, torch.ones_like(ramp))


def test_a_bilinear_last_decoder_draws_no_blocks():
    """``"upsample": "bilinear"``: the 1 x 1 decoder at half resolution reads the level below
    bilinear-upsampled (the other decoders stay nearest), so on a smooth frame V's steps at the
    coarse levels' block edges go: its mean second difference is under 0.6 x the nearest
    decoder's for the same weights (measured 0.32-0.50 x over three seeds), and its reach is no
    smaller."""
    from viewer.neural.shadow_net import SOURCE_BILINEAR_UP, SOURCE_NEAREST_UP

    smooth = {**DEFAULT_ARCHITECTURE, "upsample": "bilinear"}
    sources = {layer.name: layer.a_source for layer in plan(smooth)}
    assert sources["dec1"] == SOURCE_BILINEAR_UP
    assert {sources[f"dec{lv}"] for lv in (2, 3, 4)} == {SOURCE_NEAREST_UP}
    assert receptive_field(smooth) >= receptive_field(DEFAULT_ARCHITECTURE)
    for seed in range(3):
        v = {a: _ramp_visibility(arch, seed) for a, arch in (("nearest", DEFAULT_ARCHITECTURE),
                                                              ("bilinear", smooth))}
        d2 = {a: float((x[..., 2:] - 2 * x[..., 1:-1] + x[..., :-2]).abs().mean())
              for a, x in v.items()}
        assert d2["bilinear"] < 0.6 * d2["nearest"], (seed, d2)


def test_saved_weights_load_back_in_torch_and_in_the_viewer(tmp_path):
    torch.manual_seed(2)
    model = ShadowNet()
    path = save_shadow_net(model, tmp_path / "s.safetensors", {"note": "test"})
    net = read_shadow_net(path)
    assert net.training == {"note": "test"} and net.architecture == DEFAULT_ARCHITECTURE
    again = load_shadow_net(path)
    for name in model.weights:
        assert torch.equal(again.weights[name], model.weights[name])
    # an untrained estimator starts near "no shadow": sigmoid(3) = 0.953, give or take its small
    # output weights
    x = [torch.rand(1, c, 20, 24) for c in (3, 1, 3, 1, 1)]
    with torch.no_grad():
        v = model.visibility(*x)
    assert float(v.min()) > 0.9 and float(v.max()) < 0.99 and abs(float(v.mean()) - 0.953) < 0.02


def _write(path, tensors, meta):
    save_file(tensors, str(path), metadata=meta)
    return path


@pytest.mark.parametrize("damage, message", [
    ("missing", "cannot read|not a readable"),
    ("format", "not a relight shadow-estimator file"),
    ("version", "format version '9' is not supported"),
    ("architecture", "bad architecture metadata"),
    ("gain", "bad architecture metadata .*gain 9.0 is not a number in 1.0..4.0"),
    ("upsample", "bad architecture metadata .*upsample 'cubic' is not one of nearest, bilinear"),
    ("shape", "tensor 'enc2.weight' is float32\\[12, 12, 3, 1\\], expected float32\\[12, 12, 3, 3\\]"),
    ("nan", "tensor 'dec3.bias' has NaN/Inf values"),
    ("missing_tensor", "missing tensor 'out.bias'"),
    ("hash", "checkpoint hash mismatch"),
])
def test_a_bad_weights_file_is_one_line_naming_it(tmp_path, damage, message):
    import re

    tensors = random_tensors(DEFAULT_ARCHITECTURE, seed=1)
    meta = metadata(DEFAULT_ARCHITECTURE, tensors)
    path = tmp_path / f"{damage}.safetensors"
    if damage == "format":
        meta["format"] = "relight-neural-shader"
    elif damage == "version":
        meta["version"] = "9"
    elif damage == "architecture":
        meta["architecture"] = json.dumps({"levels": 5, "widths": [8, 8]})
    elif damage == "gain":
        meta["architecture"] = json.dumps({**DEFAULT_ARCHITECTURE, "gain": 9.0})
    elif damage == "upsample":
        meta["architecture"] = json.dumps({**DEFAULT_ARCHITECTURE, "upsample": "cubic"})
    elif damage == "shape":
        tensors["enc2.weight"] = tensors["enc2.weight"][..., :1].copy()
        meta = metadata(DEFAULT_ARCHITECTURE, tensors)
    elif damage == "nan":
        tensors["dec3.bias"][1] = np.nan
        meta = metadata(DEFAULT_ARCHITECTURE, tensors)
    elif damage == "missing_tensor":
        del tensors["out.bias"]
        meta = metadata(DEFAULT_ARCHITECTURE, tensors)
    elif damage == "hash":
        meta = metadata(DEFAULT_ARCHITECTURE, tensors)
        tensors["enc1.bias"] = tensors["enc1.bias"] + 1.0
    if damage != "missing":
        _write(path, tensors, meta)
    with pytest.raises(WeightsError) as info:
        fmt.load_shadow_net(path)
    text = str(info.value)
    assert "\n" not in text and str(path.name) in text and re.search(message, text), text


def test_the_pass_runs_only_with_the_setting(tmp_path):
    """Specialised like every pass: without ``shadow_net`` the frame has no such pass and no
    feature map; with it, one pass writing the radiance and its transient maps, and SSAO runs
    even where the scene turned it off (the estimator reads its occlusion)."""
    from viewer.renderer import Renderer
    from viewer.scene.description import scene_from_dict

    path = check_module.parity_weights(tmp_path)
    doc = {**check_module.PARITY_SCENE, "camera": {**check_module.PARITY_SCENE["camera"],
                                                   "size": [32, 24]}}
    scene = scene_from_dict(doc).with_render(model="ggx_split_sum", ssao=False)
    renderer = Renderer()
    try:
        plain = renderer.graph(scene)
        assert not any(p.name.startswith("shadow_net") or p.name.startswith("ssao")
                       for p in plain.passes)
        assert not any(r.startswith("shadow_net/") for r in plain.resources)
        with_net = renderer.graph(scene.with_render(shadow_net=str(path)))
        names = [p.name for p in with_net.passes]
        layers = [f"shadow_net:{layer.name}" for layer in plan(DEFAULT_ARCHITECTURE)[:-1]]
        start = names.index("shade") + 1
        assert "ssao" in names and names[start:start + len(layers) + 1] == layers + ["shadow_net"]
        maps = sorted(r for r in with_net.resources if r.startswith("shadow_net/"))
        assert len(maps) == len(layers)
        assert not any(with_net.resources[m].kept for m in maps)
    finally:
        renderer.release()


def test_an_unchanged_frame_reuses_the_estimator_and_the_lighting(tmp_path):
    """Drawn once, an exposure change redraws tone mapping only: the estimator's layers write
    transient maps, which the graph skips when the product they lead to is reused (one pass
    writing maps and the radiance would redraw the lighting every frame)."""
    from viewer.renderer import Renderer
    from viewer.scene.description import scene_from_dict

    path = check_module.parity_weights(tmp_path)
    doc = {**check_module.PARITY_SCENE, "camera": {**check_module.PARITY_SCENE["camera"],
                                                   "size": [32, 24]}}
    scene = scene_from_dict(doc).with_render(model="ggx_split_sum", shadow_net=str(path))
    renderer = Renderer()
    try:
        renderer.draw(scene)
        status = {p["name"]: p["status"] for p in
                  renderer.graph(scene.with_render(exposure=1.0)).describe()["passes"]}
    finally:
        renderer.release()
    drawn = sorted(name for name, st in status.items() if st != "reused")
    assert "shadow_net" in status and drawn == ["fxaa", "tonemap"], status
