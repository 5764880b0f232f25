"""Image-space G-buffer stacks: FFHQ256-PBR sample folders and the 12-channel ShadingFusion EXR.

An image stack is a G-buffer seen from one pinhole camera at the origin looking down -Z with +Y up,
so camera space *is* world space and the stack's normals can be used as world-space normals
(:meth:`ImageGBuffer.camera` is that camera). Every problem is an
:class:`~viewer.errors.InputError` naming the file.

FFHQ256-PBR sample folder (:func:`load_ffhq_pbr`); each channel is one file ``<name>.<ext>``:

=========== ================= ===== =========================================================
name        extensions          C   content
=========== ================= ===== =========================================================
rgb         png jpg jpeg       3/4  target photo, sRGB (optional)
            exr hdr                 ... or linear
albedo      png jpg jpeg       3/4  base colour, sRGB, decoded to linear (required)
            exr                     ... or linear
normal      png exr            3/4  n * 0.5 + 0.5, camera space, +Y up, +Z towards the camera
                                    (required); length < 0.05 inside the mask counts as zero:
                                    set to (0, 0, 1) with one warning giving the count
roughness   png exr            1-4  perceptual roughness, first channel (required)
specular    png exr            1-4  f0 = 0.16 s^2, first channel (optional, default 0.5)
metallic    png exr            1-4  first channel (optional, default 0)
depth       exr                1-4  view-space depth in scene units, first channel (required)
            png                     ... or normalised: D = near + D_n (far - near); 1, 800
ao          png exr            1-4  ambient occlusion, first channel (optional, default 1)
mask        png exr            1-4  coverage, first channel; >= 0.5 is foreground (required)
env         exr hdr            3/4  HDR environment (optional; only its path is kept)
camera.json                         {"fov_y": degrees} or {"fov": degrees}
                                    (required unless the caller passes fov_y)
=========== ================= ===== =========================================================

ShadingFusion stack (:func:`load_stack_exr`, thesis ch. 5): one EXR with exactly 12 channels, in
order albedo (3), roughness (1), specular (1), depth/coordinates (3), normal (3), mask (1), all in
[0, 1]: normals encoded n * 0.5 + 0.5, depth normalised as in thesis appendix B.2,
``D_n = (D - near) / (far - near)``. The last depth/coordinate channel is the normalised depth (the
three are depth replicated or (x, y, z)). OpenEXR stores channels sorted by name, so a file whose
channel names are exactly the ones :func:`save_stack_exr` writes is read by name; any other file is
read by position.

Depth is the positive distance along the view axis (-z_vs), not the Euclidean distance. Pixels with
mask < 0.5 are background: every channel takes the G-buffer background value (depth 0, alpha 0);
foreground alpha is the mask value.
"""
from __future__ import annotations

import json
import math
import os
import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import OpenImageIO as oiio

from ..errors import InputError
from ..gbuffer import CHANNELS
from ..imageio import read_image, write_exr
from ..scene.camera import Camera
from .mesh import srgb_to_linear

STACK_CHANNELS = ("albedo.R", "albedo.G", "albedo.B", "roughness", "specular",
                  "coord.X", "coord.Y", "coord.Z", "normal.X", "normal.Y", "normal.Z", "mask")
_BACKGROUND = {c.name: np.asarray(c.background, np.float32) for c in CHANNELS}
_LINEAR_EXT = (".exr", ".hdr")
_ZERO_NORMAL = 0.05  # shorter decoded normals count as zero (8-bit "zero" is ~0.007 long)


@dataclass
class ImageGBuffer:
    """A G-buffer given as images: channel name (see :mod:`viewer.gbuffer`) -> ``[H, W, C]``."""

    # albedo, normal, roughness, specular, metallic, ao, depth, alpha
    channels: dict[str, np.ndarray]
    fov_y: float  # vertical field of view, degrees
    environment: Path | None = None  # HDR environment that lit the target, if known
    target: np.ndarray | None = None  # [H, W, 3] linear RGB photo / reference rendering
    source: Path | None = None  # folder or file it was loaded from

    @property
    def size(self) -> tuple[int, int]:
        """(W, H) in pixels."""
        h, w = next(iter(self.channels.values())).shape[:2]
        return int(w), int(h)

    def camera(self, near: float = 0.05, far: float = 1000.0) -> Camera:
        """The camera the stack was seen from: origin, looking down -Z, +Y up, this fov and size."""
        return Camera(position=(0.0, 0.0, 0.0), target=(0.0, 0.0, -1.0), up=(0.0, 1.0, 0.0),
                      fov_y=float(self.fov_y), size=self.size, near=near, far=far)

    def view_dirs(self) -> np.ndarray:
        """``[H, W, 3]`` unit directions from the camera through each pixel (see view_dirs_cs)."""
        return view_dirs_cs(*self.size, self.fov_y)


def view_dirs_cs(width: int, height: int, fov_y: float) -> np.ndarray:
    """``[H, W, 3]`` float32 unit camera-space directions from the eye through pixel centres.

    Row 0 is the top of the image; the camera looks down -Z with +Y up. Identical to
    :meth:`viewer.scene.camera.Camera.view_rays_ws` for a camera at the origin looking at -Z.
    """
    cam = Camera(position=(0.0, 0.0, 0.0), target=(0.0, 0.0, -1.0), up=(0.0, 1.0, 0.0),
                 fov_y=float(fov_y), size=(int(width), int(height)))
    return cam.view_rays_ws()


# ---- shared finishing ----------------------------------------------------------------------------
def _finish(channels: dict[str, np.ndarray], mask: np.ndarray, normal_where: str | os.PathLike
            ) -> dict[str, np.ndarray]:
    """Decode-independent clean-up: unit normals inside the mask, background values outside."""
    fg = mask[:, :, 0] >= 0.5
    n = channels["normal"]
    length = np.linalg.norm(n, axis=-1)
    zero = fg & (length < _ZERO_NORMAL)
    if zero.any():
        warnings.warn(f"{normal_where}: {int(zero.sum())} zero-length normals inside the mask "
                      f"were set to face the camera", stacklevel=3)
    n = np.where(zero[..., None], np.float32([0.0, 0.0, 1.0]),
                 n / np.maximum(length, _ZERO_NORMAL)[..., None])
    channels["normal"] = n.astype(np.float32)
    channels["alpha"] = np.where(fg, np.clip(mask[:, :, 0], 0.0, 1.0), 0.0)[..., None]
    for name, arr in channels.items():
        if name == "alpha":
            continue
        channels[name] = np.where(fg[..., None], arr, _BACKGROUND[name]).astype(np.float32)
    channels["alpha"] = channels["alpha"].astype(np.float32)
    return channels


def _check_finite(arr: np.ndarray, what: str, where) -> None:
    bad = ~np.isfinite(arr)
    if bad.any():
        raise InputError(f"{what} has {int(bad.any(axis=-1).sum())} pixels with NaN/Inf values",
                         where=where)


# ---- ShadingFusion 12-channel EXR ----------------------------------------------------------------
def load_stack_exr(path: str | os.PathLike, fov_y: float | None = None, near: float = 1.0,
                   far: float = 800.0) -> ImageGBuffer:
    """Load the 12-channel ShadingFusion stack (see the module docstring).

    The file's ``fov_y`` attribute (degrees) wins over the ``fov_y`` argument; with neither it
    is an :class:`InputError`. ``near``/``far`` undo the depth normalisation of thesis appendix
    B.2.
    """
    path = Path(path)
    arr, names = read_image(path)
    if arr.shape[2] != 12:
        raise InputError(f"has {arr.shape[2]} channels ({','.join(names)}), expected 12: "
                         f"albedo(3) roughness specular depth(3) normal(3) mask", where=path)
    if sorted(names) == sorted(STACK_CHANNELS):
        arr = arr[:, :, [names.index(n) for n in STACK_CHANNELS]]
    for what, sl in (("albedo", slice(0, 3)), ("roughness", slice(3, 4)),
                     ("specular", slice(4, 5)), ("depth", slice(5, 8)),
                     ("normal", slice(8, 11)), ("mask", slice(11, 12))):
        _check_finite(arr[:, :, sl], f"channel {what}", path)
    attr_fov = _exr_attribute(path, "fov_y")
    if attr_fov is None and fov_y is None:
        raise InputError("no fov_y attribute in the file and no fov_y given", where=path)
    fov = float(attr_fov) if attr_fov is not None else float(fov_y)
    if not 0.0 < fov < 180.0:
        raise InputError(f"field of view {fov} is not in (0, 180) degrees", where=path)
    mask = arr[:, :, 11:12]
    depth = near + arr[:, :, 7:8] * (far - near)
    channels = {
        "albedo": arr[:, :, 0:3],
        "roughness": arr[:, :, 3:4],
        "specular": arr[:, :, 4:5],
        "depth": depth,
        "normal": arr[:, :, 8:11] * 2.0 - 1.0,
        "metallic": np.zeros_like(mask),
        "ao": np.ones_like(mask),
    }
    return ImageGBuffer(channels=_finish(channels, mask, path), fov_y=fov, source=path)


def save_stack_exr(path: str | os.PathLike, gbuffer: ImageGBuffer, near: float = 1.0,
                   far: float = 800.0) -> None:
    """Write ``gbuffer`` as a 12-channel ShadingFusion stack (the inverse of load_stack_exr).

    The depth is written normalised to all three coordinate channels; background depth is 0.
    The field of view is stored as the float attribute ``fov_y``.
    """
    path = Path(path)
    ch = gbuffer.channels
    w, h = gbuffer.size
    alpha = ch.get("alpha", np.ones((h, w, 1), np.float32))
    depth = ch["depth"]
    dn = np.where(alpha > 0.0, (depth - near) / (far - near), 0.0)
    out = np.concatenate([ch["albedo"], ch.get("roughness", np.full((h, w, 1), 1.0)),
                          ch.get("specular", np.full((h, w, 1), 0.5)), dn, dn, dn,
                          ch["normal"] * 0.5 + 0.5, alpha], axis=2).astype(np.float32)
    write_exr(path, out, list(STACK_CHANNELS), attributes={"fov_y": float(gbuffer.fov_y)})


def _exr_attribute(path: Path, name: str):
    inp = oiio.ImageInput.open(str(path))
    if inp is None:
        return None
    try:
        return inp.spec().getattribute(name)
    finally:
        inp.close()


# ---- FFHQ256-PBR folder --------------------------------------------------------------------------
_FFHQ = {  # name: (extensions, allowed channel counts, required)
    "rgb": ((".png", ".jpg", ".jpeg", ".exr", ".hdr"), (3, 4), False),
    "albedo": ((".png", ".jpg", ".jpeg", ".exr"), (3, 4), True),
    "normal": ((".png", ".exr"), (3, 4), True),
    "roughness": ((".png", ".exr"), (1, 2, 3, 4), True),
    "specular": ((".png", ".exr"), (1, 2, 3, 4), False),
    "metallic": ((".png", ".exr"), (1, 2, 3, 4), False),
    "depth": ((".exr", ".png"), (1, 2, 3, 4), True),
    "ao": ((".png", ".exr"), (1, 2, 3, 4), False),
    "mask": ((".png", ".exr"), (1, 2, 3, 4), True),
}


def _find(folder: Path, name: str, extensions: tuple[str, ...]) -> Path | None:
    found = sorted(p for p in folder.glob(f"{name}.*") if p.suffix.lower() in extensions)
    if len(found) > 1:
        raise InputError(f"several files for channel {name!r}: "
                         f"{', '.join(p.name for p in found)}", where=folder)
    return found[0] if found else None


def load_ffhq_pbr(folder: str | os.PathLike, fov_y: float | None = None, near: float = 1.0,
                  far: float = 800.0) -> ImageGBuffer:
    """Load one FFHQ256-PBR sample folder (layout in the module docstring).

    ``fov_y`` (degrees) is used when the folder has no ``camera.json``; ``near``/``far`` undo
    the normalisation of a ``depth.png``.
    """
    folder = Path(folder)
    if not folder.is_dir():
        raise InputError("sample folder not found", where=folder)
    files: dict[str, Path] = {}
    data: dict[str, np.ndarray] = {}
    size_of: tuple[tuple[int, int], Path] | None = None
    for name, (exts, counts, required) in _FFHQ.items():
        p = _find(folder, name, exts)
        if p is None:
            if required:
                raise InputError(f"missing required channel {name!r} "
                                 f"({'/'.join(e[1:] for e in exts)})", where=folder)
            continue
        arr, _ = read_image(p, channels=counts)
        hw = arr.shape[:2]
        if size_of is None:
            size_of = (hw, p)
        elif hw != size_of[0]:
            (h0, w0), p0 = size_of
            raise InputError(f"size mismatch: {p.name} is {hw[1]}x{hw[0]} but {p0.name} is "
                             f"{w0}x{h0}", where=p)
        _check_finite(arr, "image", p)
        files[name] = p
        data[name] = arr
    h, w = size_of[0]

    def linear(name: str) -> np.ndarray:
        rgb = data[name][:, :, :3]
        return rgb if files[name].suffix.lower() in _LINEAR_EXT else srgb_to_linear(rgb)

    def scalar(name: str, default: float) -> np.ndarray:
        if name in data:
            return data[name][:, :, :1]
        return np.full((h, w, 1), default, np.float32)

    depth = data["depth"][:, :, :1]
    if files["depth"].suffix.lower() == ".png":
        depth = near + depth * (far - near)
    mask = data["mask"][:, :, :1]
    fg = mask[:, :, 0] >= 0.5
    if (depth[:, :, 0][fg] <= 0.0).any():
        raise InputError(f"{int((depth[:, :, 0][fg] <= 0).sum())} pixels inside the mask have "
                         f"non-positive depth", where=files["depth"])
    channels = {
        "albedo": linear("albedo"),
        "normal": data["normal"][:, :, :3] * 2.0 - 1.0,
        "roughness": scalar("roughness", 1.0),
        "specular": scalar("specular", 0.5),
        "metallic": scalar("metallic", 0.0),
        "ao": scalar("ao", 1.0),
        "depth": depth,
    }
    channels = _finish(channels, mask, files["normal"])
    return ImageGBuffer(channels=channels, fov_y=_ffhq_fov(folder, fov_y),
                        environment=_find(folder, "env", (".exr", ".hdr")),
                        target=linear("rgb") if "rgb" in data else None, source=folder)


def _ffhq_fov(folder: Path, fov_y: float | None) -> float:
    cam = folder / "camera.json"
    if not cam.is_file():
        if fov_y is None:
            raise InputError("missing camera.json ({\"fov_y\": degrees}) and no fov_y given",
                             where=folder)
        return float(fov_y)
    try:
        info = json.loads(cam.read_text())
        fov = float(info["fov_y"] if "fov_y" in info else info["fov"])
    except (ValueError, KeyError, TypeError) as exc:
        raise InputError(f"expected {{\"fov_y\": degrees}} ({type(exc).__name__}: {exc})",
                         where=cam) from None
    if not (0.0 < fov < 180.0) or math.isnan(fov):
        raise InputError(f"fov_y = {fov} is not in (0, 180) degrees", where=cam)
    return fov
