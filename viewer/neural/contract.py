"""The neural networks' input/output contract (the ``architecture`` of a weights file): the
student's input sets, output forms and switches, the teacher's inputs, the networks each kind must
have (:func:`expected_networks`), the ``architecture`` and ``encoding`` metadata written for them
(:func:`architecture`, :func:`encoding`) and the check of a file's architecture
(:func:`_required_networks`). The file around it: :mod:`viewer.neural.format`."""
from __future__ import annotations

STUDENT_INPUTS = ("albedo.r", "albedo.g", "albedo.b", "roughness", "metallic", "specular", "ao",
                  "NoV")
# every student input, in the order of the generated code's arguments and of the parity kernel's
# planar rows; "vis" is the screen-space visibility of the environment's light (the g channel of
# passes/ssao.frag with SSAO_ENV_VIS), read by students that see visibility; "env_below" the
# environment's irradiance from below over that from above, one value a frame (u_env_below,
# viewer.environment.irradiance.env_below)
STUDENT_ALL_INPUTS = STUDENT_INPUTS + ("dfg.a", "dfg.b", "vis", "env_below")
# student input sets (architecture "features"; twin: learned.neural.student.FEATURE_INPUTS), each
# a subsequence of STUDENT_ALL_INPUTS. "ssao": base's inputs but ao, which (the material AO times
# the SSAO pass's occlusion O(x): the renderer runs SSAO for it, without S(x)) enters only as the
# occlusion factor on the diffuse light, as every classical model applies it: the network reads
# no screen-space evidence, whose noise and stretch the students that read it turned into
# speckle and invented shadows on real assets (issue 38)
STUDENT_FEATURES = {"base": STUDENT_INPUTS, "dfg": STUDENT_INPUTS + ("dfg.a", "dfg.b"),
                    "ssao": tuple(i for i in STUDENT_INPUTS if i != "ao"),
                    # "ssao-env": "ssao" + how bright the environment is from below (one value a
                    # frame): the bounce's gain depends on it (issue 38, lobby and sunless skies)
                    "ssao-env": tuple(i for i in STUDENT_INPUTS if i != "ao") + ("env_below",),
                    "vis": STUDENT_INPUTS + ("vis",),
                    "dfg-vis": STUDENT_INPUTS + ("dfg.a", "dfg.b", "vis")}
# the input sets whose ao input is the material AO times the SSAO pass's O(x): the renderer runs
# SSAO for them whatever [render] ssao says (learned.neural.student.Student.reads_occlusion)
STUDENT_SSAO_FEATURES = ("ssao", "ssao-env", "vis", "dfg-vis")
# student output forms (architecture "output"; twin: learned.neural.student.OUTPUTS) -> network
# outputs. The generated GLSL defines NEURAL_STUDENT_PBR (0 free6, 1 pbr3); shade_neural.frag
# combines the factors with the lighting by lib/neural.glsl's neural_student_radiance[_pbr].
STUDENT_OUTPUTS = {"free6": 6, "pbr3": 3, "split3": 3}
# what a student file without "features" / "output" (written before they existed) holds
DEFAULT_FEATURES = "base"
DEFAULT_OUTPUT = "free6"
# how a student uses its ao input (architecture "occlusion"): "input" only as an MLP input (files
# written before the key existed: the network had to learn the product, and learned the training
# set's mean occlusion instead, issue 14), "factor" also multiplies the diffuse factor(s) by it
STUDENT_OCCLUSION = ("input", "factor")
DEFAULT_OCCLUSION = "input"
# whether a student learns a factor on the screen-space indirect light (architecture "indirect";
# twin: learned.neural.student.INDIRECTS): "factor" = a second network "indirect" on the same
# inputs, INDIRECT_HIDDEN relu units -> one sigmoid output k, L = L_dir + 2 k L_ind
# (passes/ssao.frag), k = 0.5 the classical one-bounce term; files without the key (written
# before) have none. A separate network measured better than a 4th output of the student's own
# (README "Against truth": paired over 3 seeds, +0.08 dB on a held-out environment, +0.17 on
# held-out scene kinds)
STUDENT_INDIRECT = ("none", "factor")
DEFAULT_INDIRECT = "none"
INDIRECT_HIDDEN = 16  # hidden width of the "indirect" network (twin: learned.neural.student)
# whether a split3 student's base shades the environment's sun analytically (architecture "sun";
# twin: learned.neural.student.Student(sun=)): true = the base is ggx_split_sum with SUN_LIGHT (the
# IBL without the sun + the sun as a light, both with the student's corrections); files without
# the key (written before) are false, the split-sum of the whole environment
DEFAULT_SUN = False
# whether a split3 student's base has ggx_split_sum's multiple-scattering compensation
# (architecture "multiscatter"; NEURAL_STUDENT_MULTISCATTER); files without the key: single scattering
DEFAULT_MULTISCATTER = False
TEACHER_INPUTS = ("albedo.r", "albedo.g", "albedo.b", "n.x", "n.y", "n.z", "roughness", "metallic",
                  "specular", "l.x", "l.y", "l.z", "NoL", "log_Lin.r", "log_Lin.g", "log_Lin.b")
# whether a teacher sees the light's radiance log(1 + L_i(l) <n.l>) (architecture "light_input";
# twin: learned.neural.teacher.Teacher(light_input=)): true = the thesis's inputs (eq. 4.2; files
# written before the key existed), false = the first 13 only, rho independent of the light
DEFAULT_LIGHT_INPUT = True


def teacher_inputs(light_input: bool = DEFAULT_LIGHT_INPUT) -> tuple[str, ...]:
    """The teacher's inputs in order: :data:`TEACHER_INPUTS`, without the three log(1 + L_in)
    ones when ``light_input`` is false."""
    return TEACHER_INPUTS if light_input else TEACHER_INPUTS[:-3]


def expected_networks(kind: str, num_freqs: int, hidden, features: str = DEFAULT_FEATURES,
                      output: str = DEFAULT_OUTPUT, indirect: str = DEFAULT_INDIRECT,
                      light_input: bool = DEFAULT_LIGHT_INPUT) -> dict[str, dict]:
    """The architecture every file of ``kind`` must have (sizes from its hidden widths and, for a
    student, its input ``features``, ``output`` form and ``indirect`` factor; for a teacher,
    whether it sees the light, ``light_input``)."""
    enc = lambda d: d * (1 + 2 * num_freqs)  # noqa: E731
    if kind == "student":
        n_in = enc(len(STUDENT_FEATURES[features]))
        sizes = [n_in, *[int(h) for h in hidden], STUDENT_OUTPUTS[output]]
        nets = {"mlp": {"sizes": sizes,
                        "activations": ["relu"] * (len(sizes) - 2) + ["sigmoid"]}}
        if indirect == "factor":
            nets["indirect"] = {"sizes": [n_in, INDIRECT_HIDDEN, 1],
                                "activations": ["relu", "sigmoid"]}
        return nets
    if kind == "teacher":
        h = int(hidden)
        return {"diffuse": {"sizes": [enc(len(teacher_inputs(light_input))), h, h],
                            "activations": ["relu", "relu"]},
                "specular": {"sizes": [h + 6, h, 3], "activations": ["relu", "softplus"]}}
    raise ValueError(kind)


def architecture(kind: str, num_freqs: int, hidden, features: str | None = None,
                 output: str | None = None, occlusion: str | None = None,
                 indirect: str | None = None, sun: bool = False, multiscatter: bool = False,
                 light_input: bool = DEFAULT_LIGHT_INPUT) -> dict:
    """The ``architecture`` metadata of a ``kind`` network (students record ``features``,
    ``output`` and ``occlusion``, ``None`` for :data:`DEFAULT_FEATURES` / :data:`DEFAULT_OUTPUT` /
    :data:`DEFAULT_OCCLUSION`, ``indirect`` when it is not ``none``, ``sun`` and ``multiscatter``
    when true, so
    files of students without them stay as they were written before they existed; teachers
    record ``light_input`` only when it is false, for the same reason)."""
    features = features or DEFAULT_FEATURES
    output = output or DEFAULT_OUTPUT
    indirect = indirect or DEFAULT_INDIRECT
    light_input = bool(light_input) if kind == "teacher" else DEFAULT_LIGHT_INPUT
    arch = {"networks": expected_networks(kind, num_freqs, hidden, features, output, indirect,
                                          light_input),
            "hidden": hidden, "num_freqs": num_freqs,
            "inputs": list(STUDENT_FEATURES[features] if kind == "student"
                           else teacher_inputs(light_input))}
    if kind == "student":
        arch["features"] = features
        arch["output"] = output
        arch["occlusion"] = occlusion or DEFAULT_OCCLUSION
        if indirect != DEFAULT_INDIRECT:
            arch["indirect"] = indirect
        if sun:
            arch["sun"] = True
        if multiscatter:
            arch["multiscatter"] = True
    elif not light_input:
        arch["light_input"] = False
    return arch


def encoding(num_freqs: int) -> dict:
    """The ``encoding`` metadata: the Fourier features of ``learned/neural/encoding.py``."""
    return {"type": "fourier", "num_freqs": num_freqs, "frequencies": "pi * 2^k",
            "order": "x, (sin, cos) per k"}


def _required_networks(kind: str, arch: dict) -> dict[str, dict]:
    """The networks ``arch`` must describe; raises KeyError/ValueError/TypeError when it is
    malformed."""
    num_freqs = int(arch["num_freqs"])
    hidden = arch["hidden"]
    if not 0 <= num_freqs <= 16:
        raise ValueError(f"num_freqs {num_freqs}")
    features = arch.get("features", DEFAULT_FEATURES) if kind == "student" else DEFAULT_FEATURES
    if features not in STUDENT_FEATURES:
        raise ValueError(f"student features {features!r} (known: {', '.join(STUDENT_FEATURES)})")
    if kind == "student" and "inputs" in arch and \
            tuple(arch["inputs"]) != STUDENT_FEATURES[features]:
        raise ValueError(f"inputs {arch['inputs']} are not the {features!r} student inputs")
    output = arch.get("output", DEFAULT_OUTPUT) if kind == "student" else DEFAULT_OUTPUT
    if output not in STUDENT_OUTPUTS:
        raise ValueError(f"student output form {output!r} (known: {', '.join(STUDENT_OUTPUTS)})")
    if kind == "student" and arch.get("occlusion", DEFAULT_OCCLUSION) not in STUDENT_OCCLUSION:
        raise ValueError(f"student occlusion {arch['occlusion']!r} "
                         f"(known: {', '.join(STUDENT_OCCLUSION)})")
    if kind == "student" and features in ("ssao", "ssao-env") and \
            arch.get("occlusion", DEFAULT_OCCLUSION) != "factor":
        raise ValueError("student features 'ssao' apply ao only as a factor: occlusion must be "
                         "'factor'")
    indirect = arch.get("indirect", DEFAULT_INDIRECT) if kind == "student" else DEFAULT_INDIRECT
    if indirect not in STUDENT_INDIRECT:
        raise ValueError(f"student indirect {indirect!r} (known: {', '.join(STUDENT_INDIRECT)})")
    if indirect != DEFAULT_INDIRECT and STUDENT_OUTPUTS[output] != 3:
        raise ValueError(f"student indirect {indirect!r} needs a three-factor output form "
                         f"(pbr3 or split3), not {output!r}")
    for key, default in (("sun", DEFAULT_SUN), ("multiscatter", DEFAULT_MULTISCATTER)):
        # the split3 base's switches: booleans, only for that output form
        value = arch.get(key, default) if kind == "student" else default
        if not isinstance(value, bool):
            raise ValueError(f"student {key} {value!r} (true | false)")
        if value and output != "split3":
            raise ValueError(f"student {key} needs the split3 output form, not {output!r}")
    light_input = arch.get("light_input", DEFAULT_LIGHT_INPUT) if kind == "teacher" \
        else DEFAULT_LIGHT_INPUT
    if not isinstance(light_input, bool):
        raise ValueError(f"teacher light_input {light_input!r} (true | false)")
    if kind == "teacher" and "inputs" in arch and \
            tuple(arch["inputs"]) != teacher_inputs(light_input):
        raise ValueError(f"inputs {arch['inputs']} are not the teacher inputs with "
                         f"light_input {str(light_input).lower()}")
    return expected_networks(kind, num_freqs, hidden, features, output, indirect, light_input)
