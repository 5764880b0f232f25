"""Benchmarks of the neural shaders (rows for ``relight bench``; not timed tests).

* :func:`student_vs_teacher`: frame time and PSNR against a Monte-Carlo reference (``ggx_mc``, many
  samples) of the student (``neural``), the GLSL teacher at ``teacher_samples`` samples
  (``neural_teacher``) and ``ggx_split_sum`` on one scene; the issue's goals are a frame-time
  ratio teacher / student >= 100 and a PSNR difference <= 1 dB.
* :func:`student_throughput`: the student MLP alone, GLSL (compute kernel over ``pixels`` inputs,
  generated code) against torch on the same weights and inputs (goal: GLSL >= torch).

Rows: ``{"model", "variant", "samples", "size", "ms", "psnr"}`` (+ extras). Torch is imported only
for the torch throughput row (``learned`` extra); without it that row is left out.
"""
from __future__ import annotations

import time

import numpy as np

from .metrics import psnr

BENCH_SCENE = {
    "camera": {"position": [0.0, 0.4, 3.4], "target": [0, 0, 0], "fov_y": 40, "size": [128, 128]},
    "environment": {"procedural": "sky", "intensity": 0.4, "width": 256},
    "objects": [
        {"type": "sphere", "center": [-0.7, 0, 0], "radius": 0.6,
         "material": {"albedo": [0.8, 0.3, 0.2], "roughness": 0.35}},
        {"type": "sphere", "center": [0.7, 0, 0], "radius": 0.6,
         "material": {"albedo": [0.9, 0.8, 0.6], "roughness": 0.25, "metallic": 1.0}},
        {"type": "plane", "center": [0, -0.6, 0], "size": [8, 8],
         "material": {"albedo": [0.5, 0.5, 0.5], "roughness": 0.8}},
    ],
    "render": {"tonemap": "none"},
}


def _time(renderer, scene, repeats: int) -> tuple[float, np.ndarray]:
    frame = renderer.render(scene)  # warm-up: programs, IBL, sampling tables
    best = float("inf")
    for _ in range(repeats):
        renderer.ctx.finish()
        t0 = time.perf_counter()
        frame = renderer.render(scene)
        best = min(best, time.perf_counter() - t0)
    return 1e3 * best, frame.radiance[..., :3]


def _tm(x: np.ndarray) -> np.ndarray:
    x = np.clip(x, 0.0, None)
    return x / (1.0 + x)


def student_vs_teacher(renderer, teacher_samples: int = 128, reference_samples: int = 1024,
                       repeats: int = 3, scene=None) -> list[dict]:
    from ..models import MODELS
    from ..scene import scene_from_dict

    scene = scene or scene_from_dict(BENCH_SCENE)
    size = f"{scene.camera.width}x{scene.camera.height}"
    ref_model = "ggx_mc" if "ggx_mc" in MODELS else "ggx_split_sum"
    ref = renderer.render(scene.with_render(model=ref_model, samples=reference_samples,
                                            sampling="mis")).radiance[..., :3]
    rows = []
    for model, variant, kw in (("neural", "student", {}),
                               ("neural_teacher", "env", {"samples": teacher_samples,
                                                          "sampling": "env"}),
                               ("ggx_split_sum", "", {})):
        ms, img = _time(renderer, scene.with_render(model=model, **kw), repeats)
        rows.append({"model": model, "variant": variant, "samples": kw.get("samples", 1),
                     "size": size, "ms": ms, "psnr": psnr(_tm(ref), _tm(img)),
                     "reference": f"{ref_model} {reference_samples} spp"})
    s, t = rows[0], rows[1]
    s["frame_time_ratio_teacher_over_student"] = t["ms"] / s["ms"]
    s["psnr_minus_teacher"] = s["psnr"] - t["psnr"]
    return rows


_KERNEL = """
#include "lib/common.glsl"
#include "generated/neural_student.glsl"
layout(local_size_x = 64) in;
uniform uint u_count;
layout(std430, binding = 0) readonly buffer In { float inv[]; };
layout(std430, binding = 1) writeonly buffer Out { float outv[]; };
void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= u_count) return;
    uint b = 8u * i;
    vec3 kd;
    vec3 ks;
    neural_student_weights(vec3(inv[b], inv[b + 1u], inv[b + 2u]), inv[b + 3u], inv[b + 4u],
                           inv[b + 5u], inv[b + 6u], inv[b + 7u], kd, ks);
    outv[6u * i] = kd.x; outv[6u * i + 1u] = kd.y; outv[6u * i + 2u] = kd.z;
    outv[6u * i + 3u] = ks.x; outv[6u * i + 4u] = ks.y; outv[6u * i + 5u] = ks.z;
}
"""


def student_throughput(programs, weights=None, pixels: int = 65536, repeats: int = 5
                       ) -> list[dict]:
    """GLSL vs torch evaluation of the student MLP on the same ``pixels`` random inputs."""
    from ..neural import default_weights, load_network

    path = weights or default_weights("student")
    net = load_network(path, "student")
    ctx = programs.ctx
    name = "<bench:neural_student>"
    prog = programs.compute(name, virtual={name: _KERNEL, net.include_name: net.glsl})
    x = np.random.default_rng(0).uniform(0, 1, (pixels, 8)).astype(np.float32)
    src = ctx.buffer(x.tobytes())
    dst = ctx.buffer(reserve=4 * 6 * pixels)
    try:
        src.bind_to_storage_buffer(0)
        dst.bind_to_storage_buffer(1)
        prog["u_count"].value = pixels
        best = float("inf")
        for i in range(repeats + 1):
            ctx.finish()
            t0 = time.perf_counter()
            prog.run((pixels + 63) // 64)
            ctx.finish()
            if i:
                best = min(best, time.perf_counter() - t0)
    finally:
        src.release()
        dst.release()
    size = f"{pixels} px"
    rows = [{"model": "neural", "variant": "mlp glsl (baked constants)", "samples": 1,
             "size": size, "ms": 1e3 * best, "psnr": None, "macs_per_pixel": net.macs(),
             "gflops": 2e-9 * net.macs() * pixels / best}]
    try:
        from learned.evaluate import torch_student_throughput
    except ImportError:
        return rows
    t = torch_student_throughput(path, pixels, repeats)
    rows.append({"model": "neural", "variant": "mlp torch (cpu)", "samples": 1, "size": size,
                 "ms": 1e3 * t["seconds"], "psnr": None, "macs_per_pixel": net.macs(),
                 "gflops": 2e-9 * net.macs() * pixels / t["seconds"]})
    rows[0]["speedup_over_torch"] = t["seconds"] / best
    return rows


def neural_rows(renderer, quick: bool = False) -> list[dict]:
    """Everything above, for ``relight bench``."""
    rows = student_vs_teacher(renderer, teacher_samples=128,
                              reference_samples=256 if quick else 1024,
                              repeats=1 if quick else 3)
    rows += student_throughput(renderer.programs, pixels=16384 if quick else 65536)
    return rows
