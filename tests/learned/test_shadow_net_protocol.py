"""The bound of the shadow estimator's form (learned/protocol/shadow_net.py oracle_scores): the
best factor per pixel, capped at the gain and blurred, times the frame."""
from types import SimpleNamespace

import torch

from learned.protocol.shadow_net import oracle_scores


def _pair(factor: torch.Tensor):
    """An estimator image (GL row order) and a protocol image whose target is the frame times
    ``factor`` ``[H, W, 3]`` (top row first)."""
    g = torch.Generator().manual_seed(0)
    frame = torch.rand(8, 10, 3, generator=g) + 0.2  # top row first
    fg = torch.ones(8, 10, dtype=torch.bool)
    fg[:, :2] = False
    target = frame * factor
    radiance = torch.cat([frame, torch.ones(8, 10, 1)], -1).flip(0).permute(2, 0, 1)[None]
    est = SimpleNamespace(name="a", radiance=radiance)
    prot = SimpleNamespace(name="a", fg=fg, target=target[fg],
                           target_image=target.permute(2, 0, 1))
    return [est], [prot]


def test_the_oracle_reaches_a_factor_it_can_hold_and_is_capped_by_the_gain():
    half = oracle_scores(*_pair(torch.full((8, 10, 3), 0.5)))
    assert all(v[0] > 60.0 for v in half.values()), half  # a constant V = 0.5: exact
    double = oracle_scores(*_pair(torch.full((8, 10, 3), 2.0)))
    assert double["g2 s0"][0] > 60.0 and double["g2 s2"][0] > 60.0
    assert double["g1 s0"][0] < 30.0  # V <= 1 cannot brighten: the frame's own error
    ramp = torch.linspace(0.2, 1.0, 10).view(1, 10, 1).expand(8, 10, 3)
    sharp = oracle_scores(*_pair(ramp))
    assert sharp["g1 s0"][0] > 60.0 and sharp["g1 s4"][0] < sharp["g1 s1"][0] < 60.0


def test_averaged_visibility_is_the_geometric_mean_of_the_files():
    """``--average``'s ensemble: one file's V is its own; two files' the geometric mean, between
    them per pixel; fewer than two files is a usage error."""
    import pytest

    from learned.neural.shadow_net import ShadowNet
    from learned.protocol.shadow_net import averaged_visibility, main
    from learned.twins.shadow_net import shadow_net

    g = torch.Generator().manual_seed(2)
    img = SimpleNamespace(inputs=torch.rand(1, 9, 12, 16, generator=g))
    models = []
    for seed in (0, 1):
        torch.manual_seed(seed)
        m = ShadowNet({"levels": 2, "widths": [4, 4], "gain": 3.0})
        with torch.no_grad():
            m.biases["out"].add_(torch.randn(3) * 0.5)  # two clearly different estimators
        models.append(m)
    with torch.no_grad():
        a, b = (shadow_net(img.inputs, m.layers, m.params()) for m in models)
        assert torch.allclose(averaged_visibility([a]), a, rtol=1e-5)
        both = averaged_visibility([a, b])
    assert torch.allclose(both, torch.sqrt(a * b), rtol=1e-5)
    assert not torch.allclose(a, b, rtol=1e-2)
    assert bool(((both >= torch.minimum(a, b) - 1e-6) & (both <= torch.maximum(a, b) + 1e-6))
                .all())
    with pytest.raises(SystemExit):
        main(["data", "w.safetensors", "--average"])
