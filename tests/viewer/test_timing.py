"""Pass timing: fenced wall clock on llvmpipe (its timer queries measure submission only)."""
import math

from viewer.gl.timing import PassTimer
from viewer.renderer import Renderer
from viewer.scene.description import scene_from_dict


def test_renderer_profiler_times_every_pass(ctx):
    renderer = Renderer(ctx=ctx)
    timer = PassTimer(ctx)
    timer.enabled = True
    renderer.profiler = timer
    scene = scene_from_dict({"camera": {"size": [32, 32]}, "environment": {"procedural": "white"},
                             "objects": [{"type": "sphere"}]})
    renderer.draw(scene)
    ms = timer.milliseconds()
    assert {"gbuffer", "shade", "tonemap"} <= set(ms)
    assert all(v >= 0 and math.isfinite(v) for v in ms.values())
    if "llvmpipe" in ctx.info["GL_RENDERER"]:
        assert timer.mode == "wall"
    timer.enabled = False
    timer.reset()
    renderer.draw(scene)
    assert timer.milliseconds() == {}
    renderer.release()


def test_deferred_queries_report_the_previous_frame(ctx):
    """The interactive loop's timer (the window's): double-buffered queries, read one frame late
    so reading never stalls; wall mode reports the frame just drawn."""
    renderer = Renderer(ctx=ctx)
    renderer.reuse_passes = False  # both frames draw the G-buffer (the same scene twice)
    scene = scene_from_dict({"camera": {"size": [32, 32]}, "environment": {"procedural": "white"},
                             "objects": [{"type": "sphere"}]})
    for mode in ("query", "wall"):
        timer = PassTimer(ctx, mode=mode, deferred=True)
        timer.enabled = True
        renderer.profiler = timer
        renderer.draw(scene)
        timer.end_frame()
        first = dict(timer.ms)
        renderer.draw(scene)
        timer.end_frame()
        assert {"gbuffer", "shade", "tonemap"} <= set(timer.ms), (mode, timer.ms)
        if mode == "query":
            assert first == {}  # nothing finished yet: results come one frame late
        else:
            assert {"gbuffer", "shade", "tonemap"} <= set(first)
        assert all(v >= 0 or math.isnan(v) for v in timer.ms.values())
        timer.release()
    renderer.profiler = None
    renderer.release()
