"""Opening what ``relight render``, ``relight view`` and ``relight scene`` are given: a scene
file, or asset files made into a scene (:func:`viewer.scene.assets.open_assets`); and ``relight
scene``, which prints that scene as TOML to continue from."""
from __future__ import annotations

import os

from viewer.errors import SceneError

from .argtypes import _nonnegative_float
from .common import _demo_path, _parse_size, parse_settings

ENV_HELP = ("environment: sky | studio (default) | white | an equirect .exr/.hdr (linear) or "
            ".png/.jpg (sRGB, clipped)")
UP_HELP = ("the assets' up axis: +Y | +Z | -Y | -Z | +X | -X (default: glTF +Y; PLY/.splat: "
           "the header's marker, else detected; said in one line)")
FLOOR_HELP = ("a ground under the assets: catcher (the default of a bare --floor: only the "
              "shadows it receives, fading into the environment) | slab (a matte grey plane)")
SUN_HELP = ("the environment's compact sun times this (0: the same sky without its sun; default "
            "1), baked into the map the viewer and the reference both light with")
VARIANT_HELP = ("a glTF material variant (KHR_materials_variants) by name, for every glTF "
                "object (an unknown name lists the file's)")
SET_HELP = ("a [render] setting by its scene-file key, the value as in TOML (repeatable: --set "
            "raytrace=true --set ssao_rays=16 --set tonemap=aces); named options such as "
            "--model win over it")


def model_help(prefix: str = "shading model") -> str:
    from viewer.models import MODELS

    return f"{prefix}: {' | '.join(MODELS)}"


def add_asset_arguments(p, model: bool = True, size: bool = True) -> None:
    """The options every command that opens assets takes (``model``/``size``: also those two,
    for a command that does not have them yet)."""
    p.add_argument("--env", metavar="FILE|sky|studio|white", help=ENV_HELP)
    p.add_argument("--sun-strength", type=_nonnegative_float, metavar="S", help=SUN_HELP)
    p.add_argument("--up", metavar="AXIS", help=UP_HELP)
    p.add_argument("--floor", nargs="?", const="catcher", choices=("catcher", "slab"),
                   help=FLOOR_HELP)
    p.add_argument("--set", action="append", metavar="KEY=VALUE", help=SET_HELP)
    p.add_argument("--variant", metavar="NAME", help=VARIANT_HELP)
    if model:
        p.add_argument("--model", help=model_help())
    if size:
        p.add_argument("--size", help="WxH (default 512x512, or the scene file's [camera] size)")


def glue_up_values(argv: list[str]) -> list[str]:
    """``--up -Z`` -> ``--up=-Z``: argparse would take ``-Z`` for an option of its own."""
    out, i = [], 0
    argv = list(argv)
    while i < len(argv):
        if argv[i] == "--up" and i + 1 < len(argv) and argv[i + 1].upper() in ("-X", "-Y", "-Z"):
            out.append(f"--up={argv[i + 1]}")
            i += 2
        else:
            out.append(argv[i])
            i += 1
    return out


def open_input(args):
    """``(scene, contents)`` of the command line's positionals: none (the built-in demo), one
    scene file, or asset files; ``contents`` is what :func:`viewer.scene.assets.open_assets` loaded
    (hand it to the renderer with :func:`hand_over`). ``--env`` replaces a scene file's
    environment (``--sun-strength`` scales its sun, either way); ``--up`` and ``--floor`` are
    for assets only; ``--set KEY=VALUE`` changes
    ``[render]`` settings of either (checked before anything is loaded); ``--variant NAME``
    sets every glTF object's material variant (:func:`with_variant`)."""
    from viewer.scene.assets import environment_spec, is_scene_file, open_assets
    from viewer.scene.description import load_scene

    settings = parse_settings(getattr(args, "set", None))
    inputs = args.scene or []
    inputs = [inputs] if isinstance(inputs, (str, os.PathLike)) else list(inputs)
    env, up, floor = getattr(args, "env", None), getattr(args, "up", None), getattr(args, "floor",
                                                                                  False)
    later = [p for p in inputs[1:] if is_scene_file(p)]
    if later:
        raise SceneError("a scene file is opened alone, not after asset files",
                         where=later[0])
    if not inputs or is_scene_file(inputs[0]):
        if len(inputs) > 1:
            raise SceneError(f"a scene file is opened alone, not with {', '.join(inputs[1:])} "
                             f"(add them to its [[objects]])", where=inputs[0])
        if up is not None or floor:
            raise SceneError("--up and --floor are for asset files; a scene file says its "
                             "objects' transforms itself", where=inputs[0] if inputs else "demo")
        scene = load_scene(inputs[0] if inputs else _demo_path())
        if env is not None:
            from dataclasses import replace

            scene = replace(scene, environment=environment_spec(env))
        scene = scene.with_render(**settings) if settings else scene
        return with_variant(with_sun_strength(scene, args), getattr(args, "variant", None)), ()
    size = _parse_size(args.size) if getattr(args, "size", None) else None
    opened = open_assets(inputs, env=env or "studio", up=up, floor=floor, size=size)
    scene = opened.scene.with_render(**settings) if settings else opened.scene
    scene = with_sun_strength(scene, args)
    variant = getattr(args, "variant", None)
    if variant is None:
        return scene, opened.contents
    return with_variant(scene, variant), ()  # reloaded with the variant's materials


def with_sun_strength(scene, args):
    """``scene`` with ``--sun-strength`` (when given) as its environment's ``sun_strength``."""
    strength = getattr(args, "sun_strength", None)
    return scene if strength is None else scene.with_environment(sun_strength=strength)


def with_variant(scene, variant: str | None):
    """``scene`` with every glTF mesh object's material variant set to ``variant`` (None:
    unchanged); a scene without a glTF object is a one-line SceneError. The name itself is
    checked where the file loads (an unknown one lists the file's variants)."""
    if variant is None:
        return scene
    from dataclasses import replace

    objects = tuple(replace(o, variant=variant) if o.type == "mesh" and str(o.path).lower()
                    .endswith((".gltf", ".glb")) else o for o in scene.objects)
    if objects == scene.objects:
        raise SceneError("the scene has no glTF object to take a material variant",
                         where="--variant")
    return replace(scene, objects=objects)


def hand_over(renderer, contents) -> None:
    """Give ``renderer`` the content :func:`open_input` loaded, so no file is read twice; its
    geometry budget grows to hold it (content added in memory cannot be reloaded)."""
    if not contents:
        return
    import numpy as np

    def nbytes(content):
        arrays = ([v for v in vars(content).values() if isinstance(v, np.ndarray)]
                  if hasattr(content, "means") else
                  [a for m in content for a in (*vars(m).values(), *m.textures.values())
                   if isinstance(a, np.ndarray)])
        return sum(a.nbytes for a in arrays)

    cache = renderer.geometry_cache
    budget = cache.stats().max_bytes
    need = 3 * sum(nbytes(c) for _, c in contents)  # CPU arrays + GPU copies + headroom
    if budget is not None and need > budget:
        cache.resize(need)
    for obj, content in contents:
        renderer.add_geometry(obj, content)


def apply_model(scene, model):
    """``--model`` checked as a scene file's ``[render] model`` is, named by the option."""
    if model is None:
        return scene
    from viewer.scene.description import validate_render

    validate_render({"model": model}, "--model")
    return scene.with_render(model=model)


def cmd_scene(args) -> int:
    import sys

    from viewer.scene.files import scene_toml

    scene, _ = open_input(args)
    scene = apply_model(scene, args.model)
    if args.size and scene.camera.size != _parse_size(args.size):  # a scene file's camera
        scene = scene.with_camera(size=_parse_size(args.size))
    words = ["relight", "scene", *(args.scene or [])]
    for opt in ("env", "sun_strength", "up", "model", "size", "variant"):
        if getattr(args, opt, None) is not None:
            words += [f"--{opt.replace('_', '-')}", str(getattr(args, opt))]
    if args.floor:
        words += ["--floor"] + ([] if args.floor == "catcher" else [args.floor])
    for setting in args.set or ():
        words += ["--set", setting]
    sys.stdout.write(scene_toml(scene, "made by " + " ".join(words)
                                + " - render it with: relight render THIS.toml --out FILE"))
    return 0
