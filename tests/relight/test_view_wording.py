"""``relight view --screenshot`` counts its frames in English: "1 frame", "2 frames"."""
import pytest

pytestmark = pytest.mark.gui
pytest.importorskip("imgui_bundle", reason="the viewer needs imgui-bundle ([gui])")


@pytest.mark.parametrize("frames, said", [(None, "1 frame ->"), ("2", "2 frames ->")])
def test_screenshot_line_counts_frames(tmp_path, ctx, capsys, frames, said):
    from relight.cli import main

    out = tmp_path / "view.png"
    args = ["view", "--offscreen", "--size", "32x20", "--screenshot", str(out)]
    assert main(args + (["--frames", frames] if frames else [])) == 0
    assert capsys.readouterr().out.strip() == f"{said} {out}"
