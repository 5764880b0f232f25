"""What a render produces: :class:`Frame` (read back to numpy) and :class:`FrameTargets` (left on
the GPU), the read-back of one to the other, and the AOV names a render can read back; and
:func:`check_frame_size`, which turns a frame size beyond the GL limits or the machine's memory
into one line before any target is allocated."""
from __future__ import annotations

import os

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


_SOFTWARE = ("llvmpipe", "softpipe", "swrast")
# Mesa's software renderers refuse one texture over 2 GiB (measured with llvmpipe: a 16384x8192
# RGBA32F target is complete, one row more is not), below their GL_MAX_TEXTURE_SIZE squared
_SOFTWARE_TEXTURE_BYTES = 1 << 31


def check_frame_size(ctx, scene, camera, layout, n: int, where: str | None = None) -> None:
    """A :class:`SceneError` (one line, naming ``where``: ``--size``, else the scene file's
    ``camera.size``) when a frame of ``camera.size`` x ``n`` (the frame's supersampling,
    ``viewer.graph.display.ssaa_factor``) cannot be drawn, checked before any target is
    allocated (a raw "framebuffer is not complete" otherwise):

    * the GL limits: each side against ``GL_MAX_TEXTURE_SIZE``, ``GL_MAX_RENDERBUFFER_SIZE`` and
      ``GL_MAX_VIEWPORT_DIMS`` of ``ctx`` (every pass draws into textures of that size), and on
      Mesa's software renderers one RGBA32F target against their 2 GiB a texture;
    * memory: the frame's least bytes (the G-buffer ``layout``'s attachments and depth, the
      radiance and display targets; SSAO, shadows and the pool's other frames come on top)
      against the host memory available now (:func:`available_memory`). That is where a software
      renderer (llvmpipe) keeps its targets, so the bound is sound there; a GPU keeps them in
      its own memory, which GL does not report portably, so there only what the frame reads back
      to the host (radiance and display at the output size) is checked. The cache budget
      (``Budgets.targets_bytes``) is not a limit: the pool may exceed it for one frame."""
    w, h = (int(s) for s in camera.size)
    rw, rh = w * n, h * n
    name = where or (f"{scene.source}: camera.size" if scene.source else "camera.size")
    drawn = f"{w}x{h}" + (f" x ssaa {n} = {rw}x{rh}" if n > 1 else "")
    info = ctx.info
    big = 1 << 30
    tex, rb = info.get("GL_MAX_TEXTURE_SIZE", big), info.get("GL_MAX_RENDERBUFFER_SIZE", big)
    limits = (("GL_MAX_TEXTURE_SIZE", tex, tex), ("GL_MAX_RENDERBUFFER_SIZE", rb, rb),
              ("GL_MAX_VIEWPORT_DIMS", *info.get("GL_MAX_VIEWPORT_DIMS", (big, big))))
    for key, lw, lh in limits:
        if rw > lw or rh > lh:
            raise SceneError(f"size {drawn} is beyond this GL's limit of {lw}x{lh} pixels "
                             f"({key}, {info.get('GL_RENDERER', 'GL')}); render smaller"
                             + (" or with a lower ssaa" if n > 1 else ""), where=name)
    radiance, display = w * h * 16, w * h * 4  # RGBA32F, RGBA8
    need = radiance + display  # read back to the host
    if any(s in str(info.get("GL_RENDERER", "")).lower() for s in _SOFTWARE):
        largest = rw * rh * 16  # the radiance, RGBA32F
        if largest > _SOFTWARE_TEXTURE_BYTES:
            raise SceneError(f"size {drawn} needs {largest / 2**30:.1f} GiB render targets, beyond "
                             f"the {_SOFTWARE_TEXTURE_BYTES / 2**30:.0f} GiB a texture may have "
                             f"on {info.get('GL_RENDERER')}; render smaller"
                             + (" or with a lower ssaa" if n > 1 else ""), where=name)
        per = 4 * (2 if layout.dtype == "f2" else 4) * len(layout.attachments) + 4  # + depth
        need = (rw * rh * (per + 16)  # the G-buffer (as GBufferDesc.bytes), the radiance
                + display + (radiance if n > 1 else 0))  # + the resolved radiance
    free = available_memory()
    if free is not None and need > free:
        raise SceneError(f"size {drawn} needs at least {need / 2**30:.1f} GiB for the frame's "
                         f"targets, more than the {free / 2**30:.1f} GiB of memory available; "
                         f"render smaller" + (" or with a lower ssaa" if n > 1 else ""),
                         where=name)


def available_memory() -> int | None:
    """Bytes this process may still allocate, the least of: the kernel's ``MemAvailable`` (free
    plus reclaimable page cache; ``SC_AVPHYS_PAGES`` x page size where /proc is missing: free
    pages only), a cgroup v2 limit's headroom (``memory.max`` - ``memory.current``) and an
    address-space limit's (``ulimit -v``, less what is mapped now). None: nothing known."""
    found: list[int] = []
    try:
        with open("/proc/meminfo") as f:
            for line in f:
                if line.startswith("MemAvailable:"):
                    found.append(int(line.split()[1]) * 1024)
    except (OSError, ValueError):
        try:
            found.append(os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE"))
        except (ValueError, OSError, AttributeError):
            pass
    try:
        with open("/sys/fs/cgroup/memory.max") as f:
            limit = f.read().strip()
        if limit != "max":
            with open("/sys/fs/cgroup/memory.current") as f:
                found.append(int(limit) - int(f.read().strip()))
    except (OSError, ValueError):
        pass
    try:
        import resource

        soft, _ = resource.getrlimit(resource.RLIMIT_AS)
        if soft != resource.RLIM_INFINITY:
            with open("/proc/self/statm") as f:
                mapped = int(f.read().split()[0]) * os.sysconf("SC_PAGE_SIZE")
            found.append(soft - mapped)
    except (ImportError, OSError, ValueError):
        pass
    return max(0, min(found)) if found else None
