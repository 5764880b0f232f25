"""Golden images: small renders of the built-in scenes against stored references (tests/golden).

Tolerances live in tests/golden/golden.toml next to the error they guard. On failure the render,
the reference and a false-colour difference are written to pytest's temporary directory for the
test (named in the failure message; pytest keeps the last three runs), never into the source tree.
"""
from pathlib import Path

import numpy as np
import pytest

from assets import ASSET_ROOT
from viewer.imageio import read_image, write_exr, write_png
from viewer.renderer import Renderer
from viewer.scene.description import load_scene

try:
    import tomllib
except ImportError:  # pragma: no cover
    import tomli as tomllib

GOLDEN = Path(__file__).resolve().parents[1] / "golden"
CASES = tomllib.loads((GOLDEN / "golden.toml").read_text())["golden"]


@pytest.fixture(scope="module")
def renderer(ctx):
    r = Renderer(ctx=ctx)
    yield r
    r.release()


def _false_colour(err: np.ndarray) -> np.ndarray:
    e = np.clip(err / max(float(err.max()), 1e-12), 0, 1)
    return (np.stack([e, 1 - np.abs(2 * e - 1), 1 - e], -1) * 255).astype(np.uint8)


@pytest.mark.parametrize("case", CASES, ids=[c["name"] for c in CASES])
def test_golden(renderer, case, request, tmp_path):
    scene = load_scene(ASSET_ROOT / "scenes" / case["scene"]).with_render(model=case["model"])
    rad = renderer.render(scene, size=tuple(case["size"])).radiance[..., :3]
    assert np.isfinite(rad).all()
    ref_path = GOLDEN / f"{case['name']}.exr"
    if request.config.getoption("--regen-golden"):
        write_exr(ref_path, rad)
        pytest.skip(f"regenerated {ref_path.name}")
    ref, _ = read_image(ref_path, channels=3)
    err = np.abs(rad - ref)
    bad = err > case["max_abs"] + case["max_rel"] * np.abs(ref)
    fraction = bad.any(-1).mean()
    if fraction > case["allowed_fraction"]:
        out = tmp_path
        write_exr(out / f"{case['name']}.render.exr", rad)
        write_exr(out / f"{case['name']}.reference.exr", ref)
        write_png(out / f"{case['name']}.diff.png", _false_colour(err.max(-1)))
    assert fraction <= case["allowed_fraction"], (
        f"{case['name']}: {fraction:.2%} of pixels differ (max abs {err.max():.3g}); "
        f"images in {tmp_path}")
