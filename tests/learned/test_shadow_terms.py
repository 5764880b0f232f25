"""The shadow estimator's optional loss terms (learned/train/shadow_terms.py): what each sees
that the protocol's Reinhard-mapped metric does not, and how the loss adds them."""
import numpy as np
import torch

from learned.neural.shadow_net import ShadowNet
from learned.train.shadow_net import ShadowNetImage, loss, visibility
from learned.train.shadow_terms import energy_term, linear_term, prior_term


def test_the_highlight_terms_see_what_the_reinhard_metric_misses():
    """``energy_term`` and ``linear_term`` are zero (resp. minimal) for the target itself, see a
    glint dimmed to 40 % (what the gallery's lone spheres showed) far more than the Reinhard
    metric does, and ignore the empty image."""
    g = torch.Generator().manual_seed(1)
    target = torch.rand(2, 3, 16, 16, generator=g) * 0.5
    target[:, :, 4:6, 4:6] = 50.0  # a sun's glint: 4 px of 256
    mask = torch.ones(2, 3, 16, 16, dtype=torch.bool)
    mask[1] = False
    dimmed = target.clone()
    dimmed[:, :, 4:6, 4:6] *= 0.4
    assert energy_term(target, target, mask, target)[0] == 0.0
    # the image's energy falls to dimmed / target; its top 2 % (5 px: the glint's 4 and one
    # ~0.5 px beside them) to about 0.4
    whole = float(torch.log(dimmed[0].sum() / target[0].sum()) ** 2)
    assert whole > 0.3  # the glint carries three quarters of the energy
    assert 0.75 < float(energy_term(dimmed, target, mask, target)[0]) - whole < np.log(0.4) ** 2
    rein = lambda x: x / (1 + x)
    reinhard = float(((rein(dimmed[0]) - rein(target[0])) ** 2).mean())
    assert reinhard < 1e-3  # the metric's loss barely moves...
    assert float(linear_term(dimmed, target, mask)[0]) > np.log(0.3)  # ...the linear one does
    assert float(linear_term(target, target, mask)[0]) < -15  # log(0 + 1e-8)
    assert energy_term(dimmed, target, mask, target)[1] == 0.0  # no surface: no term
    # the truth against a noisy estimate of it (12 % per pixel, as the 64-spp targets): the
    # highlights picked in the noise-free frame ask for no change; picked in the target they
    # would ask for more light (its brightest pixels are those whose noise came out high)
    truth = 1 + 0.1 * torch.rand(1, 3, 64, 64, generator=g)  # a lit wall, a glint in every pixel
    noisy = truth * (1 + 0.12 * torch.randn(1, 3, 64, 64, generator=g))
    whole = torch.ones(1, 3, 64, 64, dtype=torch.bool)
    unbiased, biased = (float(energy_term(truth, noisy, whole, f)[0]) for f in (truth, noisy))
    assert unbiased < 2e-3 and biased > max(5e-3, 10 * unbiased), (unbiased, biased)


def test_the_prior_term_is_the_surface_mean_of_abs_log_v_and_pulls_v_to_one():
    """``prior_term``: 0 where V = 1, |log V| averaged over the surface only (either direction
    alike), 0 without a surface; and in ``loss`` it adds its weight times that to each image's
    log MSE, so a network's gradient under it pulls V towards 1."""
    mask = torch.zeros(2, 1, 4, 4, dtype=torch.bool)
    mask[0, :, :2] = True  # 8 surface pixels in image 0, none in image 1
    v = torch.ones(2, 3, 4, 4)
    assert torch.equal(prior_term(v, mask), torch.zeros(2))
    v[0, :, 0] = 2.0   # 4 of the 8 surface pixels at 2, every colour
    v[0, :, 1] = 0.5   # the other 4 at 1/2: the same |log V|
    v[0, :, 3] = 9.0   # off the surface: not counted
    assert torch.allclose(prior_term(v, mask), torch.tensor([np.log(2.0), 0.0]).float(), atol=1e-6)
    # in the loss: its weight times the term of the network's own V, added per image
    g = torch.Generator().manual_seed(3)
    torch.manual_seed(3)
    model = ShadowNet({"levels": 2, "widths": [4, 4], "gain": 3.0})
    img = ShadowNetImage("a", torch.rand(1, 4, 12, 16, generator=g) + 0.1,
                         torch.rand(1, 9, 12, 16, generator=g),
                         torch.rand(1, 1, 12, 16, generator=g) > 0.3,
                         torch.rand(1, 3, 12, 16, generator=g), torch.rand(1, 3, 12, 16,
                                                                           generator=g))
    with torch.no_grad():
        vis = visibility(model, img)
        plain = float(loss(model, [img], kind="log_mse"))
        pulled = float(loss(model, [img], kind="log_mse", prior=0.5))
    assert abs(pulled - plain - 0.5 * float(prior_term(vis, img.surface)[0])) < 1e-5
    assert pulled > plain  # a fresh network's V is not 1 everywhere
