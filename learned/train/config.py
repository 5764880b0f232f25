"""What a training run is: :class:`TrainConfig` (every knob of the three stages), its quick
variant, and the quick synthetic dataset (:data:`QUICK_DATA`)."""
from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class TrainConfig:
    data: str
    out: str
    teacher_steps: int = 2000
    shadow_steps: int = 500
    student_steps: int = 24000
    batch_pixels: int = 8192
    light_samples: int = 32
    strategy: str = "env"  # "uniform" | "cosine" | "env"
    lr: float = 1e-3
    teacher_hidden: int = 64
    teacher_freqs: int = 4
    # whether the teacher sees the light's radiance log(1 + L_in) (the thesis's eq. 4.2 input);
    # False (the shipped teacher's): rho from material and geometry only, exactly linear in the
    # light (architecture "light_input": false; learned.neural.teacher)
    teacher_light_input: bool = False
    # the student fields default to the shipped student's design (SHIPPED_STUDENT, as its
    # weights file's metadata records it): the 7 material and view inputs and how bright the
    # environment is from below (env_below, one value a frame) -> 32 -> 32 -> 3 (no screen-space
    # evidence: ao x O(x) only as the diffuse factor, "ssao-env"), split3 with the sun
    # light and multiple scattering, a learned indirect factor, gain penalty 1, 24,000 steps on
    # the dataset's own targets
    student_hidden: tuple[int, ...] = (32, 32)
    student_freqs: int = 0
    student_features: str = "ssao-env"  # learned.neural.student.FEATURE_INPUTS
    student_output: str = "split3"  # "free6" | "pbr3" | "split3" (learned.neural.student.OUTPUTS)
    # "none" | "factor": a learned factor on the screen-space indirect light
    # (learned.neural.student.INDIRECTS; trained on TrainImage.indirect)
    student_indirect: str = "factor"
    # a split3 student whose base shades the environment's sun analytically (architecture "sun":
    # the IBL without the sun + the sun as a light, as ggx_split_sum with SUN_LIGHT)
    student_sun: bool = True
    # a split3 student whose base has ggx_split_sum's multiple-scattering compensation
    # (architecture "multiscatter"): untrained, it renders the classical model's default
    student_multiscatter: bool = True
    # weight of Student.gain in the student's loss: how far its direct-light corrections brighten
    # the split-sum base (0: off). With path-traced targets, light from nearby surfaces that the
    # base misses (a floor seen in a sphere's lower half) is otherwise learned as a brighter
    # direct term, which new scenes without those surfaces do not have (README "Against truth")
    student_gain_penalty: float = 1.0
    # weight of Student.deviation: how far its direct-light corrections leave the split-sum base
    # either way (0: off). A student reading only the material and n.v can correct its direct
    # light only by changing the BRDF; trained under sunless skies without it, it learned to dim
    # it (the white furnace 0.7 % dark), the visibility error of its screen-space base turned into
    # material. 100 (the shipped student's) holds its direct factors at 1 to the fourth decimal
    student_direct_penalty: float = 100.0
    distill_loss: str = "log_l1"  # "l1" on radiance | "log_l1" on log(1 + radiance)
    # what the student learns from: "teacher" (teacher x shadow map, the thesis's distillation) or
    # "target" (the dataset's rgb itself: with path-traced targets, truth; STUDENT_TARGETS)
    student_target: str = "target"
    # a shadow estimator's weights file whose V takes O(x)'s place in the student's frames (a
    # student for [render] shadow_net_use = "visibility"; learned.train.stages.load_images);
    # None: SSAO's O(x), the shipped student's
    student_visibility: str | None = None
    shadow_width: int = 16
    distill_samples: int = 128
    seed: int = 0
    checkpoint_every: int = 100
    log_every: int = 50

    @classmethod
    def quick(cls, data: str, out: str, **kw) -> "TrainConfig":
        """Minutes on two CPU cores: smaller networks, fewer steps and samples."""
        base = dict(teacher_steps=3000, shadow_steps=150, batch_pixels=2048,
                    light_samples=16, teacher_hidden=32, teacher_freqs=2, shadow_width=8,
                    distill_samples=64, log_every=100)
        return cls(data=data, out=out, **(base | kw))


STUDENT_TARGETS = ("teacher", "target")

# the shipped student's design and training (assets/weights/neural_student.safetensors's
# metadata: relight train --stage student ... --student-steps 24000); TrainConfig's defaults
SHIPPED_STUDENT = {"student_hidden": (32, 32), "student_features": "ssao-env",
                   "student_output": "split3", "student_indirect": "factor", "student_sun": True,
                   "student_multiscatter": True, "student_gain_penalty": 1.0,
                   "student_direct_penalty": 100.0,
                   "student_steps": 24000, "student_target": "target", "batch_pixels": 2048}
# the Student keyword arguments of that design
SHIPPED_STUDENT_DESIGN = {"hidden": (32, 32), "features": "ssao-env", "output": "split3",
                          "indirect": "factor", "sun": True, "multiscatter": True}

# the synthetic dataset ``relight train`` generates when it is given no data (OUT/data)
QUICK_DATA = {"count": 40, "size": 64, "samples": 256, "seed": 0, "gbuffer_fraction": 0.25}

# the student comparison's held-out splits: never seen by the teacher, shadow or students
COMPARE_SPLITS = ("val", "test")
