"""The overlay at the top right of the image: frame time, GPU time per pass, the graph's reuse and
the renderer's memory (:func:`frame_lines`), and the message line while the panel is hidden."""
from __future__ import annotations

from viewer.models import SAMPLING_MODELS, sample_count

from .choices import ERROR_COLOUR


def draw_overlay(imgui, viewer) -> list[str]:
    """Frame time, per-pass GPU time (timer queries) and what is shown, top right; returns the
    lines drawn."""
    io = imgui.get_io()
    imgui.set_next_window_pos((io.display_size.x - 8, 8), imgui.Cond_.always, (1.0, 0.0))
    imgui.set_next_window_bg_alpha(0.55)
    flags = (imgui.WindowFlags_.no_decoration | imgui.WindowFlags_.always_auto_resize
             | imgui.WindowFlags_.no_inputs | imgui.WindowFlags_.no_focus_on_appearing
             | imgui.WindowFlags_.no_nav)
    imgui.begin("##overlay", None, flags)
    scene = viewer.current_scene()
    w, h = scene.camera.size
    lines = [f"{viewer.frame_ms:6.2f} ms frame  {scene.render.model}  {w}x{h}"]
    targets = viewer.targets
    if targets is not None and scene.render.model in SAMPLING_MODELS:
        lines.append(f"samples {targets.samples}/{sample_count(scene.render)}")
    lines += [f"{name:>8}: {ms:7.3f} ms GPU" for name, ms in viewer.timers.ms.items()]
    lines += frame_lines(viewer.renderer)
    for line in lines:
        imgui.text(line)
    if viewer.state.message and not viewer.state.show_ui:  # else the panel shows it
        imgui.text_colored(ERROR_COLOUR, viewer.state.message)
        lines.append(viewer.state.message)
    imgui.end()
    return lines


def frame_lines(renderer) -> list[str]:
    """The overlay's lines on the last frame's graph (the passes it reused) and the renderer's
    memory: bytes and entries per cache, against each budget (:meth:`Renderer.memory`)."""
    from viewer.cache import mib

    lines = []
    graph = renderer.last_graph
    if graph is not None:
        reused = [p.name for p in graph.passes if p.reused and not p.culled]
        lines.append("reused: " + (", ".join(reused) if reused else "nothing"))
    for name, s in renderer.memory().items():
        budget = (f" / {mib(s.max_bytes)}" if s.max_bytes is not None
                  else f" / {s.max_items}" if s.max_items is not None else "")
        lines.append(f"{name:>12}: {mib(s.bytes):>10}{budget}  ({s.items})")
    return lines
