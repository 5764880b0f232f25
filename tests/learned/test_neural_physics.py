"""Physics oracles for every learned model and every shipped weights file (issue 14).

The classical models pass these exactly (``ggx_split_sum`` and ``ggx_mc`` render the white furnace
at 0.800); the learned ones may miss by their approximation error, so each bound below is stated
beside the error it was derived from:

* **white furnace**: a Lambertian sphere (specular 0, metallic 0) of albedo 0.8 under the constant
  white environment (radiance 1) reflects exactly 0.8 everywhere;
* **albedo scaling**: halving a diffuse albedo halves the reflected radiance;
* **linearity in the environment**: doubling the environment's intensity doubles the radiance.

Checked for the torch teacher (``Teacher`` estimator, many samples), the torch student and, through
the renderer, the GLSL of both, on the shipped ``assets/weights/neural_{student,teacher}``
and every candidate student in ``assets/weights/students``. The weights shipped before the fix
(student furnace 0.424, candidates 0.40-0.58, teacher 0.724 / 0.483 / 0.709) fail every furnace
test, eight of the eleven old candidates and the old teacher the albedo test.
"""
from __future__ import annotations

import math

import numpy as np
import pytest
import torch

from assets import ASSET_ROOT
from learned.export import load_model
from learned.neural.lighting import lighting_from_gl, student_features
from viewer.environment.maps import EnvironmentSpec
from viewer.neural import default_weights

STUDENTS = [default_weights("student"), default_weights("student_visibility"),
            *sorted((ASSET_ROOT / "weights" / "students").glob("*.safetensors"))]
TEACHERS = [default_weights("teacher")]

# Candidate students (assets/weights/students, rendered by the bench as the MLP-size knob, never a
# default) that break an oracle beyond its bound, with what they measure (GLSL): strict xfails, so
# a retrained file that passes shows up. free6 designs predict per-channel k_diffuse from the
# albedo input, so their radiance is not proportional to the albedo; the larger designs fit the
# teacher's darker, tinted energy more closely (README "Energy: the white furnace").
KNOWN_FAILURES = {
    "furnace": {"w16": "0.690-0.749", "w16-pbr": "0.724", "w16x2": "0.743-0.785",
                "w16x2-dfg": "0.711-0.733", "w16x2-dfg-pbr": "0.741", "w16x2-pbr": "0.743",
                "w32x2": "0.704-0.767", "w32x2-dfg": "0.697-0.767", "w32x2-dfg-pbr": "0.692",
                "w32x2-pe2": "0.513-0.637", "w64x2": "0.643-0.739"},
    "albedo": {"w16": "1.52-1.71", "w16-pbr": "2.038", "w16x2": "1.60-1.71",
               "w16x2-dfg": "1.63-1.69", "w16x2-dfg-pbr": "1.974", "w16x2-pbr": "2.014",
               "w32x2": "1.81-1.89", "w32x2-dfg": "1.74-1.79", "w32x2-dfg-pbr": "1.990",
               "w32x2-pe2": "1.91-2.16", "w64x2": "1.87-1.96"},
}


def _students(oracle: str) -> list:
    out = []
    for p in STUDENTS:
        known = KNOWN_FAILURES.get(oracle, {}).get(p.stem)
        marks = [pytest.mark.xfail(strict=True, reason=f"candidate {p.stem} measures {known}")
                 ] if known and p.parent.name == "students" else []
        out.append(pytest.param(p, id=p.stem, marks=marks))
    return out

# Bounds and the errors they stand on. The quick networks' general approximation error is large:
# on the 8 held-out quick samples (sunlit, occluded) the per-image, per-channel energy error
# |mean(pred) / mean(target) - 1| is 26 % median for the student (vs the MC targets) and 40 %
# for the teacher (vs the unoccluded targets). The furnace is a far easier, in-distribution case,
# so the bounds are set from what the retrained weights measure here, with a margin, and are
# tighter than that general error; the weights shipped before the fix fail them.
# Student furnace: 0.79989 GLSL (-0.014 %: the student trained on path-traced truth with the
# multiscatter base and the gain penalty, README "Against truth"; -0.010 / -0.014 / -0.017 % at
# 24 / 32 / 48 pixels a side), torch -0.42 % (-0.37 +- 0.04 % over 20 point sets, -0.29 to
# -0.50 %: the points' n.v distribution is not the pixels'). Bounds: GLSL 0.1 % (6x the worst
# size; GLSL and torch twin agree to 1e-4 on any conforming device), torch 1 % (2x the worst
# point set). The truth students before it 0.838-0.886 (4.8-10.8 %), the distilled quick student
# 0.735 (8.2 %: the mean residual occlusion of its distillation targets, which it cannot see),
# every candidate 0.51-0.79 (KNOWN_FAILURES; 10 %, the bound before, passed four of them); before
# the energy fix 0.424, 47 %.
STUDENT_FURNACE_TOL = {"torch": 0.01, "glsl": 0.001}  # relative
# Teacher furnace, per channel: (0.820, 0.820, 0.839) GLSL, (0.812, 0.814, 0.837) torch: 4.9 %
# high (the teacher trained on path-traced truth without the light input, "light_input": false,
# 64 light samples per pixel; with 16 it measured (0.683, 0.668, 0.709), 17 % low: L1 on a noisy
# estimate learns its median). The quick teacher shipped before it: (0.809, 0.792, 0.635) GLSL,
# blue 21 % low; the truth teacher with the light input: blue 0.59, 26 % low; before the energy
# fix: (0.724, 0.483, 0.709), green 40 % low.
TEACHER_FURNACE_TOL = 0.10  # relative, per channel
# Student L(0.8) / L(0.4): GLSL 2.00106 (0.053 %; 0.003 / 0.053 / 0.002 % at 24 / 32 / 48 pixels),
# torch 1.9934 (-0.33 %; -0.29 +- 0.04 % over 20 point sets, -0.22 to -0.39 %): k_d depends on
# the albedo input. Bounds: GLSL 0.2 % (4x the worst size), torch 1 % (2.5x the worst point set).
# Before: 1.88-2.06. KNOWN_FAILURES lists the candidates beyond these bounds (0.48-25 %; 5 %, the
# bound before, passed four of them).
ALBEDO_RATIO_TOL = {"torch": 0.01, "glsl": 0.002}  # relative
# Teacher L(0.8) / L(0.4) per channel: (1.91, 1.82, 1.87) torch, (1.93, 1.85, 1.88) GLSL (8.8 %:
# rho depends on the albedo input; the quick teacher shipped before: (2.07, 1.77, 1.57), 21.5 %;
# before the fix (1.93, 1.25, 1.66)).
TEACHER_ALBEDO_RATIO_TOL = 0.15  # relative, per channel
# Teacher x2 intensity per channel, teachers with the log(1 + L_in) input (thesis eq. 4.2): the
# quick teacher (1.87, 2.00, 2.17) (8.4 %; before the fix (1.75, 1.92, 1.87)); the truth teacher
# with the input 2.5-2.9, which is why the shipped one has none.
TEACHER_LINEARITY_TOL = 0.20  # relative, per channel
# Teachers without it ("light_input": false): rho never sees the light, so x2 is exact up to
# float32 (measured: exactly 2 in torch and GLSL, x2 is a power of two).
LIGHTLESS_TEACHER_LINEARITY_TOL = 1e-5
STUDENT_LINEARITY_TOL = 1e-5  # exact up to float32: intensity scales E and P outside the MLP


def _sphere_scene(model: str, albedo: float = 0.8, intensity: float = 1.0, **render):
    from viewer.scene.description import scene_from_dict

    return scene_from_dict({
        "camera": {"position": [0, 0, 3], "target": [0, 0, 0], "fov_y": 30, "size": [32, 32]},
        "environment": {"procedural": "white", "intensity": intensity, "width": 64},
        "render": {"model": model, "tonemap": "none", "background": "transparent"} | render,
        "objects": [{"type": "sphere", "center": [0, 0, 0], "radius": 0.6,
                     "material": {"albedo": [albedo] * 3, "roughness": 1.0, "specular": 0.0,
                                  "metallic": 0.0}}]}, file=str(ASSET_ROOT / "furnace"))


@pytest.fixture(scope="module")
def renderer(ctx):
    from viewer.renderer import Renderer

    r = Renderer(ctx=ctx)
    yield r
    r.release()


def _glsl_mean(renderer, model: str, **kw) -> np.ndarray:
    """Mean linear radiance ``[3]`` over the fully covered pixels of the furnace sphere."""
    albedo = kw.pop("albedo", 0.8)
    intensity = kw.pop("intensity", 1.0)
    img = renderer.render(_sphere_scene(model, albedo, intensity, **kw)).radiance
    covered = img[..., 3] >= 1.0
    assert covered.sum() > 300
    return img[..., :3][covered].astype(np.float64).mean(0)


@pytest.fixture(scope="module")
def white(renderer):
    return lighting_from_gl(renderer, EnvironmentSpec(procedural="white", width=64))


def _sphere_gbuffer(count: int = 512, albedo: float = 0.8):
    """Flattened G-buffer of ``count`` points of a Lambertian sphere seen head-on: normals on the
    visible hemisphere (n.v > 0.05), v = +Z."""
    g = torch.Generator().manual_seed(0)
    n = torch.nn.functional.normalize(torch.randn(count, 3, generator=g), dim=-1)
    n[:, 2] = n[:, 2].abs().clamp_min(0.05)
    n = torch.nn.functional.normalize(n, dim=-1)
    v = torch.tensor([0.0, 0.0, 1.0]).expand(count, 3)
    gb = {"albedo": torch.full((count, 3), albedo), "normal": n, "roughness": torch.ones(count, 1),
          "metallic": torch.zeros(count, 1), "specular": torch.zeros(count, 1),
          "ao": torch.ones(count, 1)}
    return gb, v


@torch.no_grad()
def _teacher_torch(path, lighting, albedo=0.8, samples=256) -> torch.Tensor:
    gb, v = _sphere_gbuffer(albedo=albedo)
    u = torch.rand(v.shape[0], samples, 2, generator=torch.Generator().manual_seed(1))
    return load_model(path, "teacher")(gb, v, lighting, u, "cosine").mean(0).double()


@torch.no_grad()
def _student_torch(path, lighting, albedo=0.8) -> torch.Tensor:
    gb, v = _sphere_gbuffer(albedo=albedo)
    x, irr, pre = student_features(gb, v, lighting, gb["ao"][:, 0])
    return load_model(path, "student")(x, irr, pre).mean(0).double()


# ---- the student: torch and GLSL, every shipped file -----------------------------------------------

@pytest.mark.parametrize("path", _students("furnace"))
def test_student_white_furnace(renderer, white, path):
    """0.8 within STUDENT_FURNACE_TOL, in torch (points on the visible hemisphere) and in GLSL (the
    rendered sphere's pixels; same network, parity's 1e-4, different n.v distribution)."""
    torch_mean = _student_torch(path, white).numpy()
    glsl_mean = _glsl_mean(renderer, "neural", weights=str(path))
    for m, side in ((torch_mean, "torch"), (glsl_mean, "glsl")):
        assert np.all(np.abs(m / 0.8 - 1.0) < STUDENT_FURNACE_TOL[side]), (torch_mean, glsl_mean)


@pytest.mark.parametrize("path", _students("albedo"))
def test_student_albedo_scaling(renderer, white, path):
    """L(0.8) / L(0.4) = 2 within ALBEDO_RATIO_TOL (torch and GLSL)."""
    t = (_student_torch(path, white, 0.8) / _student_torch(path, white, 0.4)).numpy()
    g = _glsl_mean(renderer, "neural", weights=str(path)) / _glsl_mean(
        renderer, "neural", weights=str(path), albedo=0.4)
    for ratio, side in ((t, "torch"), (g, "glsl")):
        assert np.all(np.abs(ratio / 2.0 - 1.0) < ALBEDO_RATIO_TOL[side]), (t, g)


@pytest.mark.parametrize("path", STUDENTS, ids=lambda p: p.stem)
def test_student_is_linear_in_environment_intensity(renderer, path):
    """x2 intensity = x2 radiance, exactly: the student scales E and P, never feeds them to the
    MLP (GLSL: float32 rounding only)."""
    one = _glsl_mean(renderer, "neural", weights=str(path))
    two = _glsl_mean(renderer, "neural", weights=str(path), intensity=2.0)
    assert np.all(np.abs(two / one / 2.0 - 1.0) < STUDENT_LINEARITY_TOL), two / one


# ---- the teacher: torch and GLSL -------------------------------------------------------------------

@pytest.mark.parametrize("path", TEACHERS, ids=lambda p: p.stem)
def test_teacher_white_furnace(renderer, white, path):
    """0.8 per channel within TEACHER_FURNACE_TOL: the torch estimator (cosine sampling, 256
    samples at 512 points: MC noise < 0.5 %) and the GLSL pass (256 env samples)."""
    t = _teacher_torch(path, white).numpy()
    g = _glsl_mean(renderer, "neural_teacher", teacher_weights=str(path), samples=256,
                   sampling="env")
    for m in (t, g):
        assert np.all(np.abs(m / 0.8 - 1.0) < TEACHER_FURNACE_TOL), (t, g)


@pytest.mark.parametrize("path", TEACHERS, ids=lambda p: p.stem)
def test_teacher_albedo_scaling(white, path):
    ratio = (_teacher_torch(path, white, 0.8) / _teacher_torch(path, white, 0.4)).numpy()
    assert np.all(np.abs(ratio / 2.0 - 1.0) < TEACHER_ALBEDO_RATIO_TOL), ratio


@pytest.mark.parametrize("path", TEACHERS, ids=lambda p: p.stem)
def test_teacher_is_linear_in_environment_intensity(renderer, white, path):
    """rho L_in / p with L_in multiplied out. With log(1 + L_in) also an input (thesis eq. 4.2,
    files without ``"light_input": false``) doubling the light is exact only up to how rho depends
    on that feature (TEACHER_LINEARITY_TOL, torch); without it, exactly (torch and GLSL)."""
    from viewer.neural import load_network

    one = _teacher_torch(path, white)
    two = _teacher_torch(path, white.with_light(2.0, white.rotation))
    ratios = [(two / one).numpy()]
    tol = TEACHER_LINEARITY_TOL
    if not load_network(path, "teacher").light_input:
        tol = LIGHTLESS_TEACHER_LINEARITY_TOL
        kw = dict(teacher_weights=str(path), samples=64, sampling="env")
        ratios.append(_glsl_mean(renderer, "neural_teacher", intensity=2.0, **kw)
                      / _glsl_mean(renderer, "neural_teacher", **kw))
    for ratio in ratios:
        assert np.all(np.abs(ratio / 2.0 - 1.0) < tol), ratios


def test_lambertian_estimator_is_unbiased(white):
    """The teacher's Monte-Carlo estimator itself (rho L_in / p, averaged) with rho = albedo / pi
    returns 0.8 under every sampling strategy: the energy scale of the pipeline is not in the
    estimator (measured 0.8013 uniform, 0.8000 cosine, 0.7991 env at 1024 samples)."""
    from learned.neural.teacher import Teacher

    class Lambert(Teacher):
        def contribution(self, mat, n, v, l, li):
            return mat[..., :3] / math.pi * li * (n * l).sum(-1, keepdim=True).clamp_min(0.0)

    gb, v = _sphere_gbuffer(256)
    u = torch.rand(256, 1024, 2, generator=torch.Generator().manual_seed(2))
    for strategy in ("uniform", "cosine", "env"):
        m = Lambert(8, 0)(gb, v, white, u, strategy).mean(0)
        assert torch.allclose(m, torch.full((3,), 0.8), rtol=5e-3), (strategy, m)


# ---- the oracles can fail: a deliberately wrong network fails each one -----------------------------

def _oracle_student(**kw):
    from learned.neural.student import Student

    torch.manual_seed(0)
    return Student(**({"hidden": (8,), "output": "split3"} | kw)).eval()


@pytest.mark.parametrize("path", [STUDENTS[0]], ids=lambda p: p.stem)
def test_shipped_student_and_teacher_pass_the_oracle_module(white, path):
    """learned.protocol.oracles (the oracles as functions, BOUNDS) on the shipped files."""
    from learned.protocol.oracles import check, student_probe, teacher_probe

    s = check(student_probe(load_model(path, "student"), white), "student")
    t = check(teacher_probe(load_model(TEACHERS[0], "teacher"), white), "teacher")
    assert all(r["passed"] for r in (*s.values(), *t.values())), (s, t)


def test_a_student_that_brightens_fails_the_white_furnace(white):
    """k_d = sigmoid(2) = 0.88 -> S k_d = 1.76: the furnace at ~1.4 for 0.8."""
    from learned.protocol.oracles import check, student_probe

    bright = _oracle_student()
    with torch.no_grad():
        bright.layers[-1].bias[0] = 2.0
    res = check(student_probe(bright, white), "student")
    assert not res["furnace"]["passed"] and res["furnace"]["error"] > 0.5, res
    assert res["albedo"]["passed"] and res["linearity"]["passed"]  # only the furnace fails


def test_a_student_whose_diffuse_factor_reads_the_albedo_fails_albedo_scaling(white):
    """k_d driven by albedo.r (hidden = relu(10 - 20 a): 2 at a = 0.4, 0 at 0.8) breaks L ∝ a."""
    from learned.protocol.oracles import check, student_probe

    wrong = _oracle_student()
    with torch.no_grad():
        for p in wrong.parameters():
            p.zero_()
        wrong.layers[0].weight[0, 0] = -20.0
        wrong.layers[0].bias[0] = 10.0
        wrong.layers[-1].weight[0, 0] = 1.0
    res = check(student_probe(wrong, white), "student")
    assert not res["albedo"]["passed"] and res["albedo"]["error"] > 0.2, res


def test_a_network_that_sees_the_light_fails_linearity(white):
    """A teacher with the thesis's log(1 + L_in) input (random weights) is not linear in the
    light: the linearity bound of the teachers without it (1e-5) catches it; so does a student
    probe whose network output is squared in the light."""
    from learned.neural.teacher import Teacher
    from learned.protocol.oracles import (
        BOUNDS,
        check,
        linearity_error,
        student_probe,
        teacher_probe,
    )

    torch.manual_seed(3)
    res = check(teacher_probe(Teacher(hidden=8, num_freqs=0, light_input=True), white, 32),
                "teacher")
    assert not res["linearity"]["passed"], res
    probe = student_probe(_oracle_student(), white)
    assert linearity_error(lambda a, i=1.0: probe(a, i) ** 2) > BOUNDS["student"]["linearity"]
