"""``pareto.png``'s point labels (relight/bench/labels.py): no two overlap, each lies inside its
axes and off the legend - on the committed bench results and on a tight cluster of points."""
import itertools
import json

import numpy as np
import pytest
from assets import ASSET_ROOT

matplotlib = pytest.importorskip("matplotlib", reason="the bench extra draws the plot")
matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
from matplotlib.text import Text  # noqa: E402

from relight.bench.labels import place_labels  # noqa: E402
from relight.bench.report import pareto_figure  # noqa: E402


def _text_box(text, renderer):
    return Text.get_window_extent(text, renderer)  # the words only, not a leader line


def _check_labels(ax, renderer, texts):
    frame = ax.get_window_extent(renderer)
    boxes = [_text_box(t, renderer) for t in texts]
    for t, b in zip(texts, boxes):
        assert frame.x0 <= b.x0 and b.x1 <= frame.x1 and frame.y0 <= b.y0 and b.y1 <= frame.y1, \
            f"{t.get_text()!r} leaves its axes"
    for (ta, a), (tb, b) in itertools.combinations(zip(texts, boxes), 2):
        assert not a.overlaps(b), f"{ta.get_text()!r} overlaps {tb.get_text()!r}"
    legend = ax.get_legend()
    if legend is not None:
        lb = legend.get_window_extent(renderer)
        for t, b in zip(texts, boxes):
            assert not b.overlaps(lb), f"{t.get_text()!r} overlaps the legend"


def test_committed_pareto_plot_labels_do_not_overlap():
    rows = json.loads((ASSET_ROOT / "bench" / "bench.json").read_text())["results"]
    fig = pareto_figure(rows)
    try:
        fig.canvas.draw()
        renderer = fig.canvas.get_renderer()
        labelled = [ax for ax in fig.axes if ax.texts]
        assert len(labelled) == 2  # the two panels against the references
        names = [t.get_text() for ax in labelled for t in ax.texts]
        assert "ggx_split_sum multiscatter fp16" in names and "ggx_split_sum multiscatter" in names
        for ax in labelled:
            _check_labels(ax, renderer, ax.texts)
    finally:
        plt.close(fig)


def test_a_tight_cluster_gets_separate_labels():
    fig, ax = plt.subplots(figsize=(4, 3), dpi=110)
    try:
        rng = np.random.default_rng(0)
        points = np.column_stack([10 + rng.normal(0, 0.05, 12), 10 + rng.normal(0, 0.05, 12)])
        ax.scatter(points[:, 0], points[:, 1], s=22, label="points")
        ax.plot(points[:3, 0], points[:3, 1], "k--", label="a line")
        ax.set_xlim(8, 12)
        ax.set_ylim(8, 12)
        ax.legend(loc="upper right", fontsize=7)
        fig.canvas.draw()
        legend = ax.get_legend().get_window_extent()
        labels = [f"label {i} " + "x" * (i % 4) for i in range(len(points))]
        texts = place_labels(ax, points, labels, avoid=[legend])
        fig.canvas.draw()
        assert [t.get_text() for t in texts] == labels
        _check_labels(ax, fig.canvas.get_renderer(), texts)
    finally:
        plt.close(fig)
