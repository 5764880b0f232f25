"""The neural shader: export/load round trip, GLSL parity on random weights, bad weights files."""
import json
import struct

import numpy as np
import pytest
import torch

from learned.export import export, load_model
from learned.neural.student import Student
from learned.neural.teacher import Teacher
from learned.parity.checks import neural as tn
from viewer.neural import TEACHER_INPUTS, WEIGHT_STORAGES, WeightsError, load_network


@pytest.fixture(scope="module")
def weights(tmp_path_factory):
    d = tmp_path_factory.mktemp("weights")
    torch.manual_seed(1)
    s = Student(hidden=(16, 32), num_freqs=2)
    t = Teacher(hidden=16, num_freqs=1)
    with torch.no_grad():  # move outputs away from the sigmoid's flat ends
        s.layers[-1].weight.mul_(3.0)
    export(s, d / "s.safetensors", {"note": "test"})
    export(t, d / "t.safetensors")
    return d / "s.safetensors", d / "t.safetensors"


def test_round_trip_and_generated_header(weights):
    s_path, _ = weights
    net = load_network(s_path, "student")
    model = load_model(s_path)
    assert net.checkpoint == model.checkpoint and net.training == {"note": "test"}
    assert net.glsl.splitlines()[2] == f"// checkpoint sha256:{net.checkpoint}"
    assert "mlp 40-16-32-6" in net.glsl  # 8 inputs x (1 + 2 x 2 frequencies)
    assert net.macs() == model.macs_per_pixel() == 40 * 16 + 16 * 32 + 32 * 6


def test_student_network_parity(programs, weights):
    r = tn.check_network(programs, weights[0])
    assert r.passed and r.max_abs <= 1e-4, r


@pytest.mark.parametrize("storage", WEIGHT_STORAGES)
def test_every_weight_storage_matches_torch(programs, weights, storage):
    """Baked constants, uniform block and texture give the torch student's outputs (kernel and
    lighting pass) and the teacher's (pass); measured max abs 1.0e-7 for every storage."""
    s_path, t_path = weights
    code = load_network(s_path).code(storage)
    assert code.binding == storage and f"// weight storage {storage}" in code.glsl
    assert (code.data is None) == (storage == "const")
    r = tn.check_network(programs, s_path, storage)
    assert r.passed and r.max_abs <= 1e-4, r
    r = tn.check_model(programs, "neural", {"neural_storage": storage}, s_path)
    assert r.passed, r
    r = tn.check_model(programs, "neural_teacher",
                       {"samples": 4, "sampling": "uniform", "neural_storage": storage}, t_path)
    assert r.passed, r


def test_weights_over_16_kib_go_to_a_storage_block(programs, weights, monkeypatch):
    """``ubo`` storage above the 16 KiB minimum uniform-block size is a read-only SSBO (a small
    limit stands in for a big network: a real one compiles for minutes on llvmpipe)."""
    import viewer.neural as vn

    net = load_network(weights[0], "student")
    assert net.code("ubo").binding == "ubo"
    monkeypatch.setattr(vn.glsl, "UBO_MIN_MAX_BYTES", 256)
    code = vn.generate_glsl(net, "ubo")
    assert code.binding == "ssbo" and "readonly buffer" in code.glsl
    monkeypatch.setitem(net._code, "ubo", code)
    r = tn.check_network(programs, weights[0], "ubo")
    assert r.passed and r.max_abs <= 1e-4, r


def test_unknown_weight_storage_is_a_scene_error():
    from viewer.errors import SceneError
    from viewer.scene import scene_from_dict

    with pytest.raises(SceneError, match="render.neural_storage = 'ssbo' is not one of"):
        scene_from_dict({"render": {"model": "neural", "neural_storage": "ssbo"}})


def _student_file(tmp_path_factory, name: str, seed: int, **design):
    """A random student with ``design`` exported to a temporary weights file; its last layer is
    scaled by 3 to move the outputs away from the sigmoid's flat ends."""
    d = tmp_path_factory.mktemp(name)
    torch.manual_seed(seed)
    s = Student(hidden=(8, 12), num_freqs=1, **design)
    with torch.no_grad():
        s.layers[-1].weight.mul_(3.0)
    export(s, d / "s.safetensors")
    return d / "s.safetensors"


@pytest.fixture(scope="module")
def dfg_weights(tmp_path_factory):
    return _student_file(tmp_path_factory, "dfg", 2, features="dfg")


def test_dfg_student_round_trip_and_parity(programs, dfg_weights):
    net = load_network(dfg_weights, "student")
    assert net.features == "dfg" and "mlp 30-8-12-6" in net.glsl  # 10 inputs x (1 + 2)
    assert "#define NEURAL_STUDENT_DFG 1" in net.glsl
    assert load_model(dfg_weights).features == "dfg"
    r = tn.check_network(programs, dfg_weights)
    assert r.passed and r.max_abs <= 1e-4, r
    r = tn.check_model(programs, "neural", {}, dfg_weights)
    assert r.passed, r


@pytest.fixture(scope="module")
def pbr_weights(tmp_path_factory):
    return _student_file(tmp_path_factory, "pbr", 3, features="dfg", output="pbr3")


def test_pbr_student_round_trip_and_parity(programs, pbr_weights):
    net = load_network(pbr_weights, "student")
    assert net.output == "pbr3" and "mlp 30-8-12-3" in net.glsl
    assert "#define NEURAL_STUDENT_PBR 1" in net.glsl
    assert load_model(pbr_weights).output == "pbr3"
    r = tn.check_network(programs, pbr_weights)
    assert r.passed and r.max_abs <= 1e-4, r
    for variant in ({}, {"ao": False, "background": "transparent"}):
        r = tn.check_model(programs, "neural", variant, pbr_weights)
        assert r.passed, r


def test_files_without_output_form_are_free6(tmp_path, dfg_weights):
    """Weights exported before the output form existed (no ``output`` key) load as ``free6``."""
    arch = dict(load_network(dfg_weights).architecture)
    del arch["output"]
    old = _tamper(dfg_weights, tmp_path / "old.safetensors", {"architecture": json.dumps(arch)})
    net = load_network(old, "student")
    assert net.output == "free6" and "#define NEURAL_STUDENT_PBR 0" in net.glsl
    assert load_model(old).output == "free6"


def test_unknown_student_output_form_is_rejected(tmp_path, pbr_weights):
    arch = dict(load_network(pbr_weights).architecture, output="rgb9")
    bad = _tamper(pbr_weights, tmp_path / "o.safetensors", {"architecture": json.dumps(arch)})
    with pytest.raises(WeightsError, match="student output form 'rgb9'"):
        load_network(bad)


def _grey_probe(ctx, environment: str, **render):
    """The grey probe (assets/scenes/bench/grey_probe.toml) under ``environment``: (max tint %
    of learned.evaluate.achromatic_error, radiance [H, W, 4])."""
    from learned.evaluate import achromatic_error
    from relight.bench.scenes import bench_scene
    from viewer.renderer import Renderer

    scene = bench_scene("grey_probe").with_environment(procedural=environment)
    r = Renderer(ctx=ctx)
    try:
        img = r.render(scene.with_render(**render)).radiance
    finally:
        r.release()
    fg = img[..., 3] > 0
    assert fg.sum() > 1000  # spheres and floor cover most of the 64x64 frame
    return achromatic_error(img[..., :3], fg), img


def test_pbr_student_keeps_grey_materials_grey_by_construction(ctx, pbr_weights):
    """Any pbr3 network (here random weights) renders grey materials under an achromatic
    environment grey: the colour comes from the material and the lighting, never the MLP."""
    tint, _ = _grey_probe(ctx, "white", model="neural", weights=str(pbr_weights))
    assert tint < 1e-3, tint  # percent; measured 0 (float32: r = g = b exactly)


def test_shipped_student_renders_grey_materials_grey(ctx):
    """The reported hue shift: with the shipped weights a grey floor and grey spheres must stay
    grey. White environment: max (max - min of rgb) / luminance over the foreground < 2 %
    (shipped split3 and pbr3 students: 0.000 %; the free6 w16x2-dfg shipped before: 9.9 %).
    Studio (warm key, cool fill): the lights themselves tint a physically based render, so the
    bound is derived from them. The achromatic output forms give, per pixel of a grey material,
    L = a D + b S with scalars a, b >= 0, D the SH irradiance E and S the prefiltered radiance P
    (times grey material terms); max - min is subadditive and luminance linear, so the tint of L
    is at most the larger tint of E and P at that pixel (+ 0.01 points of float rounding),
    checked per pixel. A student with the learned indirect factor adds the indirect pass's
    f (1 - m) a mean_k L_dir(p_k), a non-negative combination of the lighting pass's output at
    other pixels: the per-pixel bound holds for that output (FrameTargets.direct), and the final
    image's tint is at most the largest bound over the frame. Measured: the shipped student's
    image tint 9.3 % (26.6 % before the indirect factor; split-sum 22.3 %); a free6 student
    (per-channel factors) is not bound by it."""
    from learned.evaluate import achromatic_error
    from learned.export import load_model
    from learned.neural.lighting import lighting_from_gl, student_features
    from learned.parity.checks.models import gl_gbuffer, gl_texture
    from learned.twins.deferred import view_ray_ws
    from relight.bench.scenes import bench_scene
    from viewer.neural import default_weights
    from viewer.renderer import Renderer

    tint, _ = _grey_probe(ctx, "white", model="neural")
    assert tint < 2.0, tint
    student = load_model(default_weights("student"), "student")
    assert student.output in ("pbr3", "split3")  # the bound below holds for these forms
    scene = bench_scene("grey_probe").with_environment(procedural="studio")
    scene = scene.with_render(model="neural")
    r = Renderer(ctx=ctx)
    try:
        t = r.draw(scene)
        gb = gl_gbuffer(t)
        # the lighting pass's own output (before the indirect pass, when there is one)
        lit = None if t.direct is None else gl_texture(t.direct).reshape(-1, 4)
        lighting = lighting_from_gl(r, scene.environment)
        img = r.render(scene).radiance
    finally:
        r.release()
    h, w = gb["alpha"].shape[:2]
    ys, xs = torch.meshgrid(torch.arange(h) + 0.5, torch.arange(w) + 0.5, indexing="ij")
    basis = torch.tensor(t.camera.basis(), dtype=torch.float32)
    d = view_ray_ws(torch.stack([xs, ys], -1).float(), basis.T,
                    torch.tensor(t.camera.tan_half_fov(), dtype=torch.float32),
                    torch.tensor([float(w), float(h)])).reshape(-1, 3)
    flat = {k: v.reshape(h * w, -1) for k, v in gb.items()}
    with torch.no_grad():
        _, irr, pre = student_features(flat, -d, lighting, flat["ao"][:, 0],
                                       dominant=student.dominant)
    def spread(rgb):  # per pixel: (max - min) / luminance, as learned.evaluate.achromatic_error
        rgb = np.clip(rgb, 0.0, None)
        y = np.maximum(rgb @ np.array([0.2126, 0.7152, 0.0722]), 1e-3)
        return (rgb.max(-1) - rgb.min(-1)) / y

    out = img[::-1].reshape(-1, 4)  # GL row order, as the G-buffer
    fg = (flat["alpha"][:, 0] > 0).numpy() & (out[:, 3] > 0)
    bound = np.maximum(spread(irr.numpy()), spread(pre.numpy()))[fg]
    direct = out if lit is None else lit
    tint = spread(direct[:, :3])[fg]
    assert fg.sum() > 1000 and np.all(tint <= bound + 1e-4), float((tint - bound).max())
    if lit is not None:  # + the indirect light gathered from the frame's direct light
        final = spread(out[:, :3])[fg]
        assert np.all(final <= bound.max() + 1e-4), float(final.max() - bound.max())
    studio = achromatic_error(img[..., :3], img[..., 3] > 0)
    print(f"studio tint {studio:.2f} %; per pixel at most its lighting's (max excess "
          f"{100 * float((tint - bound).max()):.4f} points)")


def test_unknown_student_features_are_rejected(tmp_path, dfg_weights):
    arch = dict(load_network(dfg_weights).architecture, features="fancy")
    bad = _tamper(dfg_weights, tmp_path / "f.safetensors", {"architecture": json.dumps(arch)})
    with pytest.raises(WeightsError, match="student features 'fancy'"):
        load_network(bad)


def test_student_and_teacher_pass_parity(programs, weights):
    r = tn.check_model(programs, "neural", {}, weights[0])
    assert r.passed, r
    r = tn.check_model(programs, "neural_teacher", {"samples": 4, "sampling": "uniform"},
                       weights[1])
    assert r.passed, r


def test_teacher_estimate_is_linear_in_light(weights):
    """rho L_in / p: doubling the environment doubles the light feature's multiplier (the log
    feature changes too, so only zero light is checked exactly: no light, no radiance)."""
    t = load_model(weights[1])
    n = torch.nn.functional.normalize(torch.randn(64, 3), dim=-1)
    mat = torch.rand(64, 6)
    l = torch.nn.functional.normalize(torch.randn(64, 3), dim=-1)
    with torch.no_grad():
        c = t.contribution(mat, n, -n, l, torch.zeros(64, 3))
    assert torch.all(c == 0)


def _tamper(src, dst, meta_change=None, tensor_change=None, truncate=None):
    data = src.read_bytes()
    n = struct.unpack("<Q", data[:8])[0]
    header = json.loads(data[8:8 + n])
    body = bytearray(data[8 + n:])
    if meta_change:
        header["__metadata__"].update(meta_change)
    if tensor_change:
        start = header[tensor_change]["data_offsets"][0]
        body[start:start + 4] = struct.pack("<f", 123.0)
    h = json.dumps(header).encode()
    h += b" " * ((8 - len(h) % 8) % 8)
    out = struct.pack("<Q", len(h)) + h + bytes(body)
    dst.write_bytes(out[:truncate] if truncate else out)
    return dst


@pytest.mark.parametrize("case, message", [
    ("truncated", "truncated or corrupt"),
    ("version", "format version '99' is not supported"),
    ("format", "not a relight neural-shader file"),
    ("architecture", "is not the student architecture"),
    ("tampered", "checkpoint hash mismatch"),
    ("kind", "holds a teacher network, expected a student"),
])
def test_bad_weights_are_one_line_errors_naming_the_file(tmp_path, weights, case, message):
    s_path, t_path = weights
    bad = tmp_path / f"{case}.safetensors"
    if case == "truncated":
        bad.write_bytes(s_path.read_bytes()[:-100])
    elif case == "version":
        _tamper(s_path, bad, {"version": "99"})
    elif case == "format":
        _tamper(s_path, bad, {"format": "something-else"})
    elif case == "architecture":
        arch = json.loads(load_network(s_path).architecture and
                          json.dumps(load_network(s_path).architecture))
        arch["networks"]["mlp"]["sizes"][1] = 17
        _tamper(s_path, bad, {"architecture": json.dumps(arch)})
    elif case == "tampered":
        _tamper(s_path, bad, tensor_change="mlp.0.weight")
    else:
        bad.write_bytes(t_path.read_bytes())
    before = bad.read_bytes()
    with pytest.raises(WeightsError) as info:
        load_network(bad, "student")
    text = str(info.value)
    assert message in text and str(bad) in text and "\n" not in text
    assert bad.read_bytes() == before  # nothing overwritten


def test_render_with_bad_weights_is_a_scene_level_error(tmp_path, ctx):
    from viewer.renderer import Renderer
    from viewer.scene import scene_from_dict

    missing = tmp_path / "none.safetensors"
    scene = scene_from_dict({"camera": {"size": [8, 8]},
                             "objects": [{"type": "sphere"}],
                             "render": {"model": "neural", "weights": str(missing)}})
    r = Renderer(ctx=ctx)
    try:
        with pytest.raises(WeightsError, match="weights file not found"):
            r.render(scene)
    finally:
        r.release()


def test_shipped_weights_load_and_are_small():
    from viewer.neural import default_weights

    net = load_network(default_weights("student"), "student")
    assert net.macs() <= 4096 and net.training.get("stage") == "student"
    teacher = load_network(default_weights("teacher"), "teacher")
    # the shipped student learns from the path-traced targets themselves (--student-target
    # target); a distilled one records the teacher it was distilled from
    assert net.training["distilled_from"] in (teacher.checkpoint, "the dataset's targets")
    assert net.training["config"]["student_target"] == "target"


def test_parity_cli_neural_passes(capsys):
    from relight.cli import main

    assert main(["parity", "--model", "neural", "--json"]) == 0
    rows = json.loads(capsys.readouterr().out)
    names = {r["name"] for r in rows}
    assert {"neural:network", "model:neural"} <= names
    net = next(r for r in rows if r["name"] == "neural:network")
    assert net["passed"] and net["max_abs"] <= 1e-4


@pytest.fixture(scope="module")
def vis_weights(tmp_path_factory):
    return _student_file(tmp_path_factory, "vis", 4, features="vis", output="pbr3")


def test_vis_student_round_trip_parity_and_its_ssao_pass(programs, vis_weights):
    """A student with the environment's screen-space visibility among its inputs: the generated
    code reads it, torch and GLSL agree on the network and on whole frames (where the renderer
    runs SSAO with SSAO_ENV_VIS for it although the scene did not ask for SSAO), and the input
    changes the output (a vis of 0 and of 1 give different factors)."""
    from viewer.renderer import Renderer
    from viewer.scene import scene_from_dict

    net = load_network(vis_weights, "student")
    assert net.features == "vis" and "mlp 27-8-12-3" in net.glsl  # 9 inputs x (1 + 2)
    assert "#define NEURAL_STUDENT_VIS 1" in net.glsl
    model = load_model(vis_weights)
    assert model.reads_visibility
    x = torch.from_numpy(tn.student_inputs(64))
    x0, x1 = x.clone(), x.clone()
    x0[:, 10], x1[:, 10] = 0.0, 1.0
    with torch.no_grad():
        assert (model.weights(x0) - model.weights(x1)).abs().max() > 1e-3
    r = tn.check_network(programs, vis_weights)
    assert r.passed and r.max_abs <= 1e-4, r
    r = tn.check_model(programs, "neural", {}, vis_weights)
    assert r.passed, r
    scene = scene_from_dict(tn.PARITY_SCENE).with_render(model="neural", weights=str(vis_weights))
    assert not scene.render.ssao.enabled
    renderer = Renderer(ctx=programs.ctx)
    try:
        t = renderer.draw(scene)
        assert t.ssao is not None  # the student's required pass ran
        w, h = t.ssao.size
        import numpy as np
        img = np.frombuffer(t.ssao.read(), np.float32).reshape(h, w, 4)
        assert img[..., 1].min() < 0.5 < img[..., 1].max()  # the sun's shadow on the floor
    finally:
        renderer.release()


def test_split3_student_starts_at_the_split_sum_model(programs, tmp_path):
    """A ``split3`` student is initialised to k = 0.5 everywhere, which is ``ggx_split_sum``
    (single scattering) by construction: its GLSL frame equals the classical model's to float
    rounding (an identity between two independent passes, not a twin), with and without SSAO in
    its inputs; then torch and GLSL agree on a perturbed one."""
    from viewer.renderer import Renderer
    from viewer.scene import scene_from_dict

    torch.manual_seed(5)
    s = Student(hidden=(8, 8), features="vis", output="split3")
    path = tmp_path / "split.safetensors"
    export(s, path)
    renderer = Renderer(ctx=programs.ctx)
    try:
        base = scene_from_dict(tn.PARITY_SCENE).with_render(multiscatter=False, tonemap="none",
                                                             ssao=True)
        neural = renderer.render(base.with_render(model="neural", weights=str(path))).radiance
        # the student's base is the split-sum of the whole environment (no analytic sun)
        classical = renderer.render(base.with_render(model="ggx_split_sum", sun=False)).radiance
    finally:
        renderer.release()
    np.testing.assert_allclose(neural, classical, rtol=2e-6, atol=2e-6)
    with torch.no_grad():
        s.layers[-1].weight.normal_(0.0, 2.0)
    export(s, path)
    r = tn.check_model(programs, "neural", {}, path)
    assert r.passed, r


# ---- the learned indirect factor (architecture "indirect": "factor", issue 14) --------------------

def test_indirect_student_starts_at_split_sum_with_ssao_and_indirect(programs, tmp_path):
    """An untrained student with the indirect factor (zero-initialised last layers: split3's k = 0.5
    and the indirect network's factor 2 k_i = 1) renders ``ggx_split_sum`` (single scattering) + SSAO + the classical
    indirect pass exactly, although the scene asks for neither SSAO nor indirect light: the renderer
    forces both on for it, and allocates the factor's target only for such a student."""
    from viewer.neural import learns_indirect, required_settings
    from viewer.renderer import Renderer
    from viewer.scene import scene_from_dict

    torch.manual_seed(5)
    s = Student(hidden=(8, 8), features="vis", output="split3", indirect="factor")
    path = tmp_path / "ind.safetensors"
    export(s, path)
    net = load_network(path, "student")
    assert net.indirect == "factor" and "mlp 9-8-8-3" in net.glsl
    assert "indirect 9-16-1 (relu, sigmoid)" in net.glsl
    assert "#define NEURAL_STUDENT_INDIRECT 1" in net.glsl
    base = scene_from_dict(tn.PARITY_SCENE).with_render(multiscatter=False, tonemap="none")
    scene = base.with_render(model="neural", weights=str(path))
    assert not scene.render.ssao.enabled and not scene.render.ssao.indirect
    assert learns_indirect(scene.render)
    forced = required_settings(scene.render)
    assert forced.ssao.enabled and forced.ssao.indirect
    renderer = Renderer(ctx=programs.ctx)
    try:
        targets = renderer.draw(scene)
        assert targets.indirect_factor is not None and targets.direct is not None
        w, h = targets.indirect_factor.size
        factor = np.frombuffer(targets.indirect_factor.read(), np.float32)
        np.testing.assert_array_equal(factor, np.ones(w * h, np.float32))
        neural = renderer.render(scene).radiance
        classical = renderer.render(base.with_render(model="ggx_split_sum", ssao=True,
                                                     indirect=True, sun=False)).radiance
        direct_only = renderer.render(base.with_render(model="ggx_split_sum", ssao=True)).radiance
        # a student without the factor: no factor target, the frame as before (indirect off)
        plain = tmp_path / "plain.safetensors"
        export(Student(hidden=(8, 8), features="vis", output="split3"), plain)
        t2 = renderer.draw(base.with_render(model="neural", weights=str(plain)))
        assert t2.indirect_factor is None and t2.direct is None
    finally:
        renderer.release()
    np.testing.assert_allclose(neural, classical, rtol=2e-6, atol=2e-6)
    assert np.abs(classical - direct_only).max() > 0.05  # the scene has indirect light to scale


def test_indirect_student_parity_glsl_vs_torch(programs):
    """A perturbed student with the factor: the networks (the student's and the indirect one, every
    weight storage), its lighting pass (the direct
    target), its second output (the factor, which varies over the frame) and the indirect pass
    scaled by it, GL against the torch twins."""
    path = tn.indirect_student(programs, tn.indirect_student(programs))  # a random one
    net = load_network(path, "student")
    assert net.indirect == "factor"
    for storage in WEIGHT_STORAGES:  # both networks read from every weight storage
        r = tn.check_network(programs, path, storage)
        assert r.passed and r.max_abs <= 1e-4, r
    r = tn.check_model(programs, "neural", {}, path)
    assert r.passed, r
    factor, frame = tn.check_indirect_factor(programs, path)
    assert factor.passed and factor.max_abs <= 2e-4, factor
    assert frame.passed, frame
    model = load_model(path)
    x = torch.from_numpy(tn.student_inputs(256))
    with torch.no_grad():
        f = model.indirect_factor(x)
    assert f.max() - f.min() > 0.2  # the factor is live, within [0, 2]
    assert 0.0 <= f.min() and f.max() <= 2.0


def test_indirect_factor_trains_in_the_forward_pass():
    """``Student.forward`` with the indirect light adds factor x L_ind (factor 1 untrained, the
    classical sum); without it, the lighting pass's direct light alone; students without the
    factor add L_ind as it is."""
    torch.manual_seed(0)
    s = Student(hidden=(8, 8), features="vis", output="split3", indirect="factor")
    x = torch.from_numpy(tn.student_inputs(64))
    n = x.shape[0]
    irr, pre, ind = torch.rand(n, 3), torch.rand(n, 3), torch.rand(n, 3)
    with torch.no_grad():
        direct = s(x, irr, pre)
        np.testing.assert_allclose(s(x, irr, pre, ind), direct + ind, rtol=1e-6, atol=1e-6)
        s.indirect_layers[-1].bias[0] = 1.0
        f = 2.0 * torch.sigmoid(torch.tensor(1.0))
        np.testing.assert_allclose(s(x, irr, pre, ind), direct + f * ind, rtol=1e-6, atol=1e-6)
        np.testing.assert_allclose(s(x, irr, pre), direct, rtol=0, atol=0)
    plain = Student(hidden=(8, 8), features="vis", output="split3")
    assert not plain.learns_indirect
    with pytest.raises(ValueError, match="three-factor output form"):
        Student(output="free6", indirect="factor")


def test_files_without_indirect_key_have_no_factor(pbr_weights):
    """Files written before the factor existed (no ``indirect`` in the architecture) load as
    ``none``; students without it still export no key, so their files are unchanged."""
    net = load_network(pbr_weights, "student")
    assert "indirect" not in net.architecture and net.indirect == "none"
    assert "#define NEURAL_STUDENT_INDIRECT 0" in net.glsl
    assert not load_model(pbr_weights).learns_indirect


@pytest.mark.parametrize("change, message", [
    ({"indirect": "factor"}, "is not the student architecture"),  # 3 outputs, factor claimed
    ({"indirect": "bogus"}, "student indirect 'bogus'"),
    ({"indirect": "factor", "output": "free6"}, "needs a three-factor output form"),
])
def test_mismatched_indirect_metadata_is_a_one_line_error(tmp_path, pbr_weights, change, message):
    arch = dict(load_network(pbr_weights).architecture) | change
    bad = _tamper(pbr_weights, tmp_path / "bad.safetensors", {"architecture": json.dumps(arch)})
    with pytest.raises(WeightsError) as info:
        load_network(bad, "student")
    text = str(info.value)
    assert message in text and str(bad) in text and "\n" not in text


# ---- the teacher without the light's radiance among its inputs ("light_input": false) -----------

@pytest.fixture(scope="module")
def lightless_teacher(tmp_path_factory):
    torch.manual_seed(5)
    path = tmp_path_factory.mktemp("lightless") / "t.safetensors"
    export(Teacher(hidden=8, num_freqs=1, light_input=False), path)
    return path


def test_lightless_teacher_round_trip_and_generated_code(lightless_teacher, weights):
    """``"light_input": false`` is recorded, reloaded and generated without the log(1 + L_in)
    inputs (13 inputs x 3 Fourier terms); a file without the key is the thesis's teacher, whose
    generated code still computes them."""
    net = load_network(lightless_teacher, "teacher")
    assert net.architecture["light_input"] is False and not net.light_input
    assert net.architecture["inputs"][-1] == "NoL"
    assert net.architecture["networks"]["diffuse"]["sizes"][0] == 13 * 3
    assert "log_lin" not in net.glsl and "rho * L_in" in net.glsl
    assert load_model(lightless_teacher).light_input is False
    old = load_network(weights[1], "teacher")
    assert "light_input" not in old.architecture and old.light_input
    assert "vec3 log_lin = log(1.0 + lin);" in old.glsl


def test_lightless_teacher_is_exactly_linear_in_the_light(lightless_teacher):
    """rho sees no radiance, so the contribution rho L_in is linear in L_in: twice the light is
    twice the contribution to float32 rounding (a power-of-two scale: exactly)."""
    t = load_model(lightless_teacher)
    g = torch.Generator().manual_seed(0)
    n = torch.nn.functional.normalize(torch.randn(256, 3, generator=g), dim=-1)
    l = torch.nn.functional.normalize(torch.randn(256, 3, generator=g), dim=-1)
    mat, li = torch.rand(256, 6, generator=g), 10.0 * torch.rand(256, 3, generator=g)
    with torch.no_grad():
        one = t.contribution(mat, n, -n, l, li)
        two = t.contribution(mat, n, -n, l, 2.0 * li)
    assert torch.equal(two, 2.0 * one)


def test_lightless_teacher_pass_parity(programs, lightless_teacher):
    r = tn.check_model(programs, "neural_teacher", {"samples": 4, "sampling": "env"},
                       lightless_teacher, label="light_input=false")
    assert r.passed and r.name.endswith(":light_input=false"), r


@pytest.mark.parametrize("change, message", [
    ({"light_input": "no"}, "teacher light_input 'no'"),
    ({"light_input": True}, "is not the teacher architecture"),
])
def test_mismatched_light_input_metadata_is_a_one_line_error(tmp_path, lightless_teacher,
                                                             change, message):
    arch = dict(load_network(lightless_teacher).architecture, **change)
    if change.get("light_input") is True:  # the key says 16 inputs; keep the inputs list honest
        arch["inputs"] = list(TEACHER_INPUTS)
    bad = _tamper(lightless_teacher, tmp_path / "t.safetensors",
                  {"architecture": json.dumps(arch)})
    with pytest.raises(WeightsError, match=message):
        load_network(bad)
