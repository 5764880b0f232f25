"""The training data and the three stages (thesis sec. 4.3.3-4.3.4).

Phase 1, :func:`train_teacher`: L1 against the unoccluded target (``rgb_unoccluded``: the
unshadowed image of eq. 4.3; ``rgb`` for data without it) over random foreground pixels
(``batch_pixels``, 8192 in the thesis) of one random training image per step, ``light_samples`` light directions per pixel
(``strategy`` uniform, cosine or env importance sampling). Phase 2, :func:`train_shadow`: the UNet
of eq. 4.3 on whole images, L1 over all foreground pixels (eq. 4.6), the teacher frozen.
Distillation, :func:`distill_student`: the student matches the frozen two-stage teacher (teacher x
shadow map, ``distill_samples`` light samples) per pixel under :func:`distill_loss`.
"""
from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path

import numpy as np
import torch

from viewer.environment.maps import EnvironmentSpec

from ..data.reader import DatasetError, list_samples, load_sample
from ..neural.lighting import (
    Lighting,
    env_lights_base,
    lighting_from_gl,
    student_features,
)
from ..neural.shadow import ShadowUNet
from ..neural.student import Student
from ..neural.teacher import Teacher
from .runner import Run, _loop

# ---- data ----------------------------------------------------------------------------------------

@dataclass
class TrainImage:
    name: str
    size: tuple[int, int]  # (W, H)
    fg: torch.Tensor  # [H, W] bool
    gb: dict  # channel -> [P, C] foreground pixels
    v: torch.Tensor  # [P, 3] towards the viewer
    target: torch.Tensor  # [P, 3]
    unshadowed: torch.Tensor  # [P, 3] the teacher's target: rgb_unoccluded, else rgb
    target_image: torch.Tensor  # [3, H, W]
    normal_image: torch.Tensor  # [3, H, W]
    ao_image: torch.Tensor  # [1, H, W]
    lighting: Lighting
    ssao: torch.Tensor  # [P] the SSAO pass's occlusion O(x) (eq. 6.19)
    vis: torch.Tensor  # [P] its screen-space visibility of the environment's light (SSAO_ENV_VIS)
    # [P, 3] the indirect pass's one-bounce light L_ind (screen_space_indirect); None: not computed
    indirect: torch.Tensor | None = None
    # the IBL without the environment's sun, with the sun (lighting_from_gl(..., sun=True)), for
    # students whose base shades it; None: not loaded
    lighting_sun: Lighting | None = None


def screen_space_inputs(renderer, sample, geometry: str = "stack"
                        ) -> tuple[np.ndarray, np.ndarray]:
    """The SSAO pass's occlusion O(x) and the environment's screen-space visibility S(x) on the
    sample's own G-buffer, ``[H, W]`` each (row 0 at the top): computed by the renderer's GL pass
    (``passes/ssao.frag`` with ``SSAO_ENV_VIS``, default SSAO settings) exactly as a student with
    ``vis`` inputs gets them at run time; the pass's torch twin (``learned.twins.ssao``) is held
    to it by the ``ssao:env_visibility`` parity check. ``geometry``: drawn from the sample's
    stack or from its meshes (:func:`learned.data.scene.geometry_scene`)."""
    from ..data.scene import geometry_scene
    from ..parity.checks.models import gl_texture

    scene = geometry_scene(sample, geometry, model="ggx_split_sum", ssao=True)
    img = gl_texture(renderer.environment_visibility(scene, renderer.draw(scene)))[::-1]
    return np.ascontiguousarray(img[..., 0]), np.ascontiguousarray(img[..., 1])


@torch.no_grad()
def estimator_visibility(renderer, sample, weights: str) -> np.ndarray:
    """The shadow estimator's visibility V of the weights file ``weights`` on the sample, as a
    frame with ``[render] shadow_net_use = "visibility"`` takes it in place of SSAO's O(x) and
    S(x): its mean over the colours (``passes/deferred.glsl`` ``ssao_channel`` under
    ``SSAO_SHADOW_NET``), ``[H, W]`` (row 0 at the top), on the frame the file records
    (:func:`viewer.neural.shadow_net.frame_settings`: geometry, indirect light, specular
    occlusion), through the estimator's torch twin (the ``shadow_net`` parity check holds the
    GLSL passes to it)."""
    from .shadow_net import shadow_net_image, visibility

    path = Path(weights)
    stamp = (path.stat().st_mtime_ns, path.stat().st_size) if path.is_file() else None
    frame, net = _estimator(str(path), stamp)  # a missing file: read_shadow_net's one line
    img = shadow_net_image(renderer, sample, frame["model"], frame["geometry"],
                           frame["indirect"], frame["specular_occlusion"])
    v = visibility(net, img)[0].mean(0)  # [H, W], GL row order
    return np.ascontiguousarray(v.numpy()[::-1])


@lru_cache(maxsize=2)  # one file a training run or a bench: read once, not once a sample
def _estimator(weights: str, stamp):
    """(the frame the estimator file was trained on, its torch network); ``stamp``: the file's
    modification time and size, so a file rewritten in place is read again."""
    from viewer.neural.shadow_net import frame_settings, read_shadow_net

    from ..neural.shadow_net import load_shadow_net

    return frame_settings(read_shadow_net(weights).training), load_shadow_net(weights)


def screen_space_indirect(renderer, sample, multiscatter: bool = False,
                          geometry: str = "stack") -> np.ndarray:
    """The indirect pass's one-bounce light L_ind (eq. 6.22, ``passes/ssao.frag`` with
    ``SSAO_INDIRECT``, default settings) on the sample's own G-buffer, ``[H, W, 3]`` (row 0 at the
    top): the frame of ``ggx_split_sum`` + SSAO + indirect minus its direct target, computed by the
    renderer's GL pass. It gathers ``ggx_split_sum`` + SSAO's direct light, which is what a
    ``split3`` student with ``vis`` inputs and an untrained indirect factor renders as its own;
    a trained student's direct light differs a little, so at run time the pass gathers a slightly
    different L_ind than the student was trained with. ``multiscatter``: the base of a student
    with ``"multiscatter": true`` (ggx_split_sum's default). ``geometry``: as
    :func:`screen_space_inputs`."""
    from ..data.scene import geometry_scene
    from ..parity.checks.models import gl_texture

    scene = geometry_scene(sample, geometry, model="ggx_split_sum", ssao=True, indirect=True,
                           multiscatter=bool(multiscatter))  # split3's start
    targets = renderer.draw(scene)
    out = gl_texture(targets.radiance)[..., :3] - gl_texture(targets.direct)[..., :3]
    return np.ascontiguousarray(out[::-1])


def load_images(root: str, split: str, renderer, sun: bool = False,
                multiscatter: bool = False, geometry: str = "stack",
                visibility: str | None = None) -> list[TrainImage]:
    """Every usable sample of ``split``; ``sun``: also the lighting of a student whose base
    shades the environment's sun (``TrainImage.lighting_sun``); ``multiscatter``: the indirect
    light gathered from the direct light of a base with multiple scattering; ``visibility``: a
    shadow estimator's weights file whose V takes the place of O(x) and S(x)
    (:func:`estimator_visibility`: the frames of ``shadow_net_use = "visibility"``). ``geometry``
    ``"mesh"`` (``"splat"``): the G-buffer channels and the screen-space inputs from the sample's
    mesh scene (tiled with splats; :mod:`learned.data.scene`) instead of its stack; the foreground and the targets are the
    stack's either way."""
    from ..data.scene import GEOMETRIES, geometry_channels

    if geometry not in GEOMETRIES:
        raise ValueError(f"geometry={geometry!r}: expected one of {GEOMETRIES}")
    out = []
    for folder in list_samples(root, split):
        s = load_sample(folder)
        fg = torch.from_numpy(s.foreground())
        if not fg.any():
            continue
        channels = s.channels if geometry == "stack" else geometry_channels(renderer, s, geometry)
        ch = {k: torch.from_numpy(np.ascontiguousarray(v)) for k, v in channels.items()}
        v = -torch.from_numpy(s.view_dirs())
        spec = EnvironmentSpec(path=str(s.environment))
        lighting = lighting_from_gl(renderer, spec)
        lighting_sun = lighting_from_gl(renderer, spec, sun=True) if sun else None
        target = torch.from_numpy(np.ascontiguousarray(s.target))
        unshadowed = target if s.unoccluded is None else torch.from_numpy(s.unoccluded)
        ssao, vis = (torch.from_numpy(a) for a in screen_space_inputs(renderer, s, geometry))
        if visibility is not None:  # V's mean stands for both, as in the viewer
            ssao = vis = torch.from_numpy(estimator_visibility(renderer, s, visibility))
        indirect = torch.from_numpy(screen_space_indirect(renderer, s, multiscatter, geometry))
        out.append(TrainImage(
            name=s.name, size=s.size, fg=fg, gb={k: t[fg] for k, t in ch.items()}, v=v[fg],
            target=target[fg], unshadowed=unshadowed[fg], target_image=target.permute(2, 0, 1),
            normal_image=ch["normal"].permute(2, 0, 1), ao_image=ch["ao"].permute(2, 0, 1),
            lighting=lighting, ssao=ssao[fg], vis=vis[fg], indirect=indirect[fg],
            lighting_sun=lighting_sun))
    if not out:
        raise DatasetError(f"no usable samples in the {split!r} split", where=root)
    return out


def _pick(images: list[TrainImage], rng: np.random.Generator, count: int):
    img = images[int(rng.integers(0, len(images)))]
    p = img.v.shape[0]
    idx = torch.from_numpy(rng.choice(p, size=min(count, p), replace=p < count))
    return img, idx


# ---- phase 1: the teacher ------------------------------------------------------------------------

def train_teacher(run: Run, images: list[TrainImage]) -> tuple[Teacher, list[float]]:
    cfg = run.cfg
    torch.manual_seed(cfg.seed)
    model = Teacher(hidden=cfg.teacher_hidden, num_freqs=cfg.teacher_freqs,
                    light_input=cfg.teacher_light_input)
    rng = np.random.default_rng([cfg.seed, run.rank, 1])

    def step(ddp, _):
        img, idx = _pick(images, rng, cfg.batch_pixels)
        gb = {k: t[idx] for k, t in img.gb.items()}
        u = torch.rand(len(idx), cfg.light_samples, 2)
        pred = ddp(gb, img.v[idx], img.lighting, u, cfg.strategy)
        # the teacher is the unshadowed shader of eq. 4.3: trained on the occluded targets (AO,
        # SSAO, shadows), it learned their mean occlusion as reflectance (issue 14)
        return (pred - img.unshadowed[idx]).abs().mean()

    losses = _loop(run, "teacher", model, cfg.teacher_steps, cfg.lr, step)
    return model.eval(), losses


@torch.no_grad()
def teacher_images(teacher: Teacher, images: list[TrainImage], samples: int, strategy: str,
                   seed: int = 0) -> list[torch.Tensor]:
    """The frozen teacher's unshadowed render of every image ``[3, H, W]`` (background 0)."""
    gen = torch.Generator().manual_seed(seed)
    out = []
    for img in images:
        w, h = img.size
        full = torch.zeros(h, w, 3)
        vals = []
        for chunk in torch.split(torch.arange(img.v.shape[0]), 1024):
            gb = {k: t[chunk] for k, t in img.gb.items()}
            u = torch.rand(len(chunk), samples, 2, generator=gen)
            vals.append(teacher(gb, img.v[chunk], img.lighting, u, strategy))
        full[img.fg] = torch.cat(vals)
        out.append(full.permute(2, 0, 1))
    return out


# ---- phase 2: the shadow estimator ---------------------------------------------------------------

def train_shadow(run: Run, images: list[TrainImage], unshadowed: list[torch.Tensor]
                 ) -> tuple[ShadowUNet, list[float]]:
    cfg = run.cfg
    torch.manual_seed(cfg.seed + 2)
    model = ShadowUNet(width=cfg.shadow_width)
    rng = np.random.default_rng([cfg.seed, run.rank, 2])

    def step(ddp, _):
        k = int(rng.integers(0, len(images)))
        img = images[k]
        pred = ddp(unshadowed[k][None], img.normal_image[None], img.ao_image[None])
        # eq. 4.6 over the image's pixels with a surface (the background is the environment)
        return (pred - img.target_image[None]).abs()[..., img.fg].mean()

    losses = _loop(run, "shadow", model, cfg.shadow_steps, cfg.lr, step)
    return model.eval(), losses


# ---- distillation: the student -------------------------------------------------------------------

@torch.no_grad()
def distillation_targets(images, unshadowed, shadow: ShadowUNet | None) -> list[torch.Tensor]:
    """Per image, the frozen two-stage teacher at its foreground pixels ``[P, 3]``."""
    out = []
    for img, un in zip(images, unshadowed):
        full = un if shadow is None else shadow(un[None], img.normal_image[None],
                                                img.ao_image[None])[0]
        out.append(full.permute(1, 2, 0)[img.fg])
    return out


@torch.no_grad()
def design_features(model: Student, images: list[TrainImage]) -> list[tuple]:
    """:func:`student_features` of every image as ``model`` sees them at run time: a student with
    ``vis`` inputs runs with SSAO (``viewer.neural.required_settings``), so its ao input is the
    material AO times the SSAO pass's O(x) and its vis input the pass's S(x); a student with
    ``ssao`` inputs gets the same ao and no S(x); any other student gets the material AO (the
    renderer multiplies SSAO in only when the user turns it on). A
    student whose base shades the sun (``model.sun``) reads the IBL without it and gets the sun's
    arguments as a fourth tensor (``TrainImage.lighting_sun``, ``load_images(..., sun=True)``)."""
    sun = getattr(model, "sun", False)

    def lighting(img):
        if not sun:
            return img.lighting
        if img.lighting_sun is None:
            raise ValueError("a student with the sun needs load_images(..., sun=True)")
        return img.lighting_sun

    if model.reads_visibility:
        return [student_features(img.gb, img.v, lighting(img), img.gb["ao"][:, 0] * img.ssao,
                                 img.vis, dominant=model.dominant, sun=sun) for img in images]
    ao = (lambda img: img.gb["ao"][:, 0] * img.ssao) if model.reads_occlusion else \
        (lambda img: img.gb["ao"][:, 0])
    return [student_features(img.gb, img.v, lighting(img), ao(img),
                             dominant=model.dominant, sun=sun) for img in images]


def student_args(model: Student, img: TrainImage, feats: tuple, idx=None) -> tuple:
    """The arguments of ``model``'s forward for ``img`` (``feats``: its :func:`design_features`)
    at the foreground pixels ``idx`` (None: all): the features, the indirect light of a student
    that learns a factor on it, the sun's arguments of a student whose base shades the sun."""
    x, irr, pre, *sun = feats if idx is None else (t[idx] for t in feats)
    if not (model.learns_indirect or sun):
        return x, irr, pre
    ind = None
    if model.learns_indirect:
        ind = img.indirect if idx is None else img.indirect[idx]
    return (x, irr, pre, ind, *sun)


def fixed_light(model: Student, img: TrainImage, feats: tuple) -> torch.Tensor | None:
    """What a sun student's pass adds to its prediction besides the network: the environment's
    other compact lights through its classical base (``env_lights_base``), fixed terms over all
    of ``img``'s foreground pixels; None for any other student or image."""
    if not (model.sun and img.lighting_sun is not None and len(feats) > 3):
        return None
    return env_lights_base(img.gb, feats[0], feats[3], img.lighting_sun, model.multiscatter)


def distill_loss(pred: torch.Tensor, target: torch.Tensor, kind: str) -> torch.Tensor:
    """Distillation loss of ``pred`` against ``target`` (radiance ``[N, 3]``): ``l1`` on radiance,
    or ``log_l1`` on log(1 + radiance), which weighs dark and bright pixels alike, like the
    tone-mapped metrics. Measured on the quick data (teacher 3000 steps, students 3000 steps,
    held-out PSNR vs MC): log_l1 w16x2-pbr 25.41 dB / w16x2-dfg-pbr 25.31 against l1 24.59 / 25.04;
    the free6 w16x2-dfg is indifferent (25.22 / 25.27)."""
    if kind == "l1":
        return (pred - target).abs().mean()
    if kind == "log_l1":
        return (torch.log1p(pred.clamp_min(0.0)) - torch.log1p(target.clamp_min(0.0))).abs().mean()
    raise ValueError(f"unknown distillation loss {kind!r} (l1 | log_l1)")


def distill_student(run: Run, images: list[TrainImage], targets: list[torch.Tensor],
                    design: dict | None = None, stage: str = "student", feats=None
                    ) -> tuple[Student, list[float]]:
    """Distil a :class:`Student` (``design``: its keyword arguments, default the config's) from
    the per-pixel ``targets``; every design starts from the same seed and draws the same batches.
    ``feats``: :func:`design_features` per image, when the caller already has them."""
    cfg = run.cfg
    torch.manual_seed(cfg.seed + 3)
    design = design if design is not None else {
        "hidden": cfg.student_hidden, "num_freqs": cfg.student_freqs,
        "features": cfg.student_features, "output": cfg.student_output,
        "indirect": cfg.student_indirect, "sun": cfg.student_sun,
        "multiscatter": cfg.student_multiscatter}
    model = Student(**design)
    rng = np.random.default_rng([cfg.seed, run.rank, 3])
    if feats is None:
        feats = design_features(model, images)
    extra = [fixed_light(model, img, f) for img, f in zip(images, feats)]

    def step(ddp, _):
        k = int(rng.integers(0, len(images)))
        p = targets[k].shape[0]
        idx = torch.from_numpy(rng.choice(p, size=min(cfg.batch_pixels, p), replace=False))
        args = student_args(model, images[k], feats[k], idx)
        fixed = extra[k][idx] if extra[k] is not None else 0.0
        if cfg.student_gain_penalty > 0.0 or cfg.student_direct_penalty > 0.0:
            # + the penalties on brightening the direct light and on any direct correction
            pred, gain, dev = ddp(*args, with_deviation=True)
            return (distill_loss(pred + fixed, targets[k][idx], cfg.distill_loss)
                    + cfg.student_gain_penalty * gain + cfg.student_direct_penalty * dev)
        return distill_loss(ddp(*args) + fixed, targets[k][idx], cfg.distill_loss)

    losses = _loop(run, stage, model, cfg.student_steps, cfg.lr, step)
    return model.eval(), losses
