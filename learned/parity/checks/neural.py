"""The generated neural-shader GLSL against the torch networks on the same weights: the MLP alone
(every weight storage) and the ``neural`` / ``neural_teacher`` lighting passes."""
from __future__ import annotations

import dataclasses
import shutil
from pathlib import Path

import numpy as np
import torch

from learned.export import load_model
from learned.neural.lighting import lighting_from_gl
from learned.twins.neural import shade_neural
from viewer.gl.kernels import run_kernel
from viewer.models import sample_count
from viewer.neural import (
    MODEL_KINDS,
    STUDENT_KERNEL,
    STUDENT_KERNEL_GROUP,
    WEIGHT_STORAGES,
    NeuralWeights,
    default_weights,
    load_network,
    required_settings,
)
from viewer.passes.shade import shade_defines
from viewer.renderer import Renderer
from viewer.scene.description import scene_from_dict

from ..results import compare, compare_envelope, device_filter_bits
from . import collector
from .models import PARITY_SCENE, gl_gbuffer, gl_texture, one_renderer

NETWORK_ATOL = 1e-4  # the float32 bound for outputs in [0, 1]


# whole passes: the texture lookups dominate, as for the classical models (learned/twins/deferred)
MODEL_ATOL = 1e-4


MODEL_RTOL = 5e-4


# the teacher pass is Monte Carlo: identical sample sequences on both sides, but directions that
# agree to ~1e-7 hit the sky's 2000x sun disc through bilinear lookups divided by pdfs (the same
# envelope as ggx_mc, learned/twins/deferred.py). Measured on llvmpipe: max abs 0.023 (uniform
# sampling, radiance to ~40), max rel 8e-4.
TEACHER_ATOL = 1e-3


TEACHER_RTOL = 2e-3


def eval_student_weights(programs, net, x: np.ndarray, storage: str = "const") -> np.ndarray:
    """GL ``neural_student_weights`` of the generated code of ``net`` for weight ``storage``
    (``viewer.neural.WEIGHT_STORAGES``) at ``x [n, 12]`` (every student input,
    :func:`student_inputs`) -> ``[n, 6]`` (``k_0``, ``k_1``; a ``pbr3`` student's ``k_1`` is 0)."""
    code = net.code(storage)
    name = f"<kernel:neural_student:{net.checkpoint[:12]}>"
    count = x.shape[0]
    weights = NeuralWeights(programs.ctx, code)
    try:
        out = run_kernel(programs, name, x.T, 6, lambda prog: weights.bind(prog, 0),
                         virtual={name: STUDENT_KERNEL, net.include_name: code.glsl},
                         group=STUDENT_KERNEL_GROUP, count=count)  # planar in and out: [k][n]
    finally:
        weights.release()
    return out.reshape(6, count).T.copy()


def student_inputs(n: int, seed: int = 0) -> np.ndarray:
    """Random student inputs ``[n, 12]`` (every input, ``viewer.neural.STUDENT_ALL_INPUTS``)
    over the whole domain, plus the corners of [0, 1]^8 (dfg, vis and env_below inputs 0 and 1
    alternating)."""
    rng = np.random.default_rng(seed)
    x = rng.uniform(0.0, 1.0, size=(n, 12))
    corners = np.array([[(k >> b) & 1 for b in range(8)]
                        + [k & 1, (k >> 1) & 1, (k >> 2) & 1, (k >> 3) & 1]
                        for k in range(256)], np.float64)
    return np.concatenate([x, corners]).astype(np.float32)


def check_network(programs, weights=None, storage: str = "const"):
    """The generated student network with weights read from ``storage`` vs ``Student.weights``
    (named ``neural:network`` for the default ``const``, ``neural:network:<storage>`` else)."""
    path = weights or default_weights("student")
    net = load_network(path, "student")
    model = load_model(path, "student")
    x = student_inputs(4096)
    glsl = eval_student_weights(programs, net, x, storage)
    with torch.no_grad():
        ref = model.weights(torch.from_numpy(x)).numpy()
    # a pbr3 student writes 3 factors, then zeros (viewer.neural.STUDENT_KERNEL)
    ref = np.concatenate([ref, np.zeros((ref.shape[0], 6 - ref.shape[1]), np.float32)], 1)
    name = "neural:network" + ("" if storage == "const" else f":{storage}")
    return compare(name, glsl, ref, NETWORK_ATOL, 0.0, kind="pass",
                   measured="max abs 1.2e-7 (shipped pbr3, every storage), 1.2e-7 (free6)",
                   envelope="first-order, shipped 8-16-16-3 student on these inputs: dots of "
                            "8/16 terms in any order with FMA ((k + 1) 2^-24 sum|w x|), relu "
                            "exact, sigmoid via exp ((3 + 2|x|) ulp) and / (2.5 ulp): <= 2.4e-6 "
                            "both sides; atol 1e-4 is the issue's float32 bound (40x headroom); "
                            "const/ubo/texture hold the exact float32 weights")


def check_model(programs, model: str, variant: dict, weights=None, label: str = "",
                environment: dict | None = None, renderer=None):
    """GL lighting pass of ``model`` on ``weights`` (default: the shipped file) vs its torch twin
    :func:`learned.twins.neural.shade_neural`; named ``model:<model>[:<variant>][:<label>]``.
    ``environment``: the scene's ``[environment]`` table instead of the parity scene's;
    ``renderer``: a check's :func:`~.models.one_renderer` (default: one for this frame alone)."""
    if renderer is None:
        with one_renderer(programs) as own:
            return check_model(programs, model, variant, weights, label, environment, own)
    kind = MODEL_KINDS[model]
    path = weights or default_weights(kind)
    key = "weights" if kind == "student" else "teacher_weights"
    table = dict(PARITY_SCENE, environment=environment) if environment else PARITY_SCENE
    scene = scene_from_dict(table).with_render(shadows=False, model=model,
                                               **{key: str(path)}, **variant)
    scene = dataclasses.replace(scene, render=required_settings(scene.render))
    net_model = load_model(path, kind)
    targets = renderer.draw(scene)
    gb = gl_gbuffer(targets)
    # a student with a learned indirect factor runs the indirect pass after its lighting
    # pass: the lighting pass's output is the direct target (check_indirect_factor: the rest)
    glsl = gl_texture(targets.direct if targets.indirect_factor is not None
                      else targets.radiance)
    # a student whose base shades the environment's sun: the pass ran with SUN_LIGHT and the
    # IBL without the sun (Renderer.specialization)
    defines = dict(shade_defines(model, scene.render))
    if targets.variant.defines.get("SUN_LIGHT", 0):
        defines["SUN_LIGHT"] = 1
    if targets.variant.defines.get("ENV_LIGHTS", 0):  # the environment's other lights
        defines["ENV_LIGHTS"] = targets.variant.defines["ENV_LIGHTS"]
    lighting = lighting_from_gl(renderer, scene.environment,
                                sun=bool(defines.get("SUN_LIGHT", 0)))
    ssao = None
    if scene.render.ssao.enabled:
        ssao = torch.from_numpy(gl_texture(targets.ssao).copy())
    envelope = {"weight_bits": device_filter_bits(programs)}
    grad = torch.enable_grad() if model == "neural" else torch.no_grad()
    with grad:  # the student's envelope differentiates through the network to its lookups
        ref = shade_neural(model, net_model, gb, targets.camera, lighting, defines,
                           (0, sample_count(scene.render)), scene.render.mc.seed,
                           envelope=envelope, ssao=ssao).detach().numpy()
    name = f"model:{model}" + ("" if not variant else ":" + ",".join(
        f"{k}={v}" for k, v in variant.items())) + (f":{label}" if label else "")
    if model == "neural_teacher":
        return compare(name, glsl, ref, TEACHER_ATOL, TEACHER_RTOL, kind="model",
                       measured="max abs 0.023, max rel 8e-4 (uniform sampling, sun texels)",
                       envelope="not derived: Monte Carlo as ggx_mc (per-sample radiance "
                                "lookups divided by pdfs amplify ~1e-7 direction differences on "
                                "the sun's texels); measured on llvmpipe, unverified on 8-bit "
                                "GPU filtering")
    bound = MODEL_ATOL + MODEL_RTOL * np.abs(ref)
    bound[..., :3] += envelope["bound"].numpy()
    return compare_envelope(
        name, glsl, ref, bound, kind="model",
        measured="max abs 5.7e-4 at max rel 7.6e-5 (shipped pbr3 weights, bright sky texels); "
                 "1.0e-3 at max rel 7.6e-5 (random weights); 0.025 at max rel 7.6e-5 in the "
                 "analytic sun's highlights (students with \"sun\": true, SUN_LIGHT, as "
                 "ggx_split_sum)",
        envelope=f"per pixel: atol {MODEL_ATOL:g} + rtol {MODEL_RTOL:g} (the network <= 2.4e-6, "
                 "neural_student_radiance 5e-7 rel, SH arithmetic) + the background, prefiltered "
                 "and DFG lookups' sample_trilinear_envelope (measured filter bits) times |d "
                 "radiance / d lookup| through the network by autograd")


# the factor is S k = 2 sigmoid: twice the network's bound
FACTOR_ATOL = 2 * NETWORK_ATOL


def indirect_student(programs, weights=None):
    """``weights`` (default: the shipped student) when they learn an indirect factor, else a
    random ``split3`` student with the factor and a perturbed last layer (seed 7), exported to a
    temporary file: the path."""
    import tempfile

    from learned.export import export
    from learned.neural.student import Student

    path = Path(weights or default_weights("student"))
    if load_network(path, "student").indirect != "none":
        return path
    torch.manual_seed(7)
    s = Student(hidden=(8, 8), features="vis", output="split3", indirect="factor")
    with torch.no_grad():
        for last in (s.layers[-1], s.indirect_layers[-1]):
            last.weight.normal_(0.0, 2.0)
            last.bias.normal_(0.0, 0.5)
    path = Path(tempfile.mkdtemp(prefix="relight-parity-")) / "indirect.safetensors"
    export(s, path)
    return path


def check_indirect_factor(programs, weights=None) -> list:
    """A student with a learned indirect factor, past its lighting pass (``model:neural``
    compares that): the pass's second output, the factor, against ``Student.indirect_factor``
    (``neural:indirect_factor``), and the indirect pass scaling its one-bounce light by it
    (``model:neural:indirect``: GL frame vs :func:`learned.twins.ssao.ssao_pass` with the GL
    direct light and factor, the robust comparison of ``ssao:indirect``)."""
    path = indirect_student(programs, weights)
    try:
        return _check_indirect_factor(programs, path)
    finally:
        if path != Path(weights or default_weights("student")):  # a temporary random student
            shutil.rmtree(path.parent, ignore_errors=True)


def _check_indirect_factor(programs, path) -> list:
    from learned.twins.ssao import ssao_pass

    from .ssao import robust_compare

    scene = scene_from_dict(PARITY_SCENE).with_render(
        shadows=False, model="neural", weights=str(path),
        indirect_blur=False)  # the factor on the pass's own composite (the blur: ssao:denoise)
    scene = dataclasses.replace(scene, render=required_settings(scene.render))
    assert scene.render.ssao.indirect, "the student's indirect pass is not forced on"
    net_model = load_model(path, "student")
    renderer = Renderer(ctx=programs.ctx)
    try:
        targets = renderer.draw(scene)
        gb = gl_gbuffer(targets)
        factor_gl = gl_texture(targets.indirect_factor)[..., 0]
        direct_gl = gl_texture(targets.direct)
        final_gl = gl_texture(targets.radiance)
        lighting = lighting_from_gl(renderer, scene.environment)
        ssao = torch.from_numpy(gl_texture(targets.ssao).copy())
        outputs = {}
        with torch.no_grad():
            shade_neural("neural", net_model, gb, targets.camera, lighting,
                         shade_defines("neural", scene.render), ssao=ssao, outputs=outputs)
            s = scene.render
            final = ssao_pass(gb, targets.camera, s.ssao.rays, s.ssao.steps, s.ssao.radius,
                              s.ssao.thickness, s.mc.seed, direct=torch.from_numpy(direct_gl),
                              factor=torch.from_numpy(factor_gl)).numpy()
    finally:
        renderer.release()
    factor = compare("neural:indirect_factor", factor_gl, outputs["indirect_factor"].numpy(),
                     FACTOR_ATOL, 0.0, kind="pass",
                     measured="max abs 2.4e-7 (random split3 student with the factor)",
                     envelope="2 x the network's (NETWORK_ATOL: the issue's float32 bound on "
                              "outputs in [0, 1]); S = 2 is exact; the ao and vis inputs come "
                              "from the same GL SSAO target on both sides")
    return [factor, robust_compare("model:neural:indirect", final_gl, final,
                                   float(np.abs(final).max()))]


def other_teacher(weights=None) -> Path:
    """A teacher of the other input form than ``weights`` (default: the shipped teacher): a random
    one (hidden 8, 1 Fourier frequency, seed 11) with ``light_input`` flipped, exported to a
    temporary file (the caller removes its folder), so the parity checks generate and compare
    both forms of ``neural_teacher_contribution`` (with and without the log(1 + L_in) inputs)
    whichever form is shipped."""
    import tempfile

    from learned.export import export
    from learned.neural.teacher import Teacher

    light = load_network(weights or default_weights("teacher"), "teacher").light_input
    torch.manual_seed(11)
    t = Teacher(hidden=8, num_freqs=1, light_input=not light)
    path = Path(tempfile.mkdtemp(prefix="relight-parity-")) / "teacher.safetensors"
    export(t, path)
    return path


def check_teachers(programs, weights=None) -> list:
    """``model:neural_teacher`` on ``weights`` (default: the shipped teacher) with 8 samples of
    ``env`` and of ``uniform`` sampling (the latter over a transparent background from a UBO),
    and on a random teacher of the other input form (:func:`other_teacher`, labelled
    ``light_input=true|false``)."""
    other = other_teacher(weights)
    try:
        with one_renderer(programs) as r:
            out = [check_model(programs, "neural_teacher", v, weights, renderer=r)
                   for v in ({"samples": 8, "sampling": "env"},
                             {"samples": 8, "sampling": "uniform", "background": "transparent",
                              "neural_storage": "ubo"})]
            light = load_network(other, "teacher").light_input
            out.append(check_model(programs, "neural_teacher", {"samples": 8, "sampling": "env"},
                                   other, label=f"light_input={str(light).lower()}", renderer=r))
    finally:
        shutil.rmtree(other.parent, ignore_errors=True)
    return out


def checks() -> dict:
    """This module's pass checks: name -> (model or None, check(programs) -> results).
    ``model:neural:<storage>`` and ``model:neural_teacher`` also take ``weights=`` (a weights
    file of their network's kind; default: the shipped one), so the suite can run them on small
    networks (tests/shaders/test_library_parity.py)."""
    found, register_pass_check = collector()
    # one check per weight storage (``neural:network[:<storage>]``, ``model:neural[:<storage>]``),
    # so a run can leave one storage out by name (tests/shaders/test_float_paths.py: ubo)
    for storage in WEIGHT_STORAGES:
        suffix = "" if storage == "const" else f":{storage}"
        register_pass_check("neural:network" + suffix, model="neural")(
            lambda programs, storage=storage: [check_network(programs, storage=storage)])
        if storage != "const":
            register_pass_check("model:neural" + suffix, model="neural")(
                lambda programs, weights=None, storage=storage: [
                    check_model(programs, "neural", {"neural_storage": storage}, weights)])
    def check_neural(programs):
        with one_renderer(programs) as r:
            return [check_model(programs, "neural", v, renderer=r)
                    for v in ({}, {"ao": False, "background": "transparent"})]

    register_pass_check("model:neural", model="neural")(
        lambda programs: check_neural(programs) + check_indirect_factor(programs))
    register_pass_check("model:neural_teacher", model="neural_teacher")(check_teachers)
    return found
