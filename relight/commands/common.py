"""What several sub-commands share: the demo scene, ``--size WxH``, ``--set KEY=VALUE``, the GL
context options and the import of a torch-side module with a one-line error when torch is
missing."""
from __future__ import annotations

from pathlib import Path

from viewer.errors import RelightError, SceneError


DEMO_SCENE = "demo.toml"


def _demo_path() -> Path:
    from assets import ASSET_ROOT

    return ASSET_ROOT / "scenes" / DEMO_SCENE


def _parse_size(text: str, option: str = "--size") -> tuple[int, int]:
    try:
        w, h = (int(x) for x in text.lower().split("x"))
    except ValueError:
        raise SceneError(f"{option} must look like 512x512, got {text!r}", where=option) from None
    if not (1 <= w <= 16384 and 1 <= h <= 16384):
        raise SceneError(f"{option} {w}x{h} is outside 1..16384", where=option)
    return w, h


def parse_settings(texts, option: str = "--set") -> dict:
    """``--set KEY=VALUE ...`` -> the ``[render]`` settings they name, checked by the scene files'
    one validator (:func:`viewer.scene.checks.validate_render`): a bad key or value is the same
    one-line :class:`SceneError` a scene file gives, naming ``option``. A value is read as a TOML
    value (``true``, ``16``, ``-1``, ``"aces"``), else taken as a plain string (``aces``,
    ``path/to/w.npz``); a key given twice keeps its last value. Paths are relative to the
    working folder."""
    import tomllib

    from viewer.scene.checks import validate_render

    raw: dict = {}
    for text in texts or ():
        key, eq, value = text.partition("=")
        key, value = key.strip(), value.strip()
        if not eq or not key:
            raise SceneError(f"must look like KEY=VALUE (a [render] key), got {text!r}",
                             where=option)
        try:
            parsed = tomllib.loads(f"v = {value}")
            raw[key] = parsed["v"] if set(parsed) == {"v"} else value
        except tomllib.TOMLDecodeError:
            raw[key] = value
    return validate_render(raw, option) if raw else {}


def _context_options(args):
    from viewer.gl import ContextOptions

    return ContextOptions(software=getattr(args, "software", False))


def _learned(what: str):
    import importlib

    try:
        return importlib.import_module(what)
    except ImportError as exc:
        raise RelightError(f"this command needs torch: pip install -e '.[learned]' ({exc})",
                           where=what) from None
