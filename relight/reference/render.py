"""Path-traced reference renders with Mitsuba 3: the rasteriser's own per-pixel rays, Mitsuba's
``path`` integrator, our BSDF (:mod:`relight.reference.bsdf`), and per-pixel standard errors.

Rays: by default every sample of pixel (i, j) starts at the camera position along
:meth:`viewer.scene.camera.Camera.view_rays_ws` of that pixel, the ray through its centre, so the
reference compares pixel by pixel with the rasteriser (which shades each pixel at its centre).
``antialias=True`` jitters the ray uniformly over the pixel instead (the box-filtered image).

Samples are taken in batches (a wavefront of W x H x batch lanes on the LLVM backend); the sum
and sum of squares per pixel accumulate in float64, so the estimate's standard error is the
sample standard deviation / sqrt(spp) (Russian roulette is off, so nothing else adds variance).
A checkpoint after every batch lets an interrupted render resume where it stopped.
"""
from __future__ import annotations

import json
import math
import os
import sys
import time
import warnings
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from viewer.scene.description import Scene

from .keys import config_key
from .scene import MASKED_INTEGRATOR, ReferenceError, check_traceable, to_mitsuba

VARIANTS = ("llvm_ad_rgb", "scalar_rgb")
AOVS = ("normal", "depth")
MIN_LLVM = 19  # Dr.Jit 1.x miscompiles with LLVM 15 (tried: a code-generation abort)
MAX_LANES = 1 << 22  # lanes per batch on the LLVM backend (~1 GB of JIT state at depth 6)
MAX_LAYERS = 16  # alpha-covered surfaces a coverage ray passes before it counts as a hit


@dataclass(frozen=True)
class ReferenceOptions:
    spp: int = 1024
    max_depth: int = 6         # Mitsuba's path depth: 2 = direct light only
    antialias: bool = False    # jitter rays over the pixel (default: pixel-centre rays)
    seed: int = 0
    variant: str | None = None  # None: llvm_ad_rgb when libLLVM is found, else scalar_rgb
    batch_spp: int | None = None  # samples per pixel per batch (None: as many as fit)
    geometry: str = "mesh"     # "mesh": the rasteriser's triangles; "analytic": exact spheres


@dataclass
class Reference:
    radiance: np.ndarray   # [H, W, 4] float32: mean radiance, alpha = coverage
    stderr: np.ndarray     # [H, W, 3] float32: standard error of the mean, per channel
    meta: dict = field(default_factory=dict)
    aovs: dict = field(default_factory=dict)  # name -> [H, W, C] float32 at pixel centres


# ---- backend ------------------------------------------------------------------------------------

def find_libllvm() -> str | None:
    """The path of a libLLVM shared library of version >= ``MIN_LLVM``, or None. Dr.Jit takes the
    first libLLVM it finds, and older ones (Mesa's LLVM 15 here) fail to compile its kernels (a
    hard crash, not an exception), so the library is chosen here and handed over through
    ``DRJIT_LIBLLVM_PATH``; a path already set there is taken as the user's choice."""
    if os.environ.get("DRJIT_LIBLLVM_PATH"):
        return os.environ["DRJIT_LIBLLVM_PATH"]
    import glob
    import re

    found = []
    for folder in ("/usr/lib/x86_64-linux-gnu", "/usr/lib/aarch64-linux-gnu", "/usr/lib64",
                   "/usr/lib", "/usr/local/lib", "/opt/homebrew/opt/llvm/lib",
                   "/usr/local/opt/llvm/lib"):
        for path in glob.glob(os.path.join(folder, "libLLVM*")):
            m = re.search(r"libLLVM[-.](?:so\.)?(\d+)", os.path.basename(path))
            if m and int(m.group(1)) >= MIN_LLVM:
                found.append((int(m.group(1)), path))
    return max(found)[1] if found else None


def load_mitsuba(variant: str | None = None):
    """``(mi, dr, variant)``: Mitsuba with ``variant`` set. Without one, ``llvm_ad_rgb`` when a
    libLLVM >= ``MIN_LLVM`` is installed (:func:`find_libllvm`; Debian: ``libllvm19``), else
    ``scalar_rgb`` with a warning: the scalar backend runs the Python BSDF once per sample."""
    if variant is None or variant.startswith("llvm"):
        llvm = find_libllvm()
        if llvm is not None:
            os.environ.setdefault("DRJIT_LIBLLVM_PATH", llvm)
        elif variant is None:
            variant = "scalar_rgb"
            warnings.warn(f"no libLLVM >= {MIN_LLVM} found (apt-get install libllvm19): Mitsuba "
                          "runs scalar_rgb, which calls the Python BSDF once per sample and is "
                          "orders of magnitude slower", stacklevel=2)
        else:
            raise ReferenceError(f"variant {variant} needs libLLVM >= {MIN_LLVM} (apt-get install "
                                 "libllvm19, or set DRJIT_LIBLLVM_PATH)", where="--variant")
    try:
        import drjit as dr
        import mitsuba as mi
    except ImportError:
        raise ReferenceError("relight reference needs Mitsuba 3: pip install -e '.[reference]'",
                             where="mitsuba") from None
    if variant is not None and variant not in VARIANTS:
        raise ReferenceError(f"variant {variant!r} is not one of {', '.join(VARIANTS)}",
                             where="--variant")
    for v in ([variant] if variant else list(VARIANTS)):
        try:
            mi.set_variant(v)
            if v.startswith("llvm"):
                dr.eval(mi.Float(1.0) + 1.0)  # the JIT loads libLLVM on first use
            return mi, dr, v
        except Exception as exc:  # noqa: BLE001 - any backend failure: try the next one
            last = exc
    raise ReferenceError(f"no Mitsuba variant works ({' '.join(str(last).split())[:200]})",
                         where="mitsuba")


# ---- rays ---------------------------------------------------------------------------------------

def camera_rays(camera, jitter: np.ndarray | None = None) -> np.ndarray:
    """``[H, W, 3]`` float32 unit world directions through pixel centres (``jitter`` None: exactly
    :meth:`Camera.view_rays_ws`) or through ``(j + jitter[..., 0], i + jitter[..., 1])`` for
    ``jitter`` ``[H, W, 2]`` in [0, 1) (row 0 at the top)."""
    if jitter is None:
        return camera.view_rays_ws()
    tx, ty = camera.tan_half_fov()
    h, w = camera.height, camera.width
    jj, ii = np.meshgrid(np.arange(w), np.arange(h))
    x = ((jj + jitter[..., 0]) / w * 2.0 - 1.0) * tx
    y = (1.0 - (ii + jitter[..., 1]) / h * 2.0) * ty
    d = np.stack([x, y, -np.ones_like(x)], axis=-1) @ camera.basis()
    return (d / np.linalg.norm(d, axis=-1, keepdims=True)).astype(np.float32)


# ---- rendering ----------------------------------------------------------------------------------



def render_reference(scene: Scene, options: ReferenceOptions = ReferenceOptions(),
                     checkpoint: str | os.PathLike | None = None, progress: bool = True,
                     aovs: tuple[str, ...] = ()) -> Reference:
    """Path-trace ``scene`` (module docstring). ``checkpoint``: a file that holds the partial sums
    after every batch; an existing one for the same scene and options is resumed (and removed when
    the render completes). Raises :class:`ReferenceError` (one line) for scenes without
    path-traceable geometry, unknown AOVs or a missing Mitsuba."""
    check_traceable(scene)
    bad = [a for a in aovs if a not in AOVS]
    if bad:
        raise ReferenceError(f"unknown reference AOV {bad[0]!r} (known: {', '.join(AOVS)})",
                             where="--aov")
    mi, dr, variant = load_mitsuba(options.variant)
    t0 = time.perf_counter()
    try:
        desc = to_mitsuba(scene, mi, dr, options.max_depth, options.geometry)
        masked = desc["integrator"]["type"] == MASKED_INTEGRATOR  # some alphaMode coverage
        mscene = mi.load_dict(desc)
    except ReferenceError:
        raise
    except Exception as exc:  # noqa: BLE001 - Mitsuba's own message, on one line
        raise ReferenceError(f"Mitsuba could not build the scene: {' '.join(str(exc).split())}",
                             where=scene.source or "scene") from None
    integrator = mscene.integrator()
    cam = scene.camera
    h, w = cam.height, cam.width
    n_pix = h * w
    origin = np.asarray(cam.position, np.float32)
    scalar = variant.startswith("scalar")
    batch = options.batch_spp or (1 if scalar else max(1, min(options.spp, MAX_LANES // n_pix)))
    n_batches = math.ceil(options.spp / batch)
    key = config_key(scene, options)

    state = {"sum": np.zeros((n_pix, 3)), "sumsq": np.zeros((n_pix, 3)),
             "hits": np.zeros(n_pix), "n": 0, "batch": 0}
    ckpt = Path(checkpoint) if checkpoint else None
    if ckpt is not None and ckpt.is_file():
        try:
            with np.load(ckpt, allow_pickle=False) as z:
                if str(z["key"]) == key and z["sum"].shape == (n_pix, 3):
                    state = {k: (z[k] if k in ("sum", "sumsq", "hits") else int(z[k]))
                             for k in ("sum", "sumsq", "hits", "n", "batch")}
        except (OSError, ValueError, KeyError):
            warnings.warn(f"{ckpt}: unreadable checkpoint, starting again", stacklevel=2)

    bar = _progress(n_batches, state["batch"], progress, scene.source)
    centre_dirs = camera_rays(cam).reshape(n_pix, 3)
    for b in range(state["batch"], n_batches):
        count = min(batch, options.spp - b * batch)
        if options.antialias:
            jit_rng = np.random.default_rng([options.seed, b, 11])
            dirs = np.stack([camera_rays(cam, jit_rng.random((h, w, 2))).reshape(n_pix, 3)
                             for _ in range(count)], axis=1)  # [P, B, 3]
        else:
            dirs = np.broadcast_to(centre_dirs[:, None], (n_pix, count, 3))
        values, hit = _trace(mi, dr, mscene, integrator, origin, dirs.reshape(-1, 3),
                             seed=(options.seed * 1_000_003 + b) & 0x7FFFFFFF, scalar=scalar,
                             masked=masked)
        values = values.reshape(n_pix, count, 3)
        hit = hit.reshape(n_pix, count)
        if scene.render.display.background == "transparent":
            values = values * hit[..., None]
        state["sum"] += values.sum(axis=1)
        state["sumsq"] += (values * values).sum(axis=1)
        state["hits"] += hit.sum(axis=1)
        state["n"] += count
        state["batch"] = b + 1
        if ckpt is not None and b + 1 < n_batches:
            tmp = ckpt.with_name(ckpt.name + ".tmp.npz")
            np.savez(tmp, key=np.array(key), **{k: np.asarray(v) for k, v in state.items()})
            os.replace(tmp, ckpt)
        bar(b + 1)
    n = state["n"]
    mean = state["sum"] / n
    var = np.maximum(state["sumsq"] / n - mean * mean, 0.0) * (n / max(n - 1, 1))
    radiance = np.concatenate([mean, (state["hits"] / n)[:, None]], axis=1)
    ref = Reference(radiance=radiance.reshape(h, w, 4).astype(np.float32),
                    stderr=np.sqrt(var / n).reshape(h, w, 3).astype(np.float32),
                    meta={"spp": int(n), "max_depth": int(options.max_depth),
                          "rays": "jittered over the pixel" if options.antialias
                          else "pixel centre", "geometry": options.geometry,
                          # the BSDF traced: with the multiple-scattering compensation c_ms
                          # (render.multiscatter, on by default) or single scattering
                          "multiscatter": bool(scene.render.multiscatter),
                          "seed": int(options.seed), "variant": variant,
                          "mitsuba": mi.__version__, "seconds": round(time.perf_counter() - t0, 3),
                          "size": [w, h], "scene": scene.source, "key": key})
    if aovs:
        ref.aovs = _first_hit_aovs(mi, mscene, cam, origin, centre_dirs, aovs, scalar)
    if ckpt is not None and ckpt.is_file():
        ckpt.unlink()
    return ref


def _trace(mi, dr, mscene, integrator, origin, dirs, seed: int, scalar: bool,
           masked: bool = False):
    """Radiance ``[N, 3]`` float64 and first-hit mask ``[N]`` of one sample along each ray
    (``masked``: the scene has alpha coverage, :func:`_covered` decides the hit)."""
    n = dirs.shape[0]
    if scalar:
        out = np.zeros((n, 3))
        hit = np.zeros(n, bool)
        sampler = mi.load_dict({"type": "independent"})
        for k in range(n):
            sampler.seed(seed * 7919 + k, 1)
            ray = mi.Ray3f(mi.Point3f(*origin), mi.Vector3f(*dirs[k]))
            value, _, _ = integrator.sample(mscene, sampler, ray)
            out[k] = np.array(value, np.float64).reshape(3)
            hit[k] = bool(_covered(mi, dr, mscene, ray, sampler) if masked else
                          mscene.ray_intersect(ray).is_valid())
        return out, hit
    o = mi.Point3f(np.ascontiguousarray(np.broadcast_to(origin[:, None], (3, n)), np.float32))
    d = mi.Vector3f(np.ascontiguousarray(dirs.T, np.float32))
    ray = mi.Ray3f(o, d)
    sampler = mi.load_dict({"type": "independent"})
    sampler.seed(seed, n)
    value, _, _ = integrator.sample(mscene, sampler, ray)
    hit = (_covered(mi, dr, mscene, ray, sampler) if masked else
           mscene.ray_intersect(ray).is_valid())
    dr.eval(value, hit)
    return np.array(value, np.float64).T, np.array(hit, bool)


def _covered(mi, dr, mscene, ray, sampler):
    """Whether ``ray`` is covered (the image's alpha) in a scene with alphaMode surfaces: it
    passes a ``mask`` surface with probability ``eval_null_transmission`` (1 - opacity: 0 or 1
    for MASK, so the test is exact; 1 - alpha for BLEND, drawn independently of the radiance's
    own path, so the coverage's mean is right but a transparent background zeroes a BLEND
    pixel's radiance by an uncorrelated draw) and stops at the first surface it does not pass,
    after at most :data:`MAX_LAYERS` of them (counted as a hit)."""
    hit = mi.Bool(False)
    active = mi.Bool(True)
    for _ in range(MAX_LAYERS):
        si = mscene.ray_intersect(ray, active)
        active = active & si.is_valid()
        if not dr.any(active):  # (scalar: a miss has no BSDF to call)
            return hit
        through = si.bsdf(ray).eval_null_transmission(si, active)[0]
        u = sampler.next_1d(active)
        hit = hit | (active & (u >= through))
        active = active & (u < through)
        ray = si.spawn_ray(ray.d)
    return hit | active


def _first_hit_aovs(mi, mscene, cam, origin, dirs, names, scalar):
    h, w = cam.height, cam.width
    forward = -cam.basis()[2]
    out = {}
    normals = np.zeros((h * w, 3), np.float32)
    depth = np.zeros((h * w, 1), np.float32)
    if scalar:
        for k in range(h * w):
            si = mscene.ray_intersect(mi.Ray3f(mi.Point3f(*origin), mi.Vector3f(*dirs[k])))
            if si.is_valid():
                normals[k] = np.array(si.sh_frame.n).reshape(3)
                depth[k, 0] = float(si.t) * float(dirs[k] @ forward)
    else:
        o = mi.Point3f(np.ascontiguousarray(np.broadcast_to(origin[:, None], (3, h * w)),
                                            np.float32))
        si = mscene.ray_intersect(mi.Ray3f(o, mi.Vector3f(np.ascontiguousarray(dirs.T))))
        valid = np.array(si.is_valid(), bool)
        normals = np.where(valid[:, None], np.array(si.sh_frame.n).T, 0.0).astype(np.float32)
        t = np.where(valid, np.array(si.t), 0.0)
        depth = (t * (dirs @ forward))[:, None].astype(np.float32)
    if "normal" in names:
        out["normal"] = normals.reshape(h, w, 3)
    if "depth" in names:
        out["depth"] = depth.reshape(h, w, 1)
    return out


def _progress(total: int, start: int, enabled: bool, label: str | None):
    if not enabled:
        return lambda done: None
    try:
        from tqdm import tqdm
    except ImportError:
        def report(done):
            print(f"reference: batch {done}/{total}", file=sys.stderr, flush=True)
        return report
    bar = tqdm(total=total, initial=start, desc=f"reference {Path(label).name if label else ''}",
               unit="batch", file=sys.stderr, leave=False)

    def update(done):
        bar.update(done - bar.n)
        if done >= total:
            bar.close()
    return update


# ---- files --------------------------------------------------------------------------------------

def write_reference(ref: Reference, out: str | os.PathLike) -> list[Path]:
    """``out`` (RGBA float32 EXR: mean radiance, alpha = coverage), ``<out stem>.stderr.exr``
    (per-pixel standard error), ``<out stem>.json`` (spp, depth, rays, variant, time) and one
    ``<out stem>.<aov>.exr`` per AOV. Returns the files written."""
    from viewer.imageio import write_exr

    out = Path(out)
    stem = out.with_suffix("")
    written = [out, stem.with_name(stem.name + ".stderr.exr"), stem.with_name(stem.name + ".json")]
    write_exr(out, ref.radiance)
    write_exr(written[1], ref.stderr)
    written[2].write_text(json.dumps(ref.meta, indent=2) + "\n")
    for name, img in ref.aovs.items():
        p = stem.with_name(f"{stem.name}.{name}.exr")
        write_exr(p, img)
        written.append(p)
    return written


def read_reference(path: str | os.PathLike) -> Reference:
    """A reference written by :func:`write_reference` (one-line :class:`ReferenceError` when a
    part is missing)."""
    from viewer.imageio import read_image

    path = Path(path)
    stem = path.with_suffix("")
    err = stem.with_name(stem.name + ".stderr.exr")
    meta = stem.with_name(stem.name + ".json")
    for p in (path, err, meta):
        if not p.is_file():
            raise ReferenceError("reference part missing (expected the image, .stderr.exr and "
                                 ".json written by relight reference)", where=p)
    radiance, _ = read_image(path, channels=(4,))
    stderr, _ = read_image(err, channels=(3,))
    return Reference(radiance=radiance, stderr=stderr, meta=json.loads(meta.read_text()))
