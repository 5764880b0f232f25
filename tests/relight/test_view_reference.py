"""``relight view --reference truth.exr --view error`` (or ``difference``) shows that view once the
reference is loaded, not the ordinary image; an error view without a reference is a one-line
error naming the option."""
import numpy as np
import pytest

pytestmark = pytest.mark.gui
pytest.importorskip("imgui_bundle", reason="the viewer needs imgui-bundle ([gui])")

BASE = ["view", "--offscreen", "--size", "32x20"]


def _view(tmp_path, monkeypatch, *extra, shot="view.png"):
    """Run ``relight view`` with ``extra``; returns (the screenshot's pixels, the state's view
    when the viewer closed)."""
    from relight.app.window import Viewer
    from relight.cli import main
    from viewer.imageio import read_image

    seen = {}
    close = Viewer.close

    def recording_close(self):
        seen["view"] = self.state.view
        close(self)

    monkeypatch.setattr(Viewer, "close", recording_close)
    out = tmp_path / shot
    assert main(BASE + ["--screenshot", str(out), "-q", *extra]) == 0
    return read_image(str(out))[0], seen["view"]


@pytest.mark.parametrize("view", ["error", "difference"])
def test_requested_error_view_stays_after_the_reference_loads(tmp_path, ctx, monkeypatch, view):
    from viewer.imageio import write_exr

    render, _ = _view(tmp_path, monkeypatch, shot="render.exr")
    truth = tmp_path / "truth.exr"
    write_exr(truth, render[..., :3] * 0.5)  # half as bright: the error is not zero anywhere lit
    plain, plain_view = _view(tmp_path, monkeypatch, "--reference", str(truth), shot="plain.png")
    assert plain_view == "display"
    shown, shown_view = _view(tmp_path, monkeypatch, "--reference", str(truth), "--view", view)
    assert shown_view == view
    assert not np.array_equal(shown, plain)


def test_error_view_without_a_reference_is_an_error(tmp_path, ctx, capsys):
    from relight.cli import main

    assert main(BASE + ["--view", "error", "--screenshot", str(tmp_path / "v.png")]) != 0
    err = capsys.readouterr().err.strip()
    assert "--view" in err and "--reference" in err and "\n" not in err
