"""Framing of an asset opened without a scene file (viewer.scene.framing, issue 37): the bundled
plasma gun rendered by the camera ``open_assets`` frames fills the frame's limiting side to 90 %
with equal margins, at every aspect ratio, and is never cut off at the frame's edge."""
import warnings
from pathlib import Path

import numpy as np
import pytest

from viewer.renderer import Renderer
from viewer.scene.assets import open_assets
from viewer.scene.framing import FILL

GUN = Path(__file__).resolve().parents[2] / "assets" / "models" / "cge_plasma_gun" / "plasma.gltf"


@pytest.fixture(scope="module")
def renderer(ctx):
    r = Renderer(ctx=ctx)
    yield r
    r.release()


def _mask(renderer, size, **kw):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the gun's loader warnings are tested elsewhere
        opened = open_assets([GUN], env="white", size=size, **kw)
        for obj, content in opened.contents:
            renderer.add_geometry(obj, content)
        frame = renderer.render(opened.scene.with_render(model="unlit"))
    return frame.radiance[..., 3] > 0.5


# measured (160x120, 200x80, 80x160): coverage 0.61, 0.32, 0.34 (box-corner framing before: 0.13,
# 0.07, 0.22); the limiting side's span 0.89-0.90 (before 0.52, 0.51, 0.72)
@pytest.mark.parametrize("size, least_coverage", [((160, 120), 0.5), ((200, 80), 0.25),
                                                  ((80, 160), 0.25)])
def test_the_gun_fills_the_frame_with_a_margin_at_every_aspect(renderer, size, least_coverage):
    mask = _mask(renderer, size)
    h, w = mask.shape
    rows, cols = np.nonzero(mask)
    assert not (mask[0].any() or mask[-1].any() or mask[:, 0].any() or mask[:, -1].any())
    gaps = np.array([rows.min(), h - 1 - rows.max(), cols.min(), w - 1 - cols.max()])
    span = max((rows.max() - rows.min() + 1) / h, (cols.max() - cols.min() + 1) / w)
    assert FILL - 0.04 <= span <= FILL + 0.02  # 90 % of the limiting side (pixel rounding)
    assert abs(gaps[0] - gaps[1]) <= 2 and abs(gaps[2] - gaps[3]) <= 2  # centred
    assert mask.mean() > least_coverage


@pytest.mark.parametrize("floor", ["slab", "catcher"])
def test_the_floor_is_not_clipped_by_the_tighter_framing(renderer, floor):
    """The camera came closer: near and far still enclose the floor, which covers the frame's
    bottom row from edge to edge (the slab: 3 x the gun's width; the catcher: 6 x)."""
    mask = _mask(renderer, (160, 120), floor=floor)
    assert mask[-1].all()
