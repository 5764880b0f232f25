"""HDR environments: loading equirect files and making procedural ones, in numpy.

Every environment is ``[H, W, 3]`` float32 linear radiance with ``H = W / 2`` and ``W`` a power of
two, in the project's equirect convention (row 0 is the zenith +Y; u = 0.5 is -Z, u = 0.75 is +X;
see ``shaders/lib/equirect.glsl``). Intensity and rotation are *not* baked in: they are shader
uniforms (``u_env_intensity``, ``u_env_rotation``) so sliders cost nothing. The compact sun's
strength (``sun_strength``, with any other compact light) is baked in: 0 is the same sky without it
(:func:`scale_sun`), a map the IBL, the path model and the reference all see alike.
"""
from __future__ import annotations

import math
import warnings
from dataclasses import dataclass, field

import numpy as np

from ..errors import InputError, SceneError
from ..imageio import pixel_type, read_image

PROCEDURAL = ("sky", "studio", "white")
MAX_WIDTH = 2048
_ASPECT_TOLERANCE = 0.02
# scale_sun: rounds of extraction (esplanade.exr: two lamps near the zenith, then a third that
# carries 6 % of what is left once they are gone; none after)
SUN_ROUNDS = 4  # a file is "2:1" if |W / H - 2| <= 2 * this
# integer pixel types: display-referred (sRGB-encoded) images, decoded to linear on load
DISPLAY_TYPES = ("uint8", "int8", "uint16", "int16")


@dataclass(frozen=True)
class EnvironmentSpec:
    path: str | None = None        # an equirect HDR/EXR file (takes precedence over procedural)
    procedural: str | None = None  # "sky" | "studio" | "white"
    intensity: float = 1.0         # radiance scale (shader uniform, not baked)
    rotation_deg: float = 0.0      # about +Y, counter-clockwise from above (uniform, not baked)
    width: int = 512               # width of procedural environments (rounded to a power of two)
    sun_elevation_deg: float = 35.0  # "sky": sun height above the horizon
    sun_azimuth_deg: float = 30.0    # "sky": from -Z towards +X (0 = straight ahead, 90 = +X)
    sun_radiance: float = 2000.0     # "sky": the sun disc's radiance (the zenith sky is ~0.45)
    # the light of the compact sun (and of any other compact light the viewer extracts) times
    # this, baked into the map: 0 is the sky without them, 1 the map as it is
    sun_strength: float = field(default=1.0, repr=False)
    # (sun_strength is out of the repr, which the reference's and the caches' keys hash, so keys
    # made before it stay valid; config_key and the disk key add it when it is not 1)

    def __post_init__(self):
        s = self.sun_strength
        if isinstance(s, bool) or not isinstance(s, (int, float)) or not math.isfinite(s) \
                or s < 0.0:
            raise ValueError(f"sun_strength must be a finite number >= 0, got {s!r}")


def load_environment(spec: EnvironmentSpec) -> np.ndarray:
    """The environment of ``spec`` as ``[H, W, 3]`` float32 linear radiance (H = W / 2, W a power
    of two). Files are read through :func:`viewer.imageio.read_image` (1, 3 or 4 channels; alpha
    dropped, one channel is grey); 8- and 16-bit files (PNG, JPEG, TIFF) are sRGB-encoded display
    images, decoded to linear with one warning that their dynamic range is clipped (HDR and EXR
    are linear already); then resampled to the power of two nearest their width (at most
    2048). Negative, NaN and Inf texels become 0 with one warning naming the file and the count.

    Raises :class:`InputError` for unreadable files or ones not ~2:1, and :class:`SceneError` for
    an unknown procedural name or neither a path nor a procedural name. ``spec.sun_strength``
    other than 1 scales the compact sun (:func:`scale_sun`).
    """
    env = _load(spec)
    if spec.sun_strength != 1.0:
        env = scale_sun(env, spec.sun_strength, str(spec.path or spec.procedural))
    return env


def scale_sun(env: np.ndarray, strength: float, where: str) -> np.ndarray:
    """``env`` with the light of its compact lights (its sun, lamps: the regions
    :func:`viewer.environment.sun.extract_lights` takes out, again on what is left until it
    finds none, at most :data:`SUN_ROUNDS` times) times ``strength``:
    their texels keep the sky around them plus ``strength`` times the light they carried above
    it, so 0 leaves the sky they stood in and 1 the map itself. A map without a compact light is
    returned unchanged, with one warning naming it (the setting would otherwise change nothing
    silently)."""
    from .sun import extract_lights

    residual, lights = extract_lights(env)
    for _ in range(SUN_ROUNDS - 1):  # a weaker light passes the share rule once they are gone
        residual, more = extract_lights(residual)
        if not more:
            break
    if not lights:
        warnings.warn(f"{where}: no compact sun found (nothing 1000 x brighter than the median "
                      f"carrying 5 % of the light); sun_strength {strength:g} changes nothing",
                      stacklevel=3)
        return env
    out = residual.astype(np.float64) + strength * (env.astype(np.float64) - residual)
    return np.maximum(out, 0.0).astype(np.float32)


def _load(spec: EnvironmentSpec) -> np.ndarray:
    if spec.path is not None:
        return _load_file(str(spec.path))
    if spec.procedural is None:
        raise SceneError("environment needs a path or a procedural name "
                         f"({', '.join(PROCEDURAL)})", where="environment")
    name = str(spec.procedural).lower()
    width = _pow2(spec.width, cap=MAX_WIDTH)
    if name == "white":
        return white_environment(width)
    if name == "sky":
        return sky_environment(width, spec.sun_elevation_deg, spec.sun_azimuth_deg,
                               spec.sun_radiance)
    if name == "studio":
        return studio_environment(width)
    raise SceneError(f"unknown procedural environment {spec.procedural!r} "
                     f"(expected one of {', '.join(PROCEDURAL)})", where="environment.procedural")


# ---------------------------------------------------------------------------------------------
# files
# ---------------------------------------------------------------------------------------------

def _pow2(n: int, cap: int = MAX_WIDTH) -> int:
    """The power of two nearest ``n`` (ties up), at least 4 and at most ``cap``."""
    n = max(int(n), 1)
    lo = 1 << (n.bit_length() - 1)
    p = lo if n - lo < 2 * lo - n else 2 * lo
    return int(min(max(p, 4), cap))


def _load_file(path: str) -> np.ndarray:
    arr, _ = read_image(path, channels=(1, 3, 4))
    h, w, c = arr.shape
    if c == 1:
        arr = np.repeat(arr, 3, axis=2)
    arr = np.ascontiguousarray(arr[:, :, :3], dtype=np.float32)
    if abs(w / h - 2.0) > 2.0 * _ASPECT_TOLERANCE:
        raise InputError(f"an equirect environment must be 2:1, this one is {w}x{h}", where=path)
    kind = pixel_type(path)
    if kind in DISPLAY_TYPES:  # PNG, JPEG, 8/16-bit TIFF: display-encoded sRGB, clipped at 1
        from ..geometry.mesh import srgb_to_linear

        arr = srgb_to_linear(arr)
        bits = "".join(ch for ch in kind if ch.isdigit())
        article = "an" if bits == "8" else "a"  # "an 8-bit", "a 16-bit"
        warnings.warn(f"{path}: {article} {bits}-bit image, decoded from sRGB to linear; its "
                      f"dynamic range is clipped (nothing brighter than 1: no sun, weak highlights "
                      f"and shadows) - an HDR or EXR environment lights a scene properly",
                      stacklevel=3)
    bad = ~np.isfinite(arr) | (arr < 0)
    count = int(bad.sum())
    if count:
        warnings.warn(f"{path}: {count} negative, NaN or Inf texel values set to 0", stacklevel=3)
        arr = np.where(bad, np.float32(0.0), arr)
    width = _pow2(w)
    if (w, h) == (width, width // 2):
        return arr  # already a new float32 array
    return resample(arr, width, width // 2)


def resample(img: np.ndarray, width: int, height: int) -> np.ndarray:
    """Resample ``[H, W, C]`` to ``[height, width, C]``: exact area average when shrinking by an
    integer factor, bilinear (u wraps, v clamps) otherwise. Returns float32."""
    h, w = img.shape[:2]
    if (w, h) == (width, height):
        return img.astype(np.float32, copy=True)
    if w % width == 0 and h % height == 0:
        fx, fy = w // width, h // height
        out = img.astype(np.float64).reshape(height, fy, width, fx, -1).mean(axis=(1, 3))
        return out.astype(np.float32)
    # bilinear at the destination texel centres (an area average would need a box of the
    # source/destination ratio; shrinking by large non-integer factors first halves exactly)
    while w >= 2 * width and h >= 2 * height and w % 2 == 0 and h % 2 == 0:
        img = img.reshape(h // 2, 2, w // 2, 2, -1).mean(axis=(1, 3))
        h, w = img.shape[:2]
    x = (np.arange(width) + 0.5) * (w / width) - 0.5
    y = (np.arange(height) + 0.5) * (h / height) - 0.5
    x0 = np.floor(x).astype(np.int64)
    y0 = np.floor(y).astype(np.int64)
    fx = (x - x0)[None, :, None]
    fy = (y - y0)[:, None, None]
    xa, xb = x0 % w, (x0 + 1) % w
    ya, yb = np.clip(y0, 0, h - 1), np.clip(y0 + 1, 0, h - 1)
    img = img.astype(np.float64)
    top = img[ya][:, xa] * (1 - fx) + img[ya][:, xb] * fx
    bottom = img[yb][:, xa] * (1 - fx) + img[yb][:, xb] * fx
    return (top * (1 - fy) + bottom * fy).astype(np.float32)


# ---------------------------------------------------------------------------------------------
# procedural environments
# ---------------------------------------------------------------------------------------------

def texel_directions(width: int) -> np.ndarray:
    """Unit directions ``[W/2, W, 3]`` of the texel centres of a ``W``-wide equirect map."""
    h = width // 2
    u = (np.arange(width) + 0.5) / width
    v = (np.arange(h) + 0.5) / h
    phi = 2.0 * math.pi * (u[None, :] - 0.5)
    theta = math.pi * v[:, None]
    st = np.sin(theta)
    return np.stack(np.broadcast_arrays(st * np.sin(phi), np.cos(theta), -st * np.cos(phi)),
                    axis=-1)


def white_environment(width: int = 512) -> np.ndarray:
    """Constant radiance 1 everywhere: the white furnace."""
    return np.ones((width // 2, width, 3), np.float32)


def sky_environment(width: int = 512, sun_elevation_deg: float = 35.0,
                    sun_azimuth_deg: float = 30.0, sun_radiance: float = 2000.0) -> np.ndarray:
    """Gradient sky over a dark ground, with a sun disc of 2 degrees angular radius whose
    radiance (``sun_radiance``; 2000 is ~2000 x the horizon and ~4400 x the zenith, 2e4 a
    real clear sky's 1e4+ sun-to-sky ratio) makes a visible highlight on glossy surfaces."""
    d = texel_directions(width)
    y = d[..., 1:2]
    zenith = np.array([0.25, 0.45, 1.0])
    horizon = np.array([0.9, 0.95, 1.0])
    ground = np.array([0.12, 0.10, 0.08])
    t = np.clip(y, 0.0, 1.0) ** 0.5
    sky = horizon * (1 - t) + zenith * t
    g = np.clip(-y * 8.0, 0.0, 1.0)  # soft horizon band into the ground
    env = sky * (1 - g) + ground * g
    el, az = math.radians(sun_elevation_deg), math.radians(sun_azimuth_deg)
    sun = np.array([math.cos(el) * math.sin(az), math.sin(el), -math.cos(el) * math.cos(az)])
    cos_sun = d @ sun
    radius = math.radians(2.0)
    disc = np.clip((cos_sun - math.cos(radius)) / (1.0 - math.cos(radius)) * 4.0, 0.0, 1.0)
    # texels too coarse for the disc still get it: at least the texel nearest the sun is lit
    nearest = np.unravel_index(np.argmax(cos_sun), cos_sun.shape)
    disc[nearest] = max(disc[nearest], 1.0)
    glow = np.exp((np.clip(cos_sun, -1, 1) - 1.0) * 40.0) * 2.0
    env = env + (disc[..., None] * float(sun_radiance) + glow[..., None]) * np.array([1.0, 0.92, 0.8])
    return env.astype(np.float32)


def studio_environment(width: int = 512) -> np.ndarray:
    """Dark-grey surround with three soft rectangular softboxes (key, fill, top)."""
    d = texel_directions(width)
    phi = np.arctan2(d[..., 0], -d[..., 2])           # 0 at -Z, +pi/2 at +X
    elev = np.arcsin(np.clip(d[..., 1], -1.0, 1.0))   # above the horizon > 0
    env = np.full(d.shape, 0.03) * (1.0 + 0.5 * np.clip(d[..., 1:2], 0, 1))

    def box(center_az, center_el, half_w, half_h, radiance, softness=0.08):
        da = np.angle(np.exp(1j * (phi - math.radians(center_az))))  # wrapped azimuth distance
        de = elev - math.radians(center_el)
        fa = np.clip((math.radians(half_w) - np.abs(da)) / softness + 0.5, 0, 1)
        fe = np.clip((math.radians(half_h) - np.abs(de)) / softness + 0.5, 0, 1)
        return (fa * fe)[..., None] * np.asarray(radiance)

    env = env + box(-45.0, 25.0, 18.0, 14.0, (12.0, 11.5, 11.0))   # key, front left
    env = env + box(60.0, 10.0, 14.0, 20.0, (4.0, 4.0, 4.2))      # fill, right
    env = env + box(180.0, 70.0, 30.0, 10.0, (6.0, 6.0, 6.0))     # top/back rim
    return env.astype(np.float32)
