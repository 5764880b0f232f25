"""The viewer overlay's frame lines: which passes the last frame reused, and every cache's bytes
against its budget (Renderer.memory)."""
from relight.app.panels import frame_lines
from viewer.renderer import Renderer
from viewer.scene.description import scene_from_dict

SCENE = {"camera": {"size": [24, 16]}, "environment": {"procedural": "white", "width": 32},
         "objects": [{"type": "sphere"}]}


def test_overlay_reports_reuse_and_memory(ctx):
    r = Renderer(ctx=ctx)
    try:
        assert not any(line.startswith("reused") for line in frame_lines(r))  # no frame yet
        scene = scene_from_dict(SCENE)
        r.draw(scene)
        first = frame_lines(r)
        assert first[0] == "reused: nothing"
        r.draw(scene.with_render(exposure=1.0))
        lines = frame_lines(r)
        assert lines[0] == "reused: gbuffer, shade"
        caches = {ln.split(":")[0].strip(): ln for ln in lines[1:]}
        assert {"targets", "programs", "geometry", "environments"} <= set(caches)
        assert "/ 1024.0 MiB" in caches["targets"]  # the default budget
        # the targets line counts the frame's radiance, display and G-buffer
        items = int(caches["targets"].rsplit("(", 1)[1].rstrip(")"))
        assert items >= 3
    finally:
        r.release()
