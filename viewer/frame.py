"""What a render produces: :class:`Frame` (read back to numpy) and :class:`FrameTargets` (left on
the GPU), the read-back of one to the other, and the AOV names a render can read back."""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .errors import SceneError
from .gbuffer import CHANNEL_NAMES
from .models import ShadeVariant
from .passes.gbuffer import GBufferTargets
from .scene.camera import Camera


AOV_NAMES = CHANNEL_NAMES  # albedo, alpha, normal, roughness, metallic, specular, ao, depth, color


@dataclass
class Frame:
    """What one render produced, read back to numpy (row 0 at the top)."""

    radiance: np.ndarray  # [H, W, 4] float32 linear radiance, alpha = coverage
    display: np.ndarray  # [H, W, 4] uint8 sRGB after exposure and tone mapping
    aovs: dict[str, np.ndarray] = field(default_factory=dict)  # [H, W, C] float32 each
    camera: Camera | None = None


@dataclass
class FrameTargets:
    """What :meth:`~viewer.renderer.Renderer.draw` leaves on the GPU for one frame (nothing read
    back): what a window shows, the debug views read and the parity checks compare. Textures are
    moderngl textures, GL row order (row 0 at the bottom)."""

    # RGBA32F: linear radiance composited over the background, alpha = coverage (at the output
    # size: the resolved radiance when supersampled; the other targets are then at ssaa x it)
    radiance: object
    display: object  # RGBA8: exposed, tone-mapped, sRGB-encoded
    gbuffer: GBufferTargets  # the G-buffer the frame was shaded from (.textures, .read())
    camera: Camera  # the camera it was rendered with (a stack's own camera for image stacks)
    variant: ShadeVariant  # the lighting-pass program that shaded it
    samples: int = 1  # Monte-Carlo samples averaged in `radiance` (1 for single-sample models)
    ssao: object | None = None  # RGBA32F occlusion (r), when render.ssao
    direct: object | None = None  # RGBA32F direct light before the indirect pass (render.indirect)
    # R32F: a neural student's learned factor on the indirect light (lighting pass, 2nd output)
    indirect_factor: object | None = None
    # every kept resource of the frame graph by name (viewer.graph.frame): targets with .texture
    # and .fbo (SSAO's hit targets ``ssao_hits<i>`` among them), the G-buffer; valid until the
    # renderer draws again
    targets: dict = field(default_factory=dict)


def read_texture(texture, dtype: str) -> np.ndarray:
    """A texture read back as ``[H, W, C]`` numpy (``"f4"`` float32, ``"f1"`` uint8), row 0 at the
    top (flipped from GL's bottom-up order)."""
    w, h = texture.size
    np_dtype = np.float32 if dtype == "f4" else np.uint8
    arr = np.frombuffer(texture.read(), dtype=np_dtype).reshape(h, w, texture.components)
    return arr[::-1].copy()


def downsample_aov(channel: np.ndarray, n: int, name: str) -> np.ndarray:
    """An AOV read from a G-buffer rendered at ``n`` x the size (``[render] ssaa``) brought to the
    output size: each n x n block's mean (the pixel's box filter, as the radiance is resolved),
    normals renormalised, and depth point-sampled at the block's centre (a mean across a
    silhouette is a depth no surface has). ``n = 1``: ``channel`` itself."""
    if n <= 1:
        return channel
    h, w, c = channel.shape[0] // n, channel.shape[1] // n, channel.shape[2]
    if name == "depth":
        return channel[n // 2::n, n // 2::n][:h, :w].copy()
    mean = channel[: h * n, : w * n].reshape(h, n, w, n, c).mean(axis=(1, 3))
    if name == "normal":
        length = np.linalg.norm(mean, axis=-1, keepdims=True)
        mean = np.where(length > 1e-6, mean / np.maximum(length, 1e-6), 0.0)
    return mean.astype(channel.dtype)


def read_frame(targets: FrameTargets, aovs, ssaa: int = 1) -> Frame:
    """A drawn frame read back: radiance, display pixels and the requested ``aovs`` (G-buffer
    channels brought to the output size from ``ssaa`` x it, shadow maps at their own size)."""
    radiance = read_texture(targets.radiance, "f4")
    display = read_texture(targets.display, "f1")
    frame = Frame(radiance=radiance, display=display, camera=targets.camera)
    if aovs:
        channels = targets.gbuffer.read()
        for name in aovs:
            if is_shadow_aov(name):  # a shadow map, at its own size
                frame.aovs[name] = read_shadow_map(targets, name)
                continue
            if name == "color" and "color" not in channels:
                # meshes: the unlit colour is the albedo, premultiplied by coverage
                channels["color"] = channels["albedo"] * channels["alpha"]
            frame.aovs[name] = downsample_aov(channels[name], ssaa, name)
    return frame


def check_aovs(aovs) -> None:
    """Every name in ``aovs`` is a G-buffer channel (:data:`AOV_NAMES`) or a shadow map
    (``shadow<i>``, ``shadowsun``), or a one-line error."""
    unknown = [a for a in aovs if a not in AOV_NAMES and not is_shadow_aov(a)]
    if unknown:
        raise SceneError(f"unknown AOV {', '.join(map(repr, unknown))} "
                         f"(known: {', '.join(AOV_NAMES)}, shadow<i>, shadowsun, shadowenv<k>, "
                         f"shadowenvdirs)", where="--aov")


def is_shadow_aov(name: str) -> bool:
    """``shadow<i>`` (light i's map), ``shadowsun`` (the environment's sun's), ``shadowenv<k>``
    (its other compact lights') or ``shadowenvdirs`` (the atlas of its shadow directions)."""
    rest = name[len("shadow"):] if name.startswith("shadow") else None
    return rest is not None and (rest in ("sun", "envdirs") or rest.isdigit()
                                 or (rest.startswith("env") and rest[3:].isdigit()))


def read_shadow_map(targets: FrameTargets, name: str):
    """The shadow map ``name`` of a frame, ``[H, W, 1]`` float32 normalised depth (row 0 at the
    top; a point light's: its atlas of six faces), or a one-line error naming those it has."""
    target = targets.targets.get("shadowmap" + name[len("shadow"):])
    if target is None:
        have = sorted("shadow" + k[len("shadowmap"):] for k in targets.targets
                      if k.startswith("shadowmap"))
        raise SceneError(f"this scene draws no shadow map {name!r} (it draws: "
                         f"{', '.join(have) or 'none'})", where="--aov")
    return read_texture(target.texture, "f4")
