"""The shadow estimator's optional loss terms (:func:`learned.train.shadow_net.loss`, each with
its weight in ``ShadowNetTrainConfig``), per image ``[N]``, all off by default: none moved the
validation scores beyond the seeds' spread (docs/measurements/students.md). Kept, tested, so
each documented experiment is a ``relight train`` option."""
from __future__ import annotations

import torch


def linear_term(pred: torch.Tensor, goal: torch.Tensor, mask: torch.Tensor) -> torch.Tensor:
    """Per image ``[N]``: log of the linear MSE over the surface relative to the target's mean
    square - the error the Reinhard-mapped metric all but ignores in highlights (a sun's glint at
    50 maps to 0.98, dimmed to 20 to 0.95), which a linear display of the frame shows."""
    n = mask.sum((1, 2, 3)).clamp_min(1)
    err = ((pred - goal) ** 2 * mask).sum((1, 2, 3)) / n
    return torch.log(err / ((goal ** 2 * mask).sum((1, 2, 3)) / n + 1e-8) + 1e-8)


TOP_FRACTION = 0.02  # energy_term's highlights: the image's brightest 2 % of surface pixels


def energy_term(pred: torch.Tensor, goal: torch.Tensor, mask: torch.Tensor,
                frame: torch.Tensor) -> torch.Tensor:
    """Per image ``[N]``: the squared log ratio of the product's energy to the target's over the
    surface, plus the same over the :data:`TOP_FRACTION` of surface pixels brightest in the
    unshadowed ``frame`` (its highlights), so that the estimator neither dims nor brightens an
    image, nor its glints, as a whole where it moves light between pixels. The highlights are
    picked in the frame, not the target: the target's brightest pixels are those whose Monte-Carlo
    noise came out high, and their sum would ask for more light than the truth has."""
    out = []
    for p, g, f, m in zip(pred, goal, frame, mask[:, 0].bool()):
        ps, gs = p[:, m], g[:, m]  # [3, K]
        if gs.shape[1] == 0:
            out.append(p.sum() * 0.0)
            continue
        lum = f[:3, m].sum(0)
        k = max(int(TOP_FRACTION * lum.numel()), 1)
        hi = lum >= lum.topk(k).values[-1]
        ratio = lambda a, b: torch.log((a.sum() + 1e-6) / (b.sum() + 1e-6)) ** 2
        out.append(ratio(ps, gs) + ratio(ps[:, hi], gs[:, hi]))
    return torch.stack(out)


def prior_term(visibility: torch.Tensor, mask: torch.Tensor) -> torch.Tensor:
    """Per image ``[N]``: the mean of |log V| over the surface (``visibility`` ``[N, 3, H, W]``,
    ``mask`` ``[N, 1, H, W]``), a prior towards V = 1 - correct the frame only where the
    evidence asks, and leave an unfamiliar asset alone (``relight train --shadow-prior W``)."""
    m = mask.expand_as(visibility).float()
    lv = torch.log(visibility.clamp_min(1e-4)).abs()
    return (lv * m).sum((1, 2, 3)) / m.sum((1, 2, 3)).clamp_min(1)
