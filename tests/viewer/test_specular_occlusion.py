"""Specular occlusion (``[render] specular_occlusion``, ``lib/shading.glsl specular_occlusion``):
the identities of Lagarde & de Rousiers' form, and the frame: the occlusion takes exactly that
share of split-sum's environment specular light, nothing where nothing is occluded, and nothing
in the models that do not shade with it."""
import math

import numpy as np
import pytest
import torch
from ssao_scenes import FLOOR, SSAO, WALL, _read, scene

from learned.twins.shading import specular_occlusion
from viewer.models import MODELS
from viewer.renderer import Renderer

BLACK = {"albedo": [0, 0, 0], "roughness": 0.2, "specular": 1.0}  # specular light only


@pytest.fixture(scope="module")
def renderer(ctx):
    r = Renderer(ctx=ctx)
    yield r
    r.release()


def _grid():
    nov, ao, a = torch.meshgrid(torch.linspace(0, 1, 41), torch.linspace(0, 1, 41),
                                torch.tensor([0.002025, 0.04, 0.25, 1.0]), indexing="ij")
    return nov, ao, a


def test_the_form_keeps_what_is_open_and_takes_what_is_closed():
    nov, ao, a = _grid()
    f = specular_occlusion(nov, ao, a)
    assert torch.equal(specular_occlusion(nov, torch.ones_like(ao), a), torch.ones_like(ao))
    assert torch.equal(specular_occlusion(nov, torch.zeros_like(ao), a), torch.zeros_like(ao))
    assert ((f >= 0) & (f <= 1)).all()
    assert (f[:, 1:] >= f[:, :-1]).all()  # more occlusion never gives more light


def test_a_head_on_lobe_sees_at_least_ao_and_a_rough_one_sees_ao():
    """Lagarde's design: a lobe seen head-on looks out of the opening (>= ao), a rough lobe
    samples the whole hemisphere (= ao: exponent 2^-17, so (n.v + ao)^p = 1 + p ln(...) within
    2^-17 x |ln 0.01| = 3.5e-5 for ao >= 0.01)."""
    nov, ao, a = _grid()
    head_on = specular_occlusion(torch.ones_like(nov), ao, a)
    assert (head_on >= ao - 1e-7).all()
    assert (head_on[:, 1:-1] > ao[:, 1:-1]).all()  # strictly, between the ends
    rough = specular_occlusion(nov, ao, torch.ones_like(a))
    keep = ao >= 0.01
    np.testing.assert_allclose(rough[keep], ao[keep], atol=2 ** -17 * abs(math.log(0.01)) + 1e-6)


def _crease(renderer, model="ggx_split_sum", **render):
    objects = [{**FLOOR, "material": BLACK}, {**WALL, "material": BLACK}]
    # the environment's lamps stay in the IBL (sun = false): every light is the lobe's
    sc = scene(objects, model=model, ssao=True, sun=False, **SSAO, **render)
    t = renderer.draw(sc)
    return sc, t, _read(t, "radiance")[..., :3], _read(t, "ssao")[..., 0]


def test_the_frame_takes_the_occluded_share_of_split_sums_specular_light(renderer):
    """Black specular planes in a crease: with it on against off, the ratio at each floor pixel
    is specular_occlusion(n.v, O(x), 0.2^2) from the pixel's O(x) and view ray. Bound 1e-4: the
    GL pow and n.v against float64 here differ by ~1e-6 (the parity case's envelope); the rest
    leaves room for a driver's looser exp2 and log2 (3 ulp each in GLSL 4.60)."""
    sc, t, on, ao = _crease(renderer)
    _, _, off, ao_off = _crease(renderer, specular_occlusion=False)
    np.testing.assert_array_equal(ao, ao_off)  # the same occlusion either way
    normal = t.gbuffer.read(["normal"])["normal"]
    floor = (normal[..., 1] > 0.999) & (off.sum(-1) > 1e-3)
    open_ = floor & (ao == 1.0)
    closed = floor & (ao < 0.95)
    assert open_.sum() > 50 and closed.sum() > 50, (open_.sum(), closed.sum())
    np.testing.assert_array_equal(on[open_], off[open_])  # nothing occluded, nothing taken
    # the view ray of each pixel centre, from the camera (n = +Y on the floor: n.v = -d.y)
    cam = sc.camera
    h, w = on.shape[:2]
    right, up, back = (np.asarray(b, np.float64) for b in cam.basis())
    tx, ty = cam.tan_half_fov()
    x = ((np.arange(w) + 0.5) / w * 2 - 1) * tx
    y = (1 - (np.arange(h) + 0.5) / h * 2) * ty  # row 0 at the top
    d = x[None, :, None] * right + y[:, None, None] * up - back
    d /= np.linalg.norm(d, axis=-1, keepdims=True)
    nov = np.clip(-d[..., 1], 0, 1)
    expect = specular_occlusion(torch.from_numpy(nov), torch.from_numpy(ao.astype(np.float64)),
                                torch.tensor(0.04, dtype=torch.float64)).numpy()
    ratio = on[closed] / off[closed]
    np.testing.assert_allclose(ratio, np.repeat(expect[closed][:, None], 3, 1), atol=1e-4)
    assert ratio.mean() < 0.97, ratio.mean()  # the crease's lobes lose light


@pytest.mark.parametrize("model", sorted(m for m in MODELS if not MODELS[m].specular_occlusion
                                         and MODELS[m].occlusion and m != "ggx_mc"))
def test_models_without_it_are_untouched(renderer, model):
    """blinn_phong (the thesis baseline) keeps eq. 6.19: occlusion on its diffuse light only."""
    import viewer.renderer as renderer_module

    renderer_module._LIGHT_WARNED.discard("dormant:specular_occlusion")  # said once a process
    with pytest.warns(UserWarning, match="specular_occlusion"):  # said once: it does nothing
        _, _, off, _ = _crease(renderer, model, specular_occlusion=False)
    _, _, on, _ = _crease(renderer, model)
    np.testing.assert_array_equal(on, off)
