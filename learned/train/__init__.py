"""Training: teacher (phase 1), shadow estimator (phase 2, shader frozen), student distillation.

    relight train --data DATA --out RUN [--quick] [--stage all|teacher] [--teacher-steps N] ...
    torchrun --nproc_per_node 2 -m relight train ...      # DistributedDataParallel (gloo / NCCL)

Phase 1 (thesis sec. 4.3.3-4.3.4): L1 over random foreground pixels (``batch_pixels``, 8192 in
the thesis) of one random training image per step, ``light_samples`` light directions per pixel
(``strategy`` uniform, cosine or env importance sampling), Adam. Phase 2: the UNet of eq. 4.3 on
whole images, L1 over all foreground pixels (eq. 4.6), the teacher frozen. Distillation: the
student matches the frozen two-stage teacher (teacher x shadow map, ``distill_samples`` light
samples) per pixel, L1 on log(1 + radiance) (``distill_loss``; plain L1 on radiance is dominated
by the brightest pixels, the metrics compare tone-mapped x / (1 + x)).

Every stage checkpoints ``RUN/<stage>.pt`` (model, optimiser, step, RNG) every
``checkpoint_every`` steps through a temporary file + rename and resumes from it; a finished stage
is loaded, not retrained. Logs are plain lines on stdout and in ``RUN/train.log`` (rank 0 only).
The exported weights are ``RUN/neural_student.safetensors`` and ``RUN/neural_teacher.safetensors``.

Modules by job: :mod:`.config` (:class:`TrainConfig`, :data:`QUICK_DATA`), :mod:`.runner` (the
run folder, checkpoints and resume, the process group, the step loop), :mod:`.stages` (the
training images and the three stages), :mod:`.pipeline` (:func:`train`, :func:`pipeline`),
:mod:`.shadow_net` (the viewer's shadow estimator alone on a dataset's targets: ``relight train
--stage shadow_net``). The
measured comparison of student designs, which renders through the bench, is
:mod:`relight.bench.students` (``relight train --compare-students``).
"""
from .config import COMPARE_SPLITS, QUICK_DATA, TrainConfig
from .pipeline import STAGES, checkpoint_of, pipeline, train
from .runner import Run
from .stages import (TrainImage, distill_loss, distill_student, distillation_targets,
                     load_images, teacher_images, train_shadow, train_teacher)

__all__ = ["COMPARE_SPLITS", "QUICK_DATA", "STAGES", "Run", "TrainConfig", "TrainImage",
           "checkpoint_of", "distill_loss", "distill_student", "distillation_targets",
           "load_images", "pipeline", "teacher_images", "train", "train_shadow", "train_teacher"]
