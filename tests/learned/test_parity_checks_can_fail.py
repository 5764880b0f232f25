"""The robust parity checks fail on broken implementations (issue 39): the shadow-map lookups
(learned/parity/checks/shadow.py) and the SSAO passes (learned/parity/checks/ssao.py) tolerate a
few outliers, each within what one flipped sample or ray may change - no longer anything up to 1
(shadows) or up to the image's maximum (the indirect light)."""
import numpy as np
import pytest
import torch

from learned.parity.checks import shadow as shadow_check
from learned.parity.checks.shadow import lookup_steps, robust_lookups
from learned.parity.checks.ssao import reach_max, robust_compare


def test_shadow_lookups_fail_on_a_broken_twin(programs, monkeypatch):
    """A PCSS twin that calls every receiver beyond depth 0.999 lit: 1 of the cascade atlas's 2048
    lookups differs (by 0.94), which the old rule (at most 1/500 outliers, each within 1) passed;
    the intact twin passes (0 of 2048 beyond 1e-5 for every result, input seeds 1-20)."""
    check = shadow_check.checks()["shadow:lookups"][1]
    assert all(r.passed for r in check(programs))
    pcss = shadow_check.shadow_pcss

    def lit_far_away(map_, s, plane, lens, phi, face, adaptive=True):
        v = pcss(map_, s, plane, lens, phi, face, adaptive)
        return torch.where(s[..., 2] > 0.999, torch.ones_like(v), v)

    monkeypatch.setattr(shadow_check, "shadow_pcss", lit_far_away)
    failed = [r.name for r in check(programs) if not r.passed]
    assert failed == ["shadow_pcss (cascade)"], failed


def _with_outliers(ref, count, size):
    gl = ref.copy()
    gl[:count] += size[:count] if np.ndim(size) else size
    return gl


def test_a_texel_read_may_not_differ_anywhere():
    """shadow_sample and the slopes read no spiral: one differing lookup fails (the old rule's
    `step == 0 and not bad.any() or ...` let up to 4 entirely wrong texel reads through)."""
    ref = np.random.default_rng(0).uniform(0.0, 1.0, 2048).astype(np.float32)
    gl = _with_outliers(ref, 1, 0.5)
    assert not robust_lookups("shadow_sample", gl, ref,
                              lookup_steps("shadow_sample", gl, ref, None)).passed


@pytest.mark.parametrize("count, shares, passes", [(4, 1.0, True), (4, 2.0, False),
                                                   (5, 1.0, False), (1, 8.0, False)])
def test_pcf_outliers_are_few_and_one_samples_share(count, shares, passes):
    """PCF: at most 4 of 2048 lookups (1/500) beyond 1e-5, each by one sample's share 1 / taps;
    two shares, a fifth outlier, or an entirely wrong value fails."""
    rng = np.random.default_rng(1)
    taps = rng.choice([4.0, 9.0, 32.0], 2048)
    ref = (rng.integers(0, 5, 2048) / 32.0).astype(np.float32)
    gl = _with_outliers(ref, count, shares / taps)
    steps = lookup_steps("shadow_pcf", gl, ref, taps)
    assert robust_lookups("shadow_pcf", gl, ref, steps).passed == passes


def test_blocker_outliers_move_the_mean_by_at_most_half():
    """The blocker search: 1/2 while both sides find an occluder, a found / none flip (-1) in
    full."""
    ref = np.full(2048, 0.4, np.float32)
    for delta, passes in ((0.45, True), (0.55, False), (-1.4, True)):
        gl = _with_outliers(ref, 2, delta)
        steps = lookup_steps("shadow_blocker_depth", gl, ref, None)
        assert robust_lookups("shadow_blocker_depth", gl, ref, steps).passed == passes, delta


def test_ssao_outliers_stay_within_one_rays_share():
    """The indirect light: 8 of 3072 pixels off by 0.5, where one ray's share is 0.1, fail
    (the old step, the image's maximum 522, passed them); within the share they pass; off in
    more than 1 % of the pixels they fail."""
    rng = np.random.default_rng(2)
    ref = rng.uniform(0.0, 2.0, (48, 64, 4)).astype(np.float32)
    step = np.full(ref.shape, 0.1)
    gl = ref.copy()
    gl[2, 28:36, :3] += 0.5
    assert not robust_compare("ssao:indirect", gl, ref, step).passed
    assert robust_compare("ssao:indirect", gl, ref, 522.0).passed  # the old bound
    gl = ref.copy()
    gl[2, 28:36, :3] += 0.09
    assert robust_compare("ssao:indirect", gl, ref, step).passed
    gl[10:12, :, :3] += 0.09  # 136 pixels: 4.4 %
    assert not robust_compare("ssao:indirect", gl, ref, step).passed


class _Camera:
    def tan_half_fov(self):
        return (0.5, 0.5)


def test_a_ray_reaches_only_the_light_within_its_radius():
    """reach_max: a flat G-buffer at depth 5 (64 x 64, tan 0.5: 1 pixel = 0.078 units), rays
    of radius 0.6 (within ~9 pixels): a pixel 3 pixels from a bright one can gather it, one 42
    pixels away cannot."""
    n = 64
    gb = {"alpha": torch.ones(n, n, 1), "depth": torch.full((n, n, 1), 5.0)}
    direct = np.full((n, n, 4), 0.1, np.float32)
    direct[32, 32, :3] = 100.0
    got = reach_max(gb, direct, _Camera(), 0.6, pixels=np.array([[35, 32], [2, 62]]))
    assert got[0, 0] == 100.0 and got[1, 0] == pytest.approx(0.1)
