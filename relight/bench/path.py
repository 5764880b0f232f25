"""``relight bench --suite path``: the GL path tracer (``model = "path"``) measured — how close it
comes to the truth, how fast it gets there beside Mitsuba, and what its BVH costs.

Rows of ``kind = "scene"``, one per stored reference (every ``assets/scenes/reference/*.toml`` and
``assets/scenes/shadows/*.toml`` with an ``assets/references/<name>.exr``), at the reference's
size and ``max_depth`` 6:

* the **block z-test** of :func:`block_test` (the test of ``tests/reference/test_path_convergence.py``:
  ``seeds`` independent renders of ``spp`` samples, 4 x 4-pixel blocks, Student-t threshold at a
  family-wise false-alarm rate of 1e-3, Bonferroni): blocks x channels tested, how many fail,
  the largest |z| and the threshold;
* the image's **energy bias** against the reference (covered pixels) in % with one standard error
  (the seeds' spread and the reference's own noise), and the **PSNR** of the seeds' mean against
  the reference (:func:`relight.reference.compare.score`: peak = the reference's 99.9th
  percentile);
* **time**: ``ms_per_spp``, the median whole frame over the seeds (G-buffer, tracing, read-back)
  / ``spp``, and ``path_Msps``, pixel samples per second (millions) from it, beside
  ``mitsuba_Msps``, **Mitsuba's** on the same scene, size and ``max_depth`` (``relight
  reference``, same machine, as many samples S as all the seeds together): the marginal rate
  ``(S - 1) x pixels / (t(S) - t(1))``, so its per-call scene set-up (a warm 1-spp call) is left
  out; ``mitsuba_jit_s``, the first 1-spp call on the scene minus a warm one (Dr.Jit's
  compilation; kernels it compiled for an earlier scene of the process, or keeps on disk, are
  not compiled again). ``triangles`` and ``build_ms``: the traced triangles and
  :attr:`TraceStore.build_seconds <viewer.raytrace.upload.TraceStore>` (gather, BVH, upload) of
  the scene's first frame.

``details`` (a dict: in ``path.json``, not in the table) holds the rest: seeds, the reference's
samples, the first frame's seconds (shader compilation included), every render's seconds,
Mitsuba's set-up seconds and sample count.

Rows of ``kind = "bvh"``: random triangle soups and tessellated spheres (:func:`bench_mesh`) of
10^4, 10^5 and 10^6 triangles (10^6 only without ``--quick``): ``build_ms`` (gather, BVH, upload,
as the renderer builds) and ``bvh_ms`` (the binned-SAH build alone; numba compiled beforehand),
``nodes``, ``bvh_MB`` (nodes + triangle order, CPU) and ``gpu_MB`` (every buffer,
:attr:`TraceBuffers.nbytes <viewer.raytrace.upload.TraceBuffers>`), ``sah_cost`` (relative to
the root's area), and rays per second (millions) through ``passes/raytrace.glsl`` in a compute
kernel like ``learned/parity/checks/raytrace.py``'s ``trace_gl`` (:func:`trace`):
``closest_Mrays_s`` and, separately, ``any_Mrays_s`` (the shadow rays' query), ``2^18`` random
rays (``--quick``: ``2^16``; :func:`random_rays`), upload and read-back included.
"""
from __future__ import annotations

import math
import statistics
import time
import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from relight.reference.compare import Reference, ZTest, coverage_mask, score, z_test

ROOT = Path(__file__).resolve().parents[2]
SCENE_FOLDERS = ("assets/scenes/reference", "assets/scenes/shadows")
REFERENCES = "assets/references"
BLOCK = 4       # block_test's blocks are BLOCK x BLOCK pixels
ALPHA = 1e-3    # block_test's family-wise false-alarm rate (Bonferroni over blocks and channels)


# ---- the statistics (shared with tests/reference/test_path_convergence.py) -------------------

def blocks(a: np.ndarray, k: int = BLOCK) -> np.ndarray:
    """Means over ``k x k`` pixel blocks of ``[..., H, W, C]`` (a partial last row or column of
    blocks left out)."""
    h, w = a.shape[-3] // k * k, a.shape[-2] // k * k
    a = a[..., :h, :w, :]
    return a.reshape(a.shape[:-3] + (h // k, k, w // k, k, a.shape[-1])).mean(axis=(-4, -2))


def block_test(runs: np.ndarray, ref: Reference) -> ZTest:
    """The per-block z-test of the runs' mean against ``ref`` over blocks fully covered by both.

    ``runs`` ``[G, H, W, 4]``: G independent renders (seeds); the image's standard error per block
    is their spread / sqrt(G), the threshold the Student-t quantile of G - 1 degrees of freedom at
    :data:`ALPHA` / (2 x blocks x channels). Blocks of :data:`BLOCK` x BLOCK pixels are near normal
    where single pixels are not (a conductor's sun highlight is a few very bright samples)."""
    from scipy import stats

    covered = coverage_mask(runs.mean(0), ref).astype(np.float64)[..., None]
    full = blocks(covered)[..., 0] > 0.999
    mean_b = blocks(runs[..., :3])                       # [G, h, w, 3]
    ref_b = blocks(ref.radiance[..., :3].astype(np.float64))
    # the reference's block error: its pixels' errors are independent
    ref_se = np.sqrt(blocks(ref.stderr.astype(np.float64) ** 2)) / BLOCK
    se = mean_b.std(0, ddof=1) / math.sqrt(len(runs))
    image = np.zeros(ref_b.shape[:2] + (4,))
    image[..., :3] = mean_b.mean(0)
    image[..., 3] = 1.0
    block_ref = Reference(radiance=np.concatenate([ref_b, np.ones(ref_b.shape[:2] + (1,))], -1),
                          stderr=ref_se)
    return z_test(image, block_ref, image_stderr=se, alpha=ALPHA, mask=full,
                  quantile=lambda p: float(stats.t.isf(p, len(runs) - 1)))


def energy_bias(runs: np.ndarray, ref: Reference) -> tuple[float, float]:
    """``(bias, noise)``: the covered pixels' total radiance, mean over the runs, over the
    reference's, minus 1; and one standard error of it (the runs' spread / sqrt(G) and the
    reference's per-pixel errors, independent), as a fraction of the reference's total."""
    m = coverage_mask(runs.mean(0), ref)
    totals = runs[..., :3][:, m].sum(axis=(1, 2))
    ref_total = float(ref.radiance[..., :3][m].sum())
    noise = math.hypot(totals.std(ddof=1) / math.sqrt(len(runs)),
                       math.sqrt(float((ref.stderr[m].astype(np.float64) ** 2).sum())))
    return float(totals.mean() / ref_total - 1.0), noise / ref_total


# ---- configuration -------------------------------------------------------------------------

@dataclass(frozen=True)
class PathBenchConfig:
    seeds: int = 8                 # independent renders per scene (the z-test's groups)
    spp: int = 64                  # samples per pixel per render
    max_depth: int = 6             # path segments, as Mitsuba counts them (both renderers)
    scenes: tuple | None = None    # scene files; None: every one with a stored reference
    mitsuba: bool = True           # time Mitsuba beside (needs its LLVM variant)
    triangles: tuple = (10_000, 100_000, 1_000_000)  # the BVH rows' sizes
    shapes: tuple = ("soup", "sphere")
    rays: int = 1 << 18            # rays per BVH row

    @classmethod
    def from_bench(cls, config) -> PathBenchConfig:
        """The suite's configuration for a :class:`relight.bench.run.BenchConfig`: ``--quick``
        renders 16 samples per seed, builds no 10^6-triangle BVH and traces 2^16 rays."""
        if config.quick:
            return cls(spp=16, triangles=(10_000, 100_000), rays=1 << 16)
        return cls()


def reference_scenes(root: Path = ROOT) -> list[tuple[Path, Path]]:
    """``(scene file, stored reference)`` for every scene of :data:`SCENE_FOLDERS` whose
    reference (``assets/references/<stem>.exr``) exists, sorted by folder and name."""
    out = []
    for folder in SCENE_FOLDERS:
        for toml in sorted((root / folder).glob("*.toml")):
            ref = root / REFERENCES / f"{toml.stem}.exr"
            if ref.is_file():
                out.append((toml, ref))
    return out


# ---- the suite -----------------------------------------------------------------------------

def path_rows(renderer, cfg: PathBenchConfig = PathBenchConfig(), progress: bool = False
              ) -> list[dict]:
    """Every row of the suite (module docstring): scene rows, then BVH rows."""
    from relight.reference import read_reference
    from viewer.scene.description import load_scene

    pairs = ([(Path(s), ROOT / REFERENCES / f"{Path(s).stem}.exr") for s in cfg.scenes]
             if cfg.scenes is not None else reference_scenes())
    mitsuba = cfg.mitsuba and _mitsuba_ready()
    rows = []
    for scene_path, ref_path in pairs:
        scene = load_scene(scene_path)
        ref = read_reference(ref_path)
        row = scene_row(renderer, scene, ref, cfg, name=scene_path.stem)
        if mitsuba:
            speed = mitsuba_speed(scene, cfg.seeds * cfg.spp, cfg.max_depth)
            row["mitsuba_Msps"] = speed.pop("mitsuba_Msps")
            row["path_vs_mitsuba"] = row["path_Msps"] / row["mitsuba_Msps"]
            row["mitsuba_jit_s"] = speed.pop("mitsuba_jit_s")
            row["details"].update(speed)
        rows.append(row)
        if progress:
            _say(f"path: {row['scene']}: {row['failing']}/{row['blocks']} blocks fail, bias "
                 f"{row['bias_%']:+.2f} +- {row['bias_noise_%']:.2f} %, {row['path_Msps']:.3g} "
                 f"Msamples/s (Mitsuba {row.get('mitsuba_Msps', math.nan):.3g})")
    rows += bvh_rows(renderer.programs, cfg.triangles, cfg.shapes, cfg.rays, progress=progress)
    return rows


def scene_row(renderer, scene, ref: Reference, cfg: PathBenchConfig, name: str) -> dict:
    """The ``kind = "scene"`` row of ``scene`` against ``ref`` without Mitsuba's columns."""
    from viewer.raytrace.gather import traced_meshes

    base = scene.with_render(model="path", max_depth=cfg.max_depth)
    renderer.resources.trace.release()  # this scene's BVH built afresh (scenes share meshes)
    t0 = time.perf_counter()
    renderer.render(base.with_render(samples=1, seed=cfg.seeds))  # BVH, upload, programs
    first_s = time.perf_counter() - t0
    build_ms = 1e3 * renderer.resources.trace.build_seconds
    runs, seconds = [], []
    for s in range(cfg.seeds):
        t0 = time.perf_counter()
        frame = renderer.render(base.with_render(samples=cfg.spp, seed=s))
        seconds.append(time.perf_counter() - t0)
        runs.append(frame.radiance)
    runs = np.asarray(runs, np.float64)
    h, w = runs.shape[1:3]
    test = block_test(runs, ref)
    bias, noise = energy_bias(runs, ref)
    sc = score(runs.mean(0), ref)
    per_spp = statistics.median(seconds) / cfg.spp
    triangles = sum(len(m.indices) // 3 for m in traced_meshes(
        [(obj, renderer.geometry(obj)) for obj in scene.objects]))
    return {"kind": "scene", "scene": name, "triangles": triangles, "build_ms": build_ms,
            "size": [w, h], "spp": cfg.spp, "blocks": test.count, "failing": test.failing,
            "max_z": test.max_abs_z, "z_threshold": test.threshold,
            "bias_%": 100 * bias, "bias_noise_%": 100 * noise, "psnr_db": sc.psnr,
            "ms_per_spp": 1e3 * per_spp, "path_Msps": w * h / per_spp / 1e6,
            "details": {"seeds": cfg.seeds, "max_depth": cfg.max_depth,
                        "reference_spp": int(ref.meta.get("spp", 0)), "passed": test.passed,
                        "path_first_s": first_s, "frame_s": seconds}}


def _mitsuba_ready() -> bool:
    """Whether Mitsuba's LLVM variant runs here (else its columns are left out, with a
    warning: the scalar backend's speed says nothing about Mitsuba's)."""
    from viewer.errors import RelightError

    try:
        from relight.reference import load_mitsuba

        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            variant = load_mitsuba(None)[2]
        if variant.startswith("scalar"):
            raise RelightError("needs Mitsuba's LLVM variant (libLLVM >= 19)")
    except (ImportError, RelightError) as exc:
        warnings.warn(f"relight bench path: Mitsuba's columns left out ({exc})", stacklevel=2)
        return False
    return True


def mitsuba_speed(scene, spp: int, max_depth: int) -> dict:
    """Mitsuba's samples per second on ``scene`` (module docstring): calls of 1 (cold), 1 and 1
    (warm: the faster) and ``spp`` samples per pixel, timed around
    :func:`relight.reference.render_reference`."""
    from relight.reference import ReferenceOptions, render_reference

    def timed(n):
        t0 = time.perf_counter()
        render_reference(scene, ReferenceOptions(spp=n, max_depth=max_depth), progress=False)
        return time.perf_counter() - t0

    cold = timed(1)
    warm = min(timed(1), timed(1))
    full = timed(spp)
    w, h = scene.camera.width, scene.camera.height
    return {"mitsuba_spp": spp, "mitsuba_Msps": (spp - 1) * w * h / max(full - warm, 1e-9) / 1e6,
            "mitsuba_setup_s": warm, "mitsuba_jit_s": max(cold - warm, 0.0)}


# ---- the BVH -------------------------------------------------------------------------------

# closest hit (MODE 0: t, triangle) or any hit (MODE 1) of each ray, as trace_gl's kernel
_KERNEL = """#include "passes/raytrace.glsl"
layout(local_size_x = 64) in;
uniform uint u_count;
layout(std430, binding = 0) readonly buffer In { float inv[]; };    // [n][7] o, d, t_max
layout(std430, binding = 1) writeonly buffer Out { float outv[]; };
void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= u_count) return;
    vec3 o = vec3(inv[7u * i], inv[7u * i + 1u], inv[7u * i + 2u]);
    vec3 d = vec3(inv[7u * i + 3u], inv[7u * i + 4u], inv[7u * i + 5u]);
    float t_max = inv[7u * i + 6u];
#if MODE == 0
    RayHit h = bvh_closest_hit(o, d, t_max);
    outv[2u * i] = h.t;
    outv[2u * i + 1u] = float(h.triangle);
#else
    outv[2u * i] = bvh_any_hit(o, d, t_max) ? 1.0 : 0.0;
    outv[2u * i + 1u] = 0.0;
#endif
}
"""


def trace(programs, buffers, rays: np.ndarray, any_hit: bool = False) -> np.ndarray:
    """``[n, 2]``: (t, triangle; -1 for a miss) of each ray's closest hit, or (1/0, 0): whether
    it hits anything (``any_hit``), through ``passes/raytrace.glsl`` on ``buffers``
    (a :class:`~viewer.raytrace.upload.TraceBuffers`)."""
    from viewer.gl.kernels import run_kernel

    return run_kernel(programs, "<bench:raytrace>", rays, 2, lambda prog: buffers.bind(prog, 0),
                      virtual={"<bench:raytrace>": _KERNEL}, defines={"MODE": int(any_hit)})


def random_rays(n: int, seed: int = 0) -> np.ndarray:
    """``[n, 7]`` float32: origins in a 6 m box above y = 0.5 (as the parity check's rays),
    unit directions towards the unit box the meshes fill, t_max 100."""
    rng = np.random.default_rng(seed)
    o = rng.uniform(-3.0, 3.0, (n, 3))
    o[:, 1] = np.abs(o[:, 1]) + 0.5
    d = rng.uniform(-1.2, 1.2, (n, 3)) - o
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    return np.concatenate([o, d, np.full((n, 1), 100.0)], axis=1).astype(np.float32)


def bench_mesh(shape: str, triangles: int, seed: int = 0):
    """A mesh of about ``triangles`` triangles in the unit box: ``"soup"``, random triangles
    (centres uniform in [-1, 1]^3, corners spread by about half the mean spacing, so they
    overlap as a dense soup does), or ``"sphere"``, a UV sphere of radius 1."""
    from viewer.geometry import primitives
    from viewer.geometry.mesh import Mesh

    if shape == "sphere":
        seg = round(math.sqrt(triangles)) + 1
        return primitives.sphere(segments=seg, rings=max(seg // 2, 2))
    if shape != "soup":
        raise ValueError(f"unknown BVH bench shape {shape!r}")
    rng = np.random.default_rng(seed)
    spread = 0.5 * (8.0 / triangles) ** (1.0 / 3.0)
    p = rng.uniform(-1.0, 1.0, (triangles, 1, 3)) + rng.normal(0.0, spread, (triangles, 3, 3))
    p = p.reshape(-1, 3).astype(np.float32)
    normals = np.tile(np.array([[0.0, 1.0, 0.0]], np.float32), (len(p), 1))
    return Mesh(positions=p, normals=normals,
                indices=np.arange(3 * triangles, dtype=np.uint32).reshape(triangles, 3))


def bvh_rows(programs, sizes=(10_000, 100_000), shapes=("soup", "sphere"), rays: int = 1 << 16,
             progress: bool = False) -> list[dict]:
    """One ``kind = "bvh"`` row per (size, shape) (module docstring)."""
    from viewer.raytrace.scene import build_trace_geometry
    from viewer.raytrace.upload import TraceBuffers

    build_trace_geometry([bench_mesh("soup", 64)])  # numba's compilation (or its cache's load)
    ray_array = random_rays(rays)
    rows = []
    for n in sizes:
        for shape in shapes:
            mesh = bench_mesh(shape, n)
            t0 = time.perf_counter()  # what TraceStore.build_seconds times
            geo = build_trace_geometry([mesh])
            buffers = TraceBuffers(programs.ctx, geo)
            programs.ctx.finish()
            build_s = time.perf_counter() - t0
            try:
                buffers.set_materials([mesh])
                rates, hit = {}, 0.0
                for any_hit in (False, True):
                    trace(programs, buffers, ray_array[:256], any_hit)  # compile, warm
                    t0 = time.perf_counter()
                    out = trace(programs, buffers, ray_array, any_hit)
                    rates[any_hit] = len(ray_array) / (time.perf_counter() - t0) / 1e6
                    if not any_hit:
                        hit = float((out[:, 1] >= 0).mean())
                gpu_bytes = buffers.nbytes
            finally:
                buffers.release()
            bvh = geo.bvh
            row = {"kind": "bvh", "scene": shape, "triangles": geo.triangle_count,
                   "build_ms": 1e3 * build_s, "bvh_ms": 1e3 * bvh.seconds,
                   "nodes": bvh.node_count,
                   "bvh_MB": bvh.nbytes / 2**20, "gpu_MB": gpu_bytes / 2**20,
                   "sah_cost": bvh.sah_cost(), "rays": len(ray_array),
                   "closest_Mrays_s": rates[False], "any_Mrays_s": rates[True],
                   "details": {"depth": bvh.depth, "hit_%": 100 * hit,
                               "bvh_bytes": bvh.nbytes, "gpu_bytes": gpu_bytes}}
            rows.append(row)
            if progress:
                _say(f"path: BVH {shape} {geo.triangle_count} triangles: "
                     f"{bvh.seconds:.3f} s, {row['closest_Mrays_s']:.3g} Mrays/s")
    return rows


def _say(text: str) -> None:
    import sys

    print(text, file=sys.stderr, flush=True)
