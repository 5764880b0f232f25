"""``relight render``: a scene rendered headlessly to EXR (linear) or PNG, with AOVs."""
from __future__ import annotations

from pathlib import Path

from viewer.errors import SceneError

from .common import _context_options, _parse_size
from .scene import hand_over, open_input


def cmd_render(args) -> int:
    from viewer.imageio import write_exr, write_png
    from viewer.frame import check_aovs
    from viewer.renderer import Renderer
    from viewer.scene.description import validate_render

    out = Path(args.out)
    if out.suffix.lower() not in (".exr", ".png"):
        raise SceneError("--out must end in .exr (linear radiance) or .png (tone-mapped sRGB)",
                         where=out)
    if not out.resolve().parent.is_dir():
        raise SceneError("output folder does not exist", where=out.parent)
    scene, contents = open_input(args)  # a scene file, or assets made into a scene
    changes = {k: v for k, v in (("model", args.model), ("samples", args.samples),
                                 ("exposure", args.exposure), ("tonemap", args.tonemap),
                                 ("aa", args.aa), ("ssaa", args.ssaa))
               if v is not None}
    for key, value in changes.items():  # checked as a scene file's [render] is, named by option
        validate_render({key: value}, f"--{key}")
    if changes:
        scene = scene.with_render(**changes)
    aovs = [a.strip() for a in args.aov.split(",") if a.strip()] if args.aov else []
    check_aovs(aovs)  # before any GPU work
    size = _parse_size(args.size) if args.size else None

    renderer = Renderer(options=_context_options(args))
    try:
        hand_over(renderer, contents)
        frame = renderer.render(scene, aovs=tuple(aovs), size=size)
    finally:
        renderer.release()
    # everything is in memory before the first file is written: an error writes nothing
    if out.suffix.lower() == ".exr":
        rgba = frame.radiance if scene.render.display.background == "transparent" else frame.radiance[..., :3]
        write_exr(out, rgba, ["R", "G", "B", "A"][: rgba.shape[2]])
    else:
        keep = 4 if scene.render.display.background == "transparent" else 3
        write_png(out, frame.display[..., :keep])
    written = [out]
    for name in aovs:
        arr = frame.aovs[name]
        names = {1: ["Y"], 3: ["R", "G", "B"]}.get(arr.shape[2])
        path = out.with_name(f"{out.stem}.{name}.exr")
        write_exr(path, arr, names)
        written.append(path)
    if not args.quiet:
        cam = frame.camera
        print(f"rendered {Path(scene.source).name if scene.source else 'scene'} "
              f"({scene.render.model}, {cam.width}x{cam.height}) -> "
              + ", ".join(str(p) for p in written))
    return 0
