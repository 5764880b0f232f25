"""Pass timing: fenced wall clock on llvmpipe (its timer queries measure submission only)."""
import math

from viewer.gl.timing import PassTimer
from viewer.renderer import Renderer
from viewer.scene import scene_from_dict


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
