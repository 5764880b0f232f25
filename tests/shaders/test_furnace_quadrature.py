"""White furnace against an independent integral: a conductor sphere under a uniform unit white
environment reflects, at each pixel, the directional albedo of its specular BRDF at that pixel's
n.v, and that albedo is computed here by plain numerical quadrature - not from the project's DFG
LUT, its sampling code or its GLSL.

The BRDF (the conventions of ``shaders/lib/brdf.glsl``, written out below): GGX (Walter 2007) with
alpha = r^2 for perceptual roughness r, height-correlated Smith visibility (Heitz 2014, Filament
form), Schlick Fresnel F = f0 + (1 - f0) (1 - v.h)^5 (f90 = 1 for any f0 >= 0.02, and for a
metallic f0 = 0 channel too, since f90 follows the brightest channel). Its directional albedo is
E(mu, f0) = f0 E1(mu) + (1 - f0) Ec(mu), E1 the F = 1 albedo, Ec the one weighted by (1 - v.h)^5:
both integrated over the half vector h (l = reflect(-v, h), d(omega_l) = 4 (v.h) d(omega_h)) on a
midpoint grid of 256 polar (squared spacing, dense at the lobe's peak) x 128 azimuth nodes (the
other half by symmetry). Against 1024 x 512 nodes it is converged to 8e-5 over n.v in [0.05, 1];
a cubic spline through 41 n.v values adds at most 1.1e-4.

With ``multiscatter`` the project claims energy compensation (Fdez-Aguera 2019 / Filament): E(mu,
f0) (1 + f0 (1 / E1(mu) - 1)), which makes a white (f0 = 1) conductor reflect exactly what it
receives, as a lossless microsurface must; the f0 = 0.5 channel checks the formula's wiring with
the quadrature's E1 and Ec.

Unlike the furnace tests of tests/viewer/test_render.py (plumbing: the DFG terms divide out), these
fail for a wrong DFG table, a wrong roughness-to-table mapping or swapped LUT channels; the last
test shows one such mutation failing.
"""
import math

import numpy as np
import pytest
from scipy.interpolate import CubicSpline

from viewer.renderer import Renderer
from viewer.scene.description import ObjectSpec, Scene, scene_from_dict
from viewer.scene.material import Material

SIZE = (48, 48)
F0 = (1.0, 0.5, 0.0)  # a metallic sphere of albedo F0: one channel per f0 (f90 = 1 for all)
ROUGHNESS = (0.3, 0.6, 1.0)
MU = np.linspace(0.05, 1.0, 41)  # the sphere's fully covered pixels have n.v >= 0.065 at 48^2
# Split-sum per pixel: |rendered - quadrature| <= RTOL x quadrature + ATOL. Measured on llvmpipe,
# 48 x 48, every fully covered pixel, roughness 0.3 / 0.6 / 1: F = 1 channel 0.27 / 0.40 / 0.12 %
# (the largest at r = 0.6, n.v = 0.1), f0 = 0.5 channel 0.22 / 0.35 / 0.11 %, f0 = 0 channel (the
# LUT's x) 1.5e-4 / 1.5e-4 / 3.7e-5 absolute; with multiscatter f0 = 0.5 0.09 / 0.14 / 0.05 % (f0 =
# 1 is 1 within 4e-7: the compensation divides out). At most 0.63 of the tolerance. The LUT has
# 4096 Hammersley samples per texel (IBLOptions.dfg_samples: "within 0.4 %") on 64 x 64 texels;
# with 256 samples the check fails (2.0-3.6x the tolerance).
RTOL, ATOL = 0.006, 3e-4


def albedos(mu: float, alpha: float, n_theta: int = 256, n_phi: int = 128) -> np.ndarray:
    """``(E1, Ec)`` at n.v = ``mu``: the directional albedo of the GGX / height-correlated Smith
    specular BRDF with F = 1 and with F = (1 - v.h)^5, by midpoint quadrature over the half
    vector (n = +z, v in the xz plane)."""
    s = (np.arange(n_theta) + 0.5) / n_theta
    theta = 0.5 * math.pi * s * s  # d(theta) = pi s ds: nodes crowd at the peak (h = n)
    d_theta = math.pi * s / n_theta
    phi = (np.arange(n_phi) + 0.5) / n_phi * math.pi  # [0, pi]: the integrand is even in phi
    t, p = np.meshgrid(theta, phi, indexing="ij")
    st, ct = np.sin(t), np.cos(t)
    h = np.stack([st * np.cos(p), st * np.sin(p), ct], -1)
    v = np.array([math.sqrt(max(1.0 - mu * mu, 0.0)), 0.0, mu])
    voh = h @ v
    nol = (2.0 * voh[..., None] * h - v)[..., 2]
    a2 = alpha * alpha
    d = a2 / (math.pi * (ct * ct * (a2 - 1.0) + 1.0) ** 2)
    ok = (nol > 0.0) & (voh > 0.0)
    nol = np.where(ok, nol, 0.0)
    vis = 0.5 / (mu * np.sqrt(nol * nol * (1.0 - a2) + a2)
                 + nol * math.sqrt(mu * mu * (1.0 - a2) + a2))
    w = np.where(ok, d * vis * nol * 4.0 * voh, 0.0) * st * d_theta[:, None] \
        * (2.0 * math.pi / n_phi)
    return np.array([w.sum(), (w * (1.0 - np.clip(voh, 0.0, 1.0)) ** 5).sum()])


_SPLINES: dict = {}


def expected(mu: np.ndarray, roughness: float, multiscatter: bool) -> np.ndarray:
    """``[..., 3]``: what each channel of a metallic sphere of albedo :data:`F0` reflects under a
    unit white environment at n.v = ``mu`` (the roughness is clamped to 0.045 as brdf.glsl does;
    the values here are above it)."""
    if roughness not in _SPLINES:
        alpha = max(roughness, 0.045) ** 2
        _SPLINES[roughness] = CubicSpline(MU, np.array([albedos(m, alpha) for m in MU]))
    e = _SPLINES[roughness](np.clip(mu, MU[0], 1.0))
    e1, ec = e[..., 0:1], e[..., 1:2]
    f0 = np.asarray(F0)
    out = f0 * e1 + (1.0 - f0) * ec
    return out * (1.0 + f0 * (1.0 / e1 - 1.0)) if multiscatter else out


def test_the_quadrature_reproduces_known_values():
    """The quadrature itself: E1 -> 1 for a near-mirror at normal incidence, the r = 1 normal
    incidence albedo 0.3069 (the brute-force value tests/viewer/test_render.py quotes, from a
    quadrature over l instead of h), and Ec = 0 at normal incidence (v.h = 1 for h = n)."""
    assert albedos(1.0, 0.045 ** 2)[0] == pytest.approx(1.0, abs=2e-3)
    assert albedos(1.0, 1.0)[0] == pytest.approx(0.3069, abs=2e-4)
    assert albedos(0.3, 0.36)[0] == pytest.approx(albedos(0.3, 0.36, 1024, 512)[0], abs=1e-4)
    assert albedos(1.0, 0.36)[1] < 1e-4


@pytest.fixture(scope="module")
def renderer(ctx):
    r = Renderer(ctx=ctx)
    yield r
    r.release()


def _scene(roughness: float, model: str = "ggx_split_sum", size=SIZE, **render) -> Scene:
    scene = scene_from_dict({
        "camera": {"position": [0, 0, 3.5], "fov_y": 40, "size": list(size)},
        "environment": {"procedural": "white", "width": 64},
        "render": {"tonemap": "none", "aa": "none", "model": model, "ao": False, **render}})
    material = Material(albedo=F0, metallic=1.0, roughness=roughness)
    return Scene(camera=scene.camera, environment=scene.environment, render=scene.render,
                 objects=(ObjectSpec("sphere", material=material),))


def _render(renderer, scene) -> tuple[np.ndarray, np.ndarray]:
    """``(rgb [N, 3], n.v [N])`` of the sphere's fully covered pixels; n.v from the G-buffer's
    normal and the camera's pixel-centre rays (as the pass forms it)."""
    frame = renderer.render(scene, aovs=("normal",))
    mu = np.clip((frame.aovs["normal"] * -scene.camera.view_rays_ws()).sum(-1), 0.0, 1.0)
    on = frame.radiance[..., 3] >= 1.0
    assert on.sum() > 0.4 * on.size
    return frame.radiance[..., :3][on].astype(np.float64), mu[on]


def _furnace_error(renderer, roughness: float, multiscatter: bool) -> float:
    """The largest |rendered - quadrature| / (RTOL x quadrature + ATOL) over pixels and channels
    (<= 1 passes)."""
    rgb, mu = _render(renderer, _scene(roughness, multiscatter=multiscatter))
    want = expected(mu, roughness, multiscatter)
    return float((np.abs(rgb - want) / (RTOL * want + ATOL)).max())


@pytest.mark.parametrize("multiscatter", [False, True], ids=["single", "multiscatter"])
@pytest.mark.parametrize("roughness", ROUGHNESS)
def test_split_sum_furnace_matches_the_quadrature(renderer, roughness, multiscatter):
    """Every fully covered pixel of the split-sum sphere, each channel, within RTOL / ATOL of
    the quadrature at its n.v (measured errors beside RTOL)."""
    assert _furnace_error(renderer, roughness, multiscatter) <= 1.0


# Monte Carlo (ggx_mc, 256 brdf samples; the specular integral is sampled, only the
# multiscatter compensation reads the LUT): the sphere's mean of rendered / quadrature per
# channel (f0 = 1 and 0.5) within MC_MEAN of 1. Measured at 32 x 32, roughness 0.3 / 0.6 / 1:
# 6.8e-5 / 4.7e-5 / 8.7e-5 single-scattering, 2.3e-4 / 6.0e-5 / 1.2e-4 with multiscatter (the white
# conductor's furnace: 1 within 2.3e-4, per pixel within 0.8 %).
MC_MEAN = 1e-3


@pytest.mark.parametrize("roughness", ROUGHNESS)
def test_monte_carlo_furnace_matches_the_quadrature(renderer, roughness):
    for multiscatter in (False, True):
        scene = _scene(roughness, "ggx_mc", (32, 32), samples=256, sampling="brdf",
                       multiscatter=multiscatter)
        rgb, mu = _render(renderer, scene)
        ratio = (rgb / expected(mu, roughness, multiscatter))[:, :2].mean(0)
        np.testing.assert_allclose(ratio, 1.0, atol=MC_MEAN, err_msg=f"multiscatter {multiscatter}")


MUTATIONS = {
    # the LUT built at alpha = r instead of r^2 (a wrong roughness-to-table mapping)
    "lut_alpha": ("passes/ibl_dfg.comp", "float a = r * r;", "float a = r;"),
    # the lookup returning the LUT's channels swapped
    "swapped": ("passes/shade_ggx_split_sum.frag", "return textureLod(dfg, uv, 0.0).rg;",
                "return textureLod(dfg, uv, 0.0).gr;"),
}


@pytest.mark.parametrize("mutation,roughness", [("lut_alpha", 0.6), ("swapped", 0.3)])
def test_the_furnace_check_fails_on_a_broken_dfg(ctx, monkeypatch, mutation, roughness):
    """The check above against a deliberately broken split-sum: a renderer of its own whose
    programs are assembled with one line of GLSL changed. The largest error is then many times
    the tolerance. The white furnace with multiscatter (test_render.py's identity) still passes
    the wrong roughness mapping exactly: the DFG terms divide out."""
    from viewer.gl import programs

    entry, old, new = MUTATIONS[mutation]
    real = programs.assemble
    hits = []

    def mutated(name, *args, **kwargs):
        out = real(name, *args, **kwargs)
        if name == entry and old in out.source:
            hits.append(name)
            out.source = out.source.replace(old, new)
        return out

    monkeypatch.setattr(programs, "assemble", mutated)
    broken = Renderer(ctx=ctx)
    try:
        error = _furnace_error(broken, roughness, multiscatter=False)
        white = _render(broken, _scene(roughness, multiscatter=True))[0][:, 0]
    finally:
        broken.release()
    assert hits, f"the mutation of {entry} was not applied"
    assert error > 3.0, error
    if mutation == "lut_alpha":
        np.testing.assert_allclose(white, 1.0, atol=1e-5)
