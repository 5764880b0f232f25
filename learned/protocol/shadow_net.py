"""The neural shadow estimator under the protocol: its product against the strongest classical
screen-space model given the same evidence (:mod:`.classical`: split-sum with SSAO's O(x), S(x)
on chosen terms, the sun light, the indirect light, multiple scattering; the variant chosen on
the validation split), per sample, with the paired bootstrap's 95 % interval
(:func:`.scores.paired_bootstrap`, over training seeds and samples).

The estimator's image is the frame ``[render] shadow_net`` draws (:func:`learned.train.
shadow_net.shadow_net_images`: ``ggx_split_sum`` with SSAO, times V on the surfaces); both are
scored by :func:`.scores.psnr` over the same foreground pixels against the same path-traced
target. Scoring the test split appends to the dataset's ledger (:func:`.scores.record_test`).

The bound of the form (:func:`oracle_scores`, ``--oracle``, no weights): the best factor each
pixel could have, V* = clamp(target / frame, 0, g) per colour, blurred (a Gaussian of sigma px
normalised over the surfaces, as a network's smooth output would be) and multiplied into the
same frame: what an estimator of gain g could at most score at that smoothness.

Geometry (``--geometry``, default ``stack``): every frame - the estimator's and the G-buffer
and screen-space inputs of the classical variants - drawn from each sample's image-space stack,
or (``mesh``) from the meshes the generator drew it from (:mod:`learned.data.scene`: the same
G-buffer, but the viewer's frame of a mesh scene, with its shadow maps of the environment's sun
and compact lights; for a degraded copy, ``DATA/_degraded/<level>``, its degraded stack seen and
its meshes as shadow casters only), or (``splat``) from those meshes tiled with splats of their
true materials (the viewer's splat G-buffer; splats cast the shadow maps too); the foreground and
the target are the stack's every way.

``python -m learned.protocol.shadow_net DATA --split val|test W.safetensors [W2 ...] [--average]``
``python -m learned.protocol.shadow_net DATA --split val --oracle [--geometry mesh|splat]``
"""
from __future__ import annotations

import argparse
import json
import sys
from dataclasses import asdict

import numpy as np
import torch
from torch.nn import functional as F

from viewer.errors import RelightError
from viewer.neural.shadow_net import frame_settings, read_shadow_net

from ..data.reader import DatasetError
from ..data.scene import GEOMETRIES
from ..neural.shadow_net import load_shadow_net
from ..train.shadow_net import shaded, shadow_net_images, visibility
from ..train.stages import load_images
from ..twins.shadow_net import shadow_net_apply
from .classical import Classical, variants
from .data import dataset_hash
from .run import classical_scores
from .scores import paired_bootstrap, psnr, record_test

RANKED = 6  # the classical variants listed with their scores, best first (classical_ranking)


def _top_rows(img: torch.Tensor) -> torch.Tensor:
    """``[1, C, H, W]`` in GL row order -> ``[H, W, 3]`` with row 0 at the top."""
    return img[0, :3].permute(1, 2, 0).flip(0)


def averaged_visibility(visibilities: list[torch.Tensor]) -> torch.Tensor:
    """The geometric mean of several estimators' V (each ``[1, 3, H, W]``) on one image: an
    ensemble of their seeds, at their summed cost."""
    return torch.exp(torch.stack([torch.log(v.clamp_min(1e-6)) for v in visibilities]).mean(0))


@torch.no_grad()
def estimator_scores(weights: list[str], est_images, prot_images,
                     average: bool = False) -> dict:
    """Per-sample PSNR of the unshadowed frame and of each weights file's product, over the
    protocol images' foreground pixels; with ``average`` also of the product with their V
    averaged (:func:`averaged_visibility`)."""
    by_name = {im.name: im for im in est_images}
    out = {"frame": [], "estimators": [[] for _ in weights], "average": []}
    models = [load_shadow_net(w) for w in weights]
    for p in prot_images:
        e = by_name[p.name]
        out["frame"].append(psnr(_top_rows(e.radiance)[p.fg], p.target))
        vs = [visibility(m, e) for m in models]
        for m, v, scores in zip(models, vs, out["estimators"]):
            scores.append(psnr(_top_rows(shaded(m, e, v))[p.fg], p.target))
        if average:
            v = averaged_visibility(vs)
            out["average"].append(psnr(_top_rows(shadow_net_apply(e.radiance, v, e.surface))
                                       [p.fg], p.target))
    return out


ORACLE_GAINS = (1.0, 2.0, 3.0)  # g = 1: the visibility's bound; above: an estimator with a gain
ORACLE_SIGMAS = (0, 1, 2, 4)  # px; 0: per pixel (which also fits the target's noise)


def _blur(v: torch.Tensor, mask: torch.Tensor, sigma: float) -> torch.Tensor:
    """``v`` ``[C, H, W]`` blurred by a Gaussian of ``sigma`` px normalised over ``mask``."""
    if sigma <= 0:
        return v
    r = int(3 * sigma)
    g = torch.exp(-torch.arange(-r, r + 1, dtype=torch.float32) ** 2 / (2 * sigma ** 2))
    g = g / g.sum()

    def conv(a):
        c = a.shape[0]
        a = F.conv2d(F.pad(a[None], (r, r, 0, 0), mode="replicate"),
                     g.view(1, 1, 1, -1).repeat(c, 1, 1, 1), groups=c)
        return F.conv2d(F.pad(a, (0, 0, r, r), mode="replicate"),
                        g.view(1, 1, -1, 1).repeat(c, 1, 1, 1), groups=c)[0]

    m = mask[None].float()
    return conv(v * m) / conv(m).clamp_min(1e-6)


@torch.no_grad()
def oracle_scores(est_images, prot_images) -> dict:
    """``"g<gain> s<sigma>"`` -> per-sample PSNR of the frame times the blurred best factor
    (module doc), over the protocol images' foreground pixels."""
    by_name = {im.name: im for im in est_images}
    out = {f"g{g:g} s{s:g}": [] for g in ORACLE_GAINS for s in ORACLE_SIGMAS}
    for p in prot_images:
        frame = _top_rows(by_name[p.name].radiance)  # [H, W, 3]
        target = p.target_image.permute(1, 2, 0)
        ratio = (target / frame.clamp_min(1e-6)).permute(2, 0, 1)
        for g in ORACLE_GAINS:
            best = torch.where(p.fg[None], ratio.clamp(0.0, g), torch.ones_like(ratio))
            for s in ORACLE_SIGMAS:
                v = _blur(best, p.fg, s).permute(1, 2, 0)
                out[f"g{g:g} s{s:g}"].append(psnr((frame * v)[p.fg], p.target))
    return out


def weights_frame(weights: list[str]) -> dict:
    """The frame every file of ``weights`` multiplies (:func:`viewer.neural.shadow_net.
    frame_settings`); a one-line :class:`~learned.data.reader.DatasetError` naming the first
    file that disagrees with the others (their products are scored on one set of frames)."""
    frames = [(w, frame_settings(read_shadow_net(w).training)) for w in weights]
    for w, f in frames[1:]:
        if f != frames[0][1]:
            raise DatasetError(f"trained on other frames ({f}) than {frames[0][0]} "
                               f"({frames[0][1]}): score them apart", where=w)
    return frames[0][1] if frames else frame_settings({})


def evaluate(data: str, split: str, weights: list[str], classical: dict | None = None,
             oracle: bool = False, geometry: str = "stack", indirect: bool | None = None,
             average: bool = False) -> dict:
    """Scores of ``split``: every classical variant (``classical``: the one chosen on val, as
    :func:`dataclasses.asdict` of :class:`Classical`; None: all of them, the best chosen here -
    on val only), the unshadowed frame and the estimators, and the paired difference of the
    estimators to the chosen classical variant; every frame drawn from ``geometry`` (module
    doc), the estimators' with the indirect light if they were trained on such frames
    (:func:`weights_frame`; ``indirect`` overrides it, e.g. for ``oracle``); with ``average``
    also the files' V averaged, against the mean file per sample and against the classical
    variant."""
    from viewer.renderer import Renderer

    frame = weights_frame(weights)
    if indirect is None:
        indirect = bool(frame["indirect"])
    renderer = Renderer()
    try:
        prot = load_images(data, split, renderer, sun=True, multiscatter=True, geometry=geometry)
        est = shadow_net_images(data, split, renderer, geometry=geometry,
                                indirect=indirect,
                                specular_occlusion=bool(frame["specular_occlusion"]))
    finally:
        renderer.release()
    pool = [Classical(**classical)] if classical else variants()
    found = [(m, classical_scores(m, prot)) for m in pool]
    best, best_scores = max(found, key=lambda f: float(np.mean(f[1])))
    if oracle:
        return {"split": split, "geometry": geometry, "indirect": indirect,
                "samples": len(prot), "classical_name": best.name,
                "classical_psnr": float(np.mean(best_scores)),
                "oracle": {k: {"psnr": float(np.mean(v)),
                               "vs_classical": paired_bootstrap(np.array(v) - best_scores)}
                           for k, v in oracle_scores(est, prot).items()}}
    s = estimator_scores(weights, est, prot, average)
    diff = np.array(s["estimators"]) - np.array(best_scores)[None]
    # the variants that came closest to the one chosen (the choice's margin), best first
    ranking = [{"name": m.name, "psnr": float(np.mean(v))}
               for m, v in sorted(found, key=lambda f: -float(np.mean(f[1])))[:RANKED]]
    out = {"split": split, "geometry": geometry, "indirect": indirect, "samples": len(prot),
           "classical": asdict(best),
           "classical_name": best.name, "classical_psnr": float(np.mean(best_scores)),
           "classical_ranking": ranking,
           "frame_psnr": float(np.mean(s["frame"])),
           "estimator_psnr": [float(np.mean(v)) for v in s["estimators"]],
           "vs_classical": paired_bootstrap(diff),
           "vs_frame": paired_bootstrap(np.array(s["estimators"]) - np.array(s["frame"])[None]),
           "weights": weights}
    if average:  # the files' V averaged: against each file per sample, and the classical variant
        ens = np.array(s["average"])
        out |= {"average_psnr": float(np.mean(ens)),
                "average_vs_files": paired_bootstrap(ens[None] - np.array(s["estimators"])),
                "average_vs_classical": paired_bootstrap(ens - np.array(best_scores))}
    return out


def main(argv=None) -> int:
    p = argparse.ArgumentParser(prog="python -m learned.protocol.shadow_net")
    p.add_argument("data")
    p.add_argument("weights", nargs="*")
    p.add_argument("--split", choices=("val", "test"), default="val")
    p.add_argument("--classical", help="JSON of the variant chosen on val (test: required)")
    p.add_argument("--oracle", action="store_true",
                   help="the bound of the product form instead of weights (val only)")
    p.add_argument("--geometry", choices=GEOMETRIES, default="stack",
                   help="draw the frames from the image-space stacks, the samples' meshes, or "
                        "those meshes tiled with splats")
    p.add_argument("--average", action="store_true",
                   help="also score the weights files' V averaged (geometric mean): an "
                        "ensemble of their seeds, against each file and the classical variant")
    p.add_argument("--indirect", action="store_true",
                   help="with --oracle: frames with the indirect light (weights: their own "
                        "training frames, from their metadata)")
    a = p.parse_args(argv)
    if a.oracle and a.split != "val":
        p.error("--oracle reads the validation split only")
    if not a.oracle and not a.weights:
        p.error("give the estimators' weights files (or --oracle)")
    if a.average and (a.oracle or len(a.weights) < 2):
        p.error("--average needs two or more weights files")
    if a.split == "test" and not a.classical:
        p.error("--split test scores the classical variant chosen on val: give --classical")
    try:
        r = evaluate(a.data, a.split, a.weights,
                     json.loads(a.classical) if a.classical else None, a.oracle, a.geometry,
                     True if a.indirect else None, a.average)
    except RelightError as exc:  # e.g. a sample without the meshes --geometry mesh draws
        print(f"{p.prog}: error: {exc}", file=sys.stderr)
        return exc.exit_code
    if a.split == "test":
        what = "shadow_net vs classical" + (f" ({a.geometry})" if a.geometry != "stack" else "")
        r["test_scored"] = record_test(a.data, what, a.weights,
                                       r["samples"], dataset_hash(a.data, ("test",)))
    print(json.dumps(r, indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
