"""Training the viewer's neural shadow estimator (:class:`learned.neural.shadow_net.ShadowNet`)
against a dataset's own targets - path-traced truth for a traced dataset (``relight data
--protocol`` or ``--targets reference``).

Its inputs are what the frame gives it: each sample's G-buffer drawn by the viewer with ``model``
(``ggx_split_sum`` by default) and SSAO, exactly as a frame with ``[render] shadow_net`` is drawn
before the estimator's pass (:func:`shadow_net_images`: the radiance, SSAO's occlusion O(x) and
visibility of the environment's light S(x), normals and depth read back from GL).

The loss (``loss``): ``log_mse`` (the default) is the mean over the images of log(MSE) of the
Reinhard-mapped product (radiance x V on the surfaces) against the target - the protocol's
metric itself, so a well-lit image counts as much as a badly lit one; ``l2`` / ``l1`` are the
squared / absolute difference of log(1 + x) over all the batch's surface pixels, which leaves
the images the frame already renders well to the few badly lit ones. With ``visibility_target``
the target is clamped to g x the unshadowed radiance per colour (g the network's gain): what
the product can reach. ``augment`` (default 0.2) shows every training image under another
light - radiance and target times one random factor per colour (exposure and tint), the
radiance input recomputed, mirrored left-right half of the time - so that the network learns
corrections of the frame's shading rather than its training environments' colours. The design
(gain 3, ``log_mse``, augment 0.2, batch 8, 1000 steps) was chosen on the protocol's validation
split (docs/measurements/students.md): with a visibility alone (g = 1) and ``l2`` the estimator
fitted its training environments and gained +0.15 dB on validation. With the old ``l1``: over
half of the surface pixels' best visibility is 1, and L1's median saturated the sigmoid there.
The metric maps x to x / (1 + x), which all but ignores the highlights: an estimator trained on it
alone dimmed the sun's glint on the bundled lone spheres by up to 61 % of their energy and darkened
its validation images by 8-10 % in linear energy. ``energy_weight`` adds per image the squared log
ratio of the product's energy to the target's, over the surface and over the frame's brightest 2 %
(:func:`energy_term`); ``linear_weight`` the log of the linear MSE relative to the target's mean
square (:func:`linear_term`). Neither is on by default: on the validation sets (two seeds, meshes;
docs/measurements/students.md) they changed the Reinhard PSNR by -0.3 to +0.3 dB, within the seeds'
spread, and the validation images' highlights, picked in the frame, were within 9 % of their energy
without them, so the validation sets do not show the glint dimming these terms were made for.
``prior_weight`` adds the mean |log V| over the surface (:func:`prior_term`), a prior towards V = 1
for assets unlike the training scenes: off, a wash on validation over three seeds (ibid.). A
batch of ``batch`` images per step
(Adam, cosine rate, :func:`learned.train.runner._loop`: progress bar, log lines, checkpoints every
``checkpoint_every`` steps into ``OUT/shadow_net.pt``, resumed from). Selection reads the
validation split only: the final weights' validation score (PSNR of the product, and of the
unshadowed render, over the surfaces) goes into the file's ``training`` metadata with the
command, the seed and the training data's hash.

More data (issue 38): ``extra_data``, datasets whose train splits join the training images
(``relight data --preset shadow-extra``: environments no val or test sample has);
``degrade_levels``, ``data``'s train split again at each of these G-buffer degradation levels
(in (0, 1]; :func:`learned.protocol.degrade.degraded_dataset`, written once under
``DATA/_degraded/<level>/train``, resumable), the degraded images joining the training set, so
that the estimator sees the estimated G-buffers the protocol scores it on too (drawn from their
stacks; with ``geometry = "mesh"`` the degraded stack with the true meshes as shadow casters
only, :func:`learned.data.scene.sample_mesh_scene`). ``None`` (the default):
:data:`DEFAULT_DEGRADE_LEVELS` for stacks, none for meshes. Only ``data``'s: with
``extra_data`` degraded too (two thirds of the images degraded) the estimator scored 0.4-0.8 dB
less on clean validation images and at degradation 0.5 alike (docs/measurements/students.md);
``val_data``, datasets whose val split is scored after training like ``data``'s own
(``--preset shadow-val``: a second validation set for design choices), per dataset in the
summary's and the metadata's ``val_data``. The metadata records the hashes of the extra and the
degraded training data (``extra_data_hashes``; ``degraded_data_hashes``, dataset by dataset,
level by level) and of every ``val_data`` set.
"""
from __future__ import annotations

import json
import sys
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path

import numpy as np
import torch

from viewer.renderer import Renderer

from ..data.reader import DatasetError, list_samples, load_sample
from ..data.scene import geometry_scene
from ..evaluate import metrics
from ..neural.shadow_net import ShadowNet, save_shadow_net
from ..parity.checks.models import gl_gbuffer
from ..parity.checks.shadow_net import frame_inputs
from ..protocol.data import dataset_hash
from ..protocol.degrade import degraded_dataset
from ..twins.shadow_net import (shadow_net, shadow_net_apply, shadow_net_demodulate,
                                shadow_net_input_a)
from .decals import decal
from .shadow_terms import energy_term, linear_term, prior_term
from .runner import Run, _loop

STAGE = "shadow_net"
SHIPPED_ARCHITECTURE = {"levels": 5, "widths": [8, 12, 16, 24, 32], "gain": 3.0}
DEFAULT_DEGRADE_LEVELS = (0.25, 0.75)  # chosen on validation (module doc)


@dataclass
class ShadowNetTrainConfig:
    data: str
    out: str
    steps: int = 1000
    lr: float = 1e-3
    batch: int = 8
    seed: int = 0
    model: str = "ggx_split_sum"  # the model whose frames the estimator multiplies
    # the shipped design: 5 levels, gain 3; without "env_visibility" the geometry's default
    # (:func:`architecture`)
    architecture: dict = field(default_factory=lambda: dict(SHIPPED_ARCHITECTURE))
    limit: int | None = None  # samples per split (None: all)
    # more datasets whose train splits join the training images (environments that no val or
    # test sample has; their val and test splits, if any, are not read)
    extra_data: tuple[str, ...] = ()
    visibility_target: bool = False  # min(target, g x unshadowed radiance) (module doc)
    loss: str = "log_mse"  # "log_mse" (the metric) | "l2" | "l1" on log(1 + x) (module doc)
    augment: float = 0.2  # > 0: exposure, tint (this log-normal sigma) and mirror (module doc)
    decals: float = 0.0  # the share of training images with a painted-on pattern (.decals)
    # log_mse's terms that keep the image's energy and its highlights', and the linear image
    # (loss, module doc; both off: neither moved the validation scores)
    energy_weight: float = 0.0
    linear_weight: float = 0.0
    prior_weight: float = 0.0  # x mean |log V| (shadow_terms.prior_term; tried, not shipped)
    # the frames drawn from each sample's image-space stack or its meshes (learned.data.scene)
    geometry: str = "stack"
    # the frame the estimator multiplies has the screen-space one-bounce indirect light (module
    # doc); recorded in the weights' training metadata ("frame"), read by the protocol's scoring
    # and checked by the viewer (viewer.graph.shadow_net)
    indirect: bool = True
    # the frame's specular occlusion ([render] specular_occlusion, the viewer's default since
    # 2026-11-29; recorded beside indirect): the shipped files' frames since then (the files
    # before had none: --no-shadow-specular-occlusion)
    specular_occlusion: bool = True
    # data's train split again at each of these degradation levels (in (0, 1];
    # learned.protocol.degrade, written once under DATA/_degraded/<level>/train); None: the
    # geometry's default (levels): DEFAULT_DEGRADE_LEVELS for stacks, () for meshes
    degrade_levels: tuple[float, ...] | None = None
    # more datasets whose val split is scored after training, as data's own (module doc)
    val_data: tuple[str, ...] = ()
    log_every: int = 50
    checkpoint_every: int = 200


@dataclass
class ShadowNetImage:
    """One sample as the estimator sees it, ``[1, C, H, W]`` in GL row order."""

    name: str
    radiance: torch.Tensor  # [1, 4, H, W] the unshadowed frame (alpha: coverage)
    inputs: torch.Tensor    # [1, 9, H, W] learned.twins.shadow_net.shadow_net_inputs
    surface: torch.Tensor   # [1, 1, H, W] bool
    target: torch.Tensor    # [1, 3, H, W] the dataset's target (truth for traced data)
    albedo: torch.Tensor    # [1, 3, H, W] the G-buffer's base colour (a demodulating estimator's)


FIELDS = ("radiance", "inputs", "surface", "target", "albedo")  # the tensors, in order


def shadow_net_image(renderer, sample, model: str = "ggx_split_sum", geometry: str = "stack",
                     indirect: bool = False, specular_occlusion: bool = False
                     ) -> ShadowNetImage:
    """One sample drawn by ``renderer`` with ``model`` and SSAO (no estimator), with the
    screen-space one-bounce indirect light if ``indirect`` (the frame the estimator multiplies:
    :func:`viewer.neural.shadow_net.frame_settings`) and specular occlusion if
    ``specular_occlusion``, from its image-space stack or (``geometry = "mesh"``) from the
    meshes it was generated from (:func:`learned.data.scene.geometry_scene`)."""
    scene = geometry_scene(sample, geometry, model=model, ssao=True, indirect=indirect,
                           specular_occlusion=specular_occlusion)
    targets = renderer.draw(scene)
    radiance, inputs, surface, _ = frame_inputs(renderer, scene, targets)
    albedo = gl_gbuffer(targets)["albedo"].permute(2, 0, 1)[None].float()
    target = torch.from_numpy(np.ascontiguousarray(sample.target[::-1]))  # GL row order
    return ShadowNetImage(sample.name, radiance, inputs, surface,
                          target.permute(2, 0, 1)[None].float(), albedo)


def shadow_net_images(root: str, split: str, renderer, model: str = "ggx_split_sum",
                      limit: int | None = None, geometry: str = "stack",
                      indirect: bool = False, specular_occlusion: bool = False
                      ) -> list[ShadowNetImage]:
    """:func:`shadow_net_image` of every sample of ``split`` (the first ``limit``)."""
    return [shadow_net_image(renderer, load_sample(folder), model, geometry, indirect,
                             specular_occlusion)
            for folder in list_samples(root, split)[:limit]]


def model_inputs(model: ShadowNet, img: ShadowNetImage) -> torch.Tensor:
    """``img``'s inputs as ``model`` reads them: the stored ones, or with the radiance over the
    base colour for an estimator that :attr:`~learned.neural.shadow_net.ShadowNet.demodulates`
    (``shadow_net_input_a`` of ``shadow_net_demodulate``)."""
    if not model.demodulates:
        return img.inputs
    rgb = shadow_net_demodulate(img.radiance[:, :3].movedim(1, -1), img.albedo.movedim(1, -1))
    a = shadow_net_input_a(rgb, img.inputs[:, 3])  # [B, H, W, 4]: log(1 + L), O(x)
    return torch.cat([a[..., :3].movedim(-1, 1), img.inputs[:, 3:]], 1)


def visibility(model: ShadowNet, img: ShadowNetImage) -> torch.Tensor:
    """``model``'s V ``[1, 3, H, W]`` on ``img``."""
    return shadow_net(model_inputs(model, img), model.layers, model.params())


def shaded(model: ShadowNet, img: ShadowNetImage,
           vis: torch.Tensor | None = None) -> torch.Tensor:
    """The product ``[1, 4, H, W]`` the frame would show with ``model``'s estimator (``vis``:
    its V, when the caller has it already)."""
    vis = visibility(model, img) if vis is None else vis
    return shadow_net_apply(img.radiance, vis, img.surface)


def stack(batch: list[ShadowNetImage]) -> list[ShadowNetImage]:
    """Images of one size stacked into one (one pass of the network for them all)."""
    groups: dict[tuple, list[ShadowNetImage]] = {}
    for img in batch:
        groups.setdefault(tuple(img.target.shape[-2:]), []).append(img)
    return [ShadowNetImage("+".join(i.name for i in g),
                           *(torch.cat([getattr(i, k) for i in g]) for k in FIELDS))
            for g in groups.values()]


def augmented(img: ShadowNetImage, rng: np.random.Generator, tint: float) -> ShadowNetImage:
    """``img`` under another light: the radiance and the target times one random factor per
    colour (exposure e^U(-1, 1) times tint e^N(0, ``tint``)), the radiance input recomputed, and
    mirrored left-right half of the time (the normals' x negated). The best visibility
    target / radiance is unchanged by the factors."""
    k = torch.from_numpy(np.exp(rng.normal(0.0, tint, 3) + rng.uniform(-1.0, 1.0)))
    k = k.float().view(1, 3, 1, 1)
    radiance = torch.cat([img.radiance[:, :3] * k, img.radiance[:, 3:]], 1)
    inputs = img.inputs.clone()
    inputs[:, :3] = torch.log1p(radiance[:, :3].clamp_min(0.0))  # shadow_net_input_a
    target, surface, albedo = img.target * k, img.surface, img.albedo
    if rng.random() < 0.5:
        radiance, inputs, target, surface, albedo = (
            t.flip(-1) for t in (radiance, inputs, target, surface, albedo))
        inputs[:, 4] = -inputs[:, 4]  # the normal's x (camera space, x to the right)
    return ShadowNetImage(img.name, radiance, inputs, surface, target, albedo)


def decaled(img: ShadowNetImage, rng: np.random.Generator) -> ShadowNetImage:
    """``img`` with a pattern of :func:`.decals.decal` painted on its surfaces: the radiance, the
    target and the base colour times the same factor, the radiance input recomputed."""
    f = decal(rng, *img.target.shape[-2:])
    f = torch.where(img.surface, f, torch.ones_like(f))
    radiance = torch.cat([img.radiance[:, :3] * f, img.radiance[:, 3:]], 1)
    inputs = img.inputs.clone()
    inputs[:, :3] = torch.log1p(radiance[:, :3].clamp_min(0.0))  # shadow_net_input_a
    return ShadowNetImage(img.name, radiance, inputs, img.surface, img.target * f,
                          img.albedo * f)


LOSSES = ("l1", "l2", "log_mse")


def loss(model: ShadowNet, batch: list[ShadowNetImage], visibility_target: bool = False,
         kind: str = "l1", linear: float = 0.0, energy: float = 0.0,
         prior: float = 0.0) -> torch.Tensor:
    """``l1`` | ``l2``: the mean difference of log(1 + x) over the surface pixels of ``batch``;
    ``log_mse``: the mean over the images of log(MSE) of the Reinhard-mapped x / (1 + x) over
    each image's surface - the protocol's metric itself (its mean PSNR is -10 / ln 10 times this
    plus a constant), so every image counts as much as it does in the score, however bright.
    ``visibility_target``: against min(target, g x unshadowed radiance), g the network's gain
    (module doc). With ``log_mse``, each image's term adds ``linear`` x :func:`linear_term`,
    ``energy`` x :func:`energy_term` and ``prior`` x :func:`prior_term` (of V itself)."""
    if kind not in LOSSES:
        raise ValueError(f"unknown loss {kind!r} ({' | '.join(LOSSES)})")
    gain = float(model.layers[-1].get("gain", 1.0))
    total, count, logs = 0.0, 0, []
    for img in stack(batch):
        vis = visibility(model, img)  # kept for the prior term
        pred = shaded(model, img, vis)[:, :3]
        goal = torch.minimum(img.target, gain * img.radiance[:, :3]) if visibility_target \
            else img.target
        mask = img.surface.expand_as(pred)
        if kind == "log_mse":
            p, g = pred.clamp_min(0.0), goal.clamp_min(0.0)
            err = (p / (1 + p) - g / (1 + g)) ** 2 * mask
            n = mask.sum((1, 2, 3))
            keep = n > 0
            term = torch.log(err.sum((1, 2, 3)) / n.clamp_min(1) + 1e-8)
            if linear:
                term = term + linear * linear_term(p, g, mask)
            if energy:
                term = term + energy * energy_term(p, g, mask, img.radiance)
            if prior:
                term = term + prior * prior_term(vis, img.surface)
            logs.append(term[keep])
            continue
        diff = torch.log1p(pred.clamp_min(0.0)) - torch.log1p(goal.clamp_min(0.0))
        err = diff.abs() if kind == "l1" else diff * diff
        total = total + err[mask].sum()
        count += int(mask.sum())
    if kind == "log_mse":
        return torch.cat(logs).mean()
    return total / max(count, 1)


@torch.no_grad()
def scores(model: ShadowNet | None, images: list[ShadowNetImage]) -> dict:
    """Mean PSNR (dB, :func:`learned.evaluate.metrics` over the surfaces) of the product, or of
    the unshadowed frame with ``model`` None, and the per-image values."""
    values = []
    for img in images:
        pred = img.radiance if model is None else shaded(model, img)
        hwc = lambda t: t[0, :3].permute(1, 2, 0).numpy()
        values.append(metrics(hwc(pred), hwc(img.target), img.surface[0, 0].numpy())["psnr"])
    return {"psnr": float(np.mean(values)) if values else float("nan"), "per_image": values}


def architecture(cfg: ShadowNetTrainConfig) -> dict:
    """``cfg.architecture``, with ``"env_visibility"`` (whether the estimator reads S(x)) by the
    geometry when it does not say: stacks read it, their only evidence of a cast shadow (on
    validation -0.8 dB without it); meshes and splats do not, their frames carry the shadow
    maps' (on validation a wash without it, and on real assets 1.5 % of the pixels darkened
    where the truth is not, against 4.9 % with it; docs/measurements/students.md)."""
    return {"env_visibility": cfg.geometry == "stack"} | dict(cfg.architecture)


def levels(cfg: ShadowNetTrainConfig) -> tuple[float, ...]:
    """The degradation levels a run uses: ``cfg.degrade_levels``, or its geometry's default."""
    if cfg.degrade_levels is not None:
        return tuple(float(lv) for lv in cfg.degrade_levels)
    return DEFAULT_DEGRADE_LEVELS if cfg.geometry == "stack" else ()


def train_shadow_net(cfg: ShadowNetTrainConfig, quiet: bool = False) -> dict:
    """Train on ``cfg.data``'s train split (with its degraded copies and ``extra_data``'s),
    score on its val split and ``val_data``'s, write ``OUT/shadow_net.safetensors``; returns a
    summary."""
    cfg = replace(cfg, degrade_levels=levels(cfg))
    bad = [lv for lv in cfg.degrade_levels if not 0.0 < float(lv) <= 1.0]
    if bad:
        raise ValueError(f"degrade_levels: {bad[0]!r} is not in (0, 1]")
    for d in cfg.val_data:
        if not (Path(d) / "val").is_dir():
            raise DatasetError("no 'val' split folder to score (val_data)", where=d)
    run = Run(cfg, 0, quiet)
    run.log(f"config {json.dumps(asdict(cfg))}")
    roots = (cfg.data, *cfg.extra_data)
    degraded = tuple(str(degraded_dataset(cfg.data, lv, ("train",), progress=not quiet))
                     for lv in cfg.degrade_levels)
    renderer = Renderer()
    images = lambda root, split: shadow_net_images(root, split, renderer, cfg.model, cfg.limit,
                                                   cfg.geometry, cfg.indirect,
                                                   cfg.specular_occlusion)
    try:
        train = [img for root in (*roots, *degraded) for img in images(root, "train")]
        val = images(cfg.data, "val") if (Path(cfg.data) / "val").is_dir() else []
        more_val = {d: images(d, "val") for d in cfg.val_data}
    finally:
        renderer.release()
    if not train:
        raise ValueError(f"{cfg.data}: no training samples")
    run.log(f"{len(train)} training images ({len(degraded)} degraded sets), {len(val)} "
            f"validation images" + "".join(f", {len(v)} of {d}" for d, v in more_val.items()))
    torch.manual_seed(cfg.seed)
    model = ShadowNet(architecture(cfg))
    rng = np.random.default_rng([cfg.seed, 38])

    def step(m, _):
        pick = rng.choice(len(train), size=min(cfg.batch, len(train)), replace=False)
        batch = [augmented(train[i], rng, cfg.augment) if cfg.augment > 0 else train[i]
                 for i in pick]
        if cfg.decals > 0:  # no draw without decals: the default's batches are as before
            batch = [decaled(b, rng) if rng.random() < cfg.decals else b for b in batch]
        return loss(m, batch, cfg.visibility_target, cfg.loss, cfg.linear_weight,
                    cfg.energy_weight, cfg.prior_weight)

    losses = _loop(run, STAGE, model, cfg.steps, cfg.lr, step)
    model.eval()
    val_scores = {"with": scores(model, val), "without": scores(None, val)} if val else {}
    for k, v in val_scores.items():
        run.log(f"val PSNR {k} the estimator: {v['psnr']:.2f} dB")
    more_scores = {d: {"with": scores(model, v), "without": scores(None, v)}
                   for d, v in more_val.items()}
    for d, sc in more_scores.items():
        run.log(f"{d} val PSNR with / without the estimator: {sc['with']['psnr']:.2f} / "
                f"{sc['without']['psnr']:.2f} dB")
    training = {"command": " ".join(sys.argv), "seed": cfg.seed, "config": asdict(cfg),
                "frame": {"model": cfg.model, "ssao": True, "indirect": bool(cfg.indirect),
                          "specular_occlusion": bool(cfg.specular_occlusion),
                          "geometry": cfg.geometry},
                "dataset_hash": dataset_hash(cfg.data, ("train",)), "steps": cfg.steps,
                "extra_data_hashes": [dataset_hash(d, ("train",)) for d in cfg.extra_data],
                "degrade_levels": list(cfg.degrade_levels),
                "degraded_data_hashes": [dataset_hash(d, ("train",)) for d in degraded],
                "final_loss": losses[-1] if losses else None,
                "val_psnr": {k: v["psnr"] for k, v in val_scores.items()},
                "val_data": {d: {"with": sc["with"]["psnr"], "without": sc["without"]["psnr"],
                                 "dataset_hash": dataset_hash(d, ("val",))}
                             for d, sc in more_scores.items()}}
    path = save_shadow_net(model, Path(cfg.out) / "shadow_net.safetensors", training)
    return {"shadow_net": str(path), "losses": losses, "val": val_scores,
            "val_data": more_scores}
