"""The viewer's file actions: files dropped on the window, opening a scene, an asset, an
environment file, a reference render for the difference views, saving what is shown as a scene.
A mixin of :class:`~relight.app.window.Viewer` (it uses the window's state, GL context and
messages). Every action that fails leaves the scene on screen as it was and says why in one line
(the message line: the panel, or the overlay while the panel is hidden)."""
from __future__ import annotations

import warnings
from dataclasses import replace
from pathlib import Path

import numpy as np

from viewer.errors import InputError, RelightError
from viewer.gl.context import make_current
from viewer.scene.description import load_scene

from .state import load_into, with_environment_file

SCENE_SUFFIXES = (".toml",)
IMAGE_SUFFIXES = (".hdr", ".exr", ".pfm", ".tif", ".tiff", ".png", ".jpg", ".jpeg")
ASSET_SUFFIXES = (".gltf", ".glb", ".obj", ".ply", ".splat")  # opened by viewer.scene.assets


class FileActions:
    """Opening and saving files; mixed into :class:`~relight.app.window.Viewer`."""

    def drop(self, paths: list[str]) -> None:
        """Files dropped on the window: a ``.toml`` scene opens; assets (glTF, GLB, OBJ, PLY,
        ``.splat``) dropped together open as one framed scene (:meth:`open_assets`); an image
        becomes the environment (after the scene or assets, so it lights them)."""
        kinds: dict[str, list[str]] = {"scene": [], "asset": [], "image": []}
        for path in paths:
            suffix = Path(path).suffix.lower()
            kind = ("scene" if suffix in SCENE_SUFFIXES else "asset" if suffix in ASSET_SUFFIXES
                    else "image" if suffix in IMAGE_SUFFIXES else None)
            if kind is None:
                self.state.message = str(InputError(
                    f"unsupported file type {suffix or '(none)'}: drop a .toml scene, an asset "
                    f"({', '.join(ASSET_SUFFIXES)}) or an HDR/EXR environment", where=path))
            else:
                kinds[kind].append(path)
        for path in kinds["scene"]:
            self.open_scene(path)
        if kinds["asset"]:
            self.open_assets(kinds["asset"])
        for path in kinds["image"]:
            self.set_environment_file(path)

    def open_assets(self, paths: list[str]) -> bool:
        """A scene framing ``paths`` (``viewer.scene.assets.scene_from_assets``) at the current render
        size, lit by the current environment. A file that cannot be read keeps the scene on
        screen (its geometry loads on the first draw: a failure there is rejected like any
        other)."""
        from viewer.scene.assets import scene_from_assets

        where = paths[0]
        try:
            with warnings.catch_warnings(record=True) as caught:
                scene = scene_from_assets([str(p) for p in paths], size=self.state.camera.size)
        except RelightError as exc:
            self.state.message = str(exc)
            return False
        except (OSError, ValueError) as exc:  # a reader's own error on a corrupt file
            first = (str(exc).strip().splitlines() or [type(exc).__name__])[0]
            self.state.message = str(InputError(f"cannot open: {first}", where=where))
            return False
        self.state = load_into(self.state, replace(scene, environment=self.state.environment))
        self.state.message = None
        self.show_warnings(caught)
        return True

    def open_scene(self, path: str) -> bool:
        try:
            with warnings.catch_warnings(record=True) as caught:
                scene = load_scene(path)
        except RelightError as exc:
            self.state.message = str(exc)
            return False
        self.state = load_into(self.state, scene)
        self.state.message = None
        self.show_warnings(caught)
        return True

    def set_environment_file(self, path: str) -> None:
        """Use an equirect HDR/EXR; a file that cannot be used leaves the environment as it was."""
        self.state = with_environment_file(self.state, str(Path(path).resolve()))
        self.state.message = None

    def load_reference(self, path: str) -> bool:
        """Load a linear render (EXR/HDR, the size of the render) for the difference views."""
        from viewer.imageio import read_image

        try:
            arr, _ = read_image(path, channels=(3, 4))
        except RelightError as exc:
            self.state.message = str(exc)
            return False
        h, w = arr.shape[:2]
        rgba = np.ones((h, w, 4), np.float32)
        rgba[..., :3] = arr[..., :3]
        if self._reference is not None:
            self._reference.release()
        make_current(self.ctx)
        tex = self.ctx.texture((w, h), 4, np.ascontiguousarray(rgba[::-1]).tobytes(), dtype="f4")
        tex.filter = (self.ctx.NEAREST, self.ctx.NEAREST)
        self._reference = tex
        self.state.reference_path = str(path)
        self.state.message = None
        return True

    def save_scene(self, path: str) -> bool:
        """Write what is shown as a scene TOML that ``relight render`` renders identically."""
        from viewer.scene.files import save_scene

        try:
            save_scene(self.current_scene(), path)
        except RelightError as exc:
            self.state.message = str(exc)
            return False
        self.state.message = f"saved {path}"
        return True
