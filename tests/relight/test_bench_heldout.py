"""``relight bench --heldout DATA``: every model scored against a held-out dataset's targets, each
dataset's Pareto front (lower ms, higher PSNR) marked."""
import math

import pytest

from relight.bench.heldout import heldout_front, heldout_rows
from relight.bench.run import BenchConfig, _same_heldout
from viewer.errors import RelightError


def _row(dataset, model, ms, psnr):
    return {"dataset": dataset, "model": model, "variant": "", "ms": ms, "psnr": psnr}


def test_front_is_per_dataset_and_drops_dominated_rows():
    rows = [_row("a", "fast", 1.0, 20.0), _row("a", "slow_worse", 5.0, 19.0),
            _row("a", "slow_better", 5.0, 25.0), _row("a", "nan", math.nan, 30.0),
            _row("b", "fast", 1.0, 30.0), _row("b", "slow_better", 5.0, 31.0),
            _row("b", "tie_slower", 6.0, 31.0)]
    front = heldout_front(rows)
    assert [(r["dataset"], r["model"]) for r in front] == [
        ("a", "fast"), ("a", "slow_better"), ("b", "fast"), ("b", "slow_better")]


def test_stored_rows_are_reused_only_for_the_same_datasets(tmp_path):
    rows = [{"dataset_path": str(tmp_path / "x")}]
    assert _same_heldout(rows, BenchConfig(heldout=(str(tmp_path / "x"),)))
    assert not _same_heldout(rows, BenchConfig(heldout=(str(tmp_path / "y"),)))
    assert _same_heldout([], BenchConfig())


def test_heldout_rows_score_every_model_and_mark_the_front(tmp_path, ctx):
    from learned.data.generator import GeneratorConfig, generate
    from learned.evaluate import models_to_evaluate
    from viewer.renderer import Renderer

    data = tmp_path / "held"
    r = Renderer(ctx=ctx)
    try:
        generate(data, GeneratorConfig(count=2, size=16, samples=4, seed=5, env_width=32),
                 renderer=r, progress=False)
        rows = heldout_rows(r, [str(data)], teacher_samples=2)
        with pytest.raises(RelightError) as info:
            heldout_rows(r, [str(tmp_path / "missing")])
    finally:
        r.release()
    assert "missing" in str(info.value) and "\n" not in str(info.value)
    assert len(rows) == len(models_to_evaluate(2))
    assert all(row["dataset"] == "held" and row["count"] == 2 for row in rows)
    front = [row for row in rows if row["pareto"]]  # in the rows' order; heldout_front: by time
    assert front and {id(row) for row in front} == {id(row) for row in heldout_front(rows)}
    best = max(rows, key=lambda row: row["psnr"])
    fastest = min(rows, key=lambda row: row["ms"])
    assert best["pareto"] and fastest["pareto"]
