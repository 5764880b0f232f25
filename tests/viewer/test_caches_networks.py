"""Bounded caches of neural networks: the uploaded weight data of the buffered storages (eviction
releases the GL buffer; counted for real by viewer.gl.tracking) and the loaded weight files."""
import shutil

import numpy as np
import pytest

from viewer.gl.tracking import track_objects
from viewer.renderer import Renderer
from viewer.scene.description import scene_from_dict

BASE = {
    "camera": {"position": [0, 0.4, 2.4], "target": [0, 0.2, 0], "fov_y": 45, "size": [32, 24]},
    "environment": {"procedural": "sky", "width": 64},
    "objects": [],
    "render": {"tonemap": "none", "shadows": False},
}


@pytest.fixture
def tracker(ctx):
    t = track_objects(ctx)
    yield t
    t.uninstall()


def _tiny_student(folder):
    """A random one-hidden-layer student (4 units, no Fourier features) exported to ``folder``:
    its uniform-block code compiles in a second on llvmpipe (the shipped student's, in ~30 s)."""
    torch = pytest.importorskip("torch")
    from learned.export import export
    from learned.neural.student import Student

    torch.manual_seed(0)
    export(Student(hidden=(4,), num_freqs=0), folder / "tiny.safetensors")
    return folder / "tiny.safetensors"


def test_neural_weight_uploads_are_bounded_and_released(ctx, tracker, tmp_path):
    scene = scene_from_dict({**BASE, "objects": [
        {"type": "sphere", "center": [0, 0.4, 0], "radius": 0.4}],
        "render": {**BASE["render"], "model": "neural",
                   "weights": str(_tiny_student(tmp_path))}})
    ubo, tex = scene.with_render(neural_storage="ubo"), scene.with_render(neural_storage="texture")
    r = Renderer(ctx=ctx)
    try:
        first = r.render(ubo).radiance
        shade = r.resources.layout_pass("shade", r.layout_for(ubo))
        shade.weights.resize(max_items=1)
        level = tracker.live()
        r.render(tex)  # its weights texture evicts the uniform buffer of the ubo storage
        assert len(shade.weights) == 1 and shade.weights.stats().evictions == 1
        assert tracker.live()["Buffer"] == level["Buffer"] - 1
        np.testing.assert_array_equal(r.render(ubo).radiance, first)
    finally:
        r.release()


def test_loaded_networks_are_bounded(tmp_path):
    from viewer.neural import network
    from viewer.neural.format import default_weights

    saved = network._CACHE.max_items
    network._CACHE.clear()
    network._CACHE.resize(max_items=2)
    before = network.cache_stats().evictions  # counters are the process's, not this test's
    try:
        for i in range(3):
            path = shutil.copy(default_weights("student"), tmp_path / f"w{i}.safetensors")
            network.load_network(path, "student")
        stats = network.cache_stats()
        assert stats.items == 2 and stats.evictions - before == 1
    finally:
        network._CACHE.resize(max_items=saved)
        network._CACHE.clear()
