"""``relight view``: the interactive viewer (:mod:`relight.app`), or its screenshot offscreen."""
from __future__ import annotations

from pathlib import Path

from viewer.errors import RelightError, SceneError

from .common import _context_options, _parse_size
from .scene import apply_model, hand_over, open_input

_REFERENCE_VIEWS = ("difference", "error")  # the views that compare the render to --reference


def cmd_view(args) -> int:
    try:
        import imgui_bundle  # noqa: F401  (before glfw: both must use the same libglfw)
    except ImportError as exc:
        raise RelightError(f"relight view needs imgui-bundle: pip install -e '.[gui]' ({exc})",
                           where="view") from None
    from ..app.window import Viewer

    if args.frames is not None and args.frames < 1:
        raise SceneError(f"--frames must be at least 1, got {args.frames}", where="--frames")
    shot = Path(args.screenshot) if args.screenshot else None
    if shot is not None:
        if shot.suffix.lower() not in (".png", ".exr"):
            raise SceneError("--screenshot must end in .png (the view) or .exr (linear radiance)",
                             where=shot)
        if not shot.resolve().parent.is_dir():
            raise SceneError("output folder does not exist", where=shot.parent)
    if args.screenshot_ui and (shot is None or shot.suffix.lower() != ".png"):
        raise SceneError("--screenshot-ui needs --screenshot FILE.png", where="--screenshot-ui")
    if args.view in _REFERENCE_VIEWS and not args.reference:
        raise SceneError(f"the {args.view} view needs --reference FILE (a linear EXR/HDR render "
                         f"to compare against)", where="--view")
    scene, contents = open_input(args)  # a scene file, or assets made into a scene
    scene = apply_model(scene, args.model)
    if args.size:
        scene = scene.with_camera(size=_parse_size(args.size))
    window = _parse_size(args.window, "--window") if args.window else None
    viewer = Viewer(scene, window_size=window, offscreen=args.offscreen,
                    options=_context_options(args),
                    title=f"relight view - {Path(scene.source).name if scene.source else 'scene'}")
    viewer.state.fit_view = args.fit_window
    try:
        hand_over(viewer.renderer, contents)
        if args.reference:
            viewer.frame()
            if not viewer.load_reference(args.reference):
                raise RelightError(viewer.state.message)
        if args.view:  # after the reference: a frame drawn in an error view without one would
            viewer.state.view = args.view  # fall back to the ordinary image
        frames = args.frames
        if frames is None and (args.offscreen or shot is not None):
            frames = 1
        viewer.run(frames=frames)
        if viewer.renders == 0:  # the scene itself failed (a missing mesh, an unknown model)
            raise RelightError(viewer.state.message or "nothing could be rendered")
        if shot is not None:
            viewer.screenshot(shot, ui=args.screenshot_ui)
            if not args.quiet:
                frames = viewer.frames
                print(f"{frames} frame{'' if frames == 1 else 's'} -> {shot}")
    finally:
        viewer.close()
    return 0
