"""``env_below``: how bright the environment's light from below is against its light from above,
the one per-frame input of a student with ``ssao-env`` features (``u_env_below``). Its numpy
(``viewer.environment.irradiance.env_below``, the viewer's uniform) and torch
(``learned.neural.torch_lighting.env_below``, training) forms agree; it obeys its identities
(a uniform environment 1, light only from above about 0, the sun taken out or not the same
value, the sun's strength moving it the right way); and a student that reads it renders in GLSL
what its torch twin computes, which fails when the pass reads another value."""
import math

import numpy as np
import pytest
import torch

from learned.export import export
from learned.neural.lighting import lighting_from_gl
from learned.neural.student import Student
from learned.neural.torch_lighting import env_below as env_below_torch
from learned.parity.checks import neural as tn
from viewer.environment.maps import EnvironmentSpec
from viewer.imageio import write_exr
from viewer.neural import load_network


@pytest.fixture(scope="module")
def renderer(programs):
    from viewer.renderer import Renderer

    r = Renderer(ctx=programs.ctx)
    yield r
    r.release()


def _sky(sun_strength=1.0):
    return EnvironmentSpec(procedural="sky", width=64, sun_strength=sun_strength)


def _one_side(tmp_path, below: bool = False, scale: float = 1.0):
    """An equirect map lit from one side of the horizon only (a blue-white gradient), black on
    the other: above by default, ``below`` flips it; ``scale`` multiplies it."""
    h, w = 64, 128
    theta = (np.arange(h) + 0.5) / h * math.pi  # from +Y down
    img = np.zeros((h, w, 3), np.float32)
    lit = theta > math.pi / 2 if below else theta < math.pi / 2
    img[lit] = (np.array([0.6, 0.8, 1.0], np.float32) * scale
                * (1.0 + np.abs(np.cos(theta[lit])))[:, None, None].astype(np.float32))
    path = tmp_path / f"side_{int(below)}_{scale:g}.exr"
    write_exr(path, img)
    return EnvironmentSpec(path=str(path))


def _upper_only(tmp_path):
    return _one_side(tmp_path)


def test_numpy_and_torch_agree(renderer, tmp_path):
    """The viewer's value (numpy, computed by the IBL's builder from the irradiance map's array and
    its lights) equals the twin's (torch, the same map read back from the texture, the same
    lights) to float32 rounding (rel 1e-5), for the whole IBL and for the one without its sun,
    whose lights carry the sun."""
    from viewer.scene.description import Scene

    for spec in (_sky(), _sky(0.0), EnvironmentSpec(path="assets/environments/lobby.exr"),
                 EnvironmentSpec(path="assets/environments/park.exr"), _upper_only(tmp_path)):
        for sun in (False, True):
            ibl = renderer.resources.ibl(spec, sun=sun) if sun else \
                renderer.ibl(Scene(environment=spec))
            value = ibl.env_below
            twin = env_below_torch(lighting_from_gl(renderer, spec, sun=sun))
            assert 0.0 <= value <= 1.0
            assert twin == pytest.approx(value, rel=1e-5, abs=1e-7), (spec, sun)


def test_identities(renderer, tmp_path):
    """A uniform environment lights a surface facing down as one facing up: 1 (to float32
    rounding). Light from above only: under 0.03 (the irradiance map's bilinear rows at the
    poles, measured 0.0; exact 0); from below only 1; a black map 0; a map scaled by 1e-6 or
    1e6 the same as at 1. The sky with its sun taken out as a light gives the
    value of the whole map to 2 % (the SH of a compact sun against its exact cosine: measured
    0.3 %), and taking the sun's light away raises it (more of what is left comes from below)."""
    white = env_below_torch(lighting_from_gl(renderer, EnvironmentSpec(procedural="white")))
    assert white == pytest.approx(1.0, abs=1e-5)
    upper = env_below_torch(lighting_from_gl(renderer, _upper_only(tmp_path)))
    assert upper < 0.03
    # light from below alone: the clamp's end, 1 (not the 0 of a black sky); any scale alike
    assert env_below_torch(lighting_from_gl(renderer, _one_side(tmp_path, below=True))) == 1.0
    black = np.zeros((16, 32, 3), np.float32)
    write_exr(tmp_path / "black.exr", black)
    assert env_below_torch(lighting_from_gl(
        renderer, EnvironmentSpec(path=str(tmp_path / "black.exr")))) == 0.0
    for scale in (1e-6, 1e6):  # the intensity of the map cancels
        scaled = env_below_torch(lighting_from_gl(renderer, _one_side(tmp_path, scale=scale)))
        assert scaled == pytest.approx(upper, abs=1e-6)
    whole = env_below_torch(lighting_from_gl(renderer, _sky()))
    split = lighting_from_gl(renderer, _sky(), sun=True)
    assert split.sun is not None  # the procedural sky's sun is taken out
    assert env_below_torch(split) == pytest.approx(whole, rel=0.02)
    sunless = env_below_torch(lighting_from_gl(renderer, _sky(0.0)))
    assert sunless > 1.5 * whole


def test_a_student_that_reads_it_renders_its_twin(programs, tmp_path):
    """A student with ``ssao-env`` features whose networks lean hard on the input (its weights
    times 8) renders in GLSL what its torch twin computes (``model:neural``, the parity scene's
    sky: env_below 0.07). The pass reads the uniform: the same student with the input's weights
    zeroed renders another image, so a pass that read another value would fail the check."""
    from viewer.renderer import Renderer
    from viewer.scene.description import scene_from_dict

    torch.manual_seed(7)
    s = Student(hidden=(8, 8), features="ssao-env", output="split3", indirect="factor",
                sun=True, multiscatter=True)
    with torch.no_grad():
        for layers in (s.layers, s.indirect_layers):
            layers[0].weight[:, -1].normal_(0.0, 8.0)
        s.layers[-1].weight.normal_(0.0, 2.0)
        s.indirect_layers[-1].weight.normal_(0.0, 2.0)
    path = tmp_path / "env.safetensors"
    export(s, path)
    net = load_network(path, "student")
    assert net.architecture["inputs"][-1] == "env_below"
    assert "#define NEURAL_STUDENT_ENV 1" in net.glsl
    r = tn.check_model(programs, "neural", {}, path)
    assert r.passed, r
    with torch.no_grad():
        for layers in (s.layers, s.indirect_layers):
            layers[0].weight[:, -1].zero_()
    flat = tmp_path / "flat.safetensors"
    export(s, flat)
    base = scene_from_dict(tn.PARITY_SCENE).with_render(tonemap="none")
    renderer = Renderer(ctx=programs.ctx)
    try:
        a = renderer.render(base.with_render(model="neural", weights=str(path))).radiance
        b = renderer.render(base.with_render(model="neural", weights=str(flat))).radiance
    finally:
        renderer.release()
    assert np.abs(a[..., :3] - b[..., :3]).max() > 1e-2


def test_a_student_without_it_does_not_read_it(tmp_path):
    """The shipped input sets keep their inputs: only ``ssao-env`` reads the value, and its
    generated code says so."""
    torch.manual_seed(3)
    path = tmp_path / "ssao.safetensors"
    export(Student(hidden=(8,), features="ssao", output="split3"), path)
    net = load_network(path, "student")
    assert "env_below" not in net.architecture["inputs"]
    assert "#define NEURAL_STUDENT_ENV 0" in net.glsl
