"""What shadows cost in pyrender, the headless Python renderer a user would pick instead: the bench's
demo scene rebuilt in pyrender (ten UV spheres of 9,216 triangles, radius 0.9, 2.2 apart, on a
16 x 10 floor; the demo's camera) at 512^2 under 1 and 4 directional lights placed as
``relight bench --suite shadows`` places them, each frame timed with pyrender's directional shadow
maps (``RenderFlags.SHADOWS_DIRECTIONAL``, its 2048^2 maps) and without, in the same run.

Standalone: pyrender pins PyOpenGL 3.1.0 and needs numpy < 2, which this project's environment does
not hold, so it runs in its own, whose requirements are ``requirements-pyrender.txt`` beside it::

    python -m venv /tmp/pyrender-venv
    /tmp/pyrender-venv/bin/pip install -r relight/bench/external/requirements-pyrender.txt
    /tmp/pyrender-venv/bin/python relight/bench/external/pyrender_shadows.py --frames 30

It prints one markdown row per light count (medians of ``--frames`` frames after 3 warm-up
frames; ``glFinish`` inside pyrender's read-back ends each frame).
"""
from __future__ import annotations

import argparse
import os
import time

os.environ.setdefault("PYOPENGL_PLATFORM", "egl")

import numpy as np  # noqa: E402


def look_at(eye, target, up=(0.0, 1.0, 0.0)) -> np.ndarray:
    eye, target, up = (np.asarray(v, np.float64) for v in (eye, target, up))
    f = target - eye
    f /= np.linalg.norm(f)
    s = np.cross(f, up)
    s /= np.linalg.norm(s)
    m = np.eye(4)
    m[:3, 0], m[:3, 1], m[:3, 2], m[:3, 3] = s, np.cross(s, f), -f, eye
    return m


def demo_scene(lights: int):
    import pyrender
    import trimesh

    scene = pyrender.Scene(ambient_light=[0.1, 0.1, 0.1])
    ball = pyrender.Mesh.from_trimesh(
        trimesh.creation.uv_sphere(radius=0.9, count=[25, 96]),
        material=pyrender.MetallicRoughnessMaterial(baseColorFactor=[0.85, 0.55, 0.25, 1.0],
                                                    roughnessFactor=0.5))
    for row in range(2):
        for col in range(5):
            pose = np.eye(4)
            pose[:3, 3] = [(col - 2) * 2.2, 1.1 + (0.5 - row) * 2.2, 0.0]
            scene.add(ball, pose=pose)
    floor = np.eye(4)
    floor[1, 3] = -1.0
    scene.add(pyrender.Mesh.from_trimesh(
        trimesh.creation.box(extents=[16.0, 0.01, 10.0]),
        material=pyrender.MetallicRoughnessMaterial(baseColorFactor=[0.5, 0.5, 0.5, 1.0])),
        pose=floor)
    scene.add(pyrender.PerspectiveCamera(yfov=np.radians(34.0)),
              pose=look_at([0.0, 3.6, 12.5], [0.0, 0.6, 0.0]))
    for i in range(lights):  # relight.bench.shadows._lights: around the sky, 45 degrees up
        a = 2.0 * np.pi * i / lights
        d = np.array([np.cos(a) * 0.7071, 0.7071, np.sin(a) * 0.7071])
        scene.add(pyrender.DirectionalLight(intensity=2.0 / lights),
                  pose=look_at(d * 10.0, [0.0, 0.0, 0.0]))
    return scene


def median_ms(renderer, scene, flags, frames: int) -> float:
    for _ in range(3):
        renderer.render(scene, flags=flags)
    times = []
    for _ in range(frames):
        t = time.perf_counter()
        renderer.render(scene, flags=flags)
        times.append((time.perf_counter() - t) * 1000.0)
    return float(np.median(times))


def main() -> None:
    import pyrender

    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--frames", type=int, default=30)
    args = parser.parse_args()
    renderer = pyrender.OffscreenRenderer(512, 512)
    print("| renderer | lights | size | ms_shadows | ms_without | ratio |")
    print("|---|---|---|---|---|---|")
    for lights in (1, 4):
        scene = demo_scene(lights)
        on = median_ms(renderer, scene, pyrender.RenderFlags.SHADOWS_DIRECTIONAL, args.frames)
        off = median_ms(renderer, scene, pyrender.RenderFlags.NONE, args.frames)
        print(f"| pyrender {pyrender.__version__} | {lights} | 512x512 | {on:.1f} | {off:.1f} | "
              f"{on / off:.2f} |")
    renderer.delete()


if __name__ == "__main__":
    main()
