"""Synthetic datasets in the FFHQ256-PBR layout, rendered by the workbench.

    relight-style use:  generate("data/quick", GeneratorConfig(count=24, size=64), progress=True)

Every sample is a random scene seen from a camera at the origin looking down -Z (so camera space is
world space, as the layout wants): 1-3 spheres and meshes (torus, box, capsule made with trimesh)
with random materials, usually a floor plane, under a procedural sky (random sun) or studio, or
one of ``env_paths``, at a random intensity and rotation (baked into the written ``env.exr``).
The target ``rgb.exr`` is the Monte-Carlo reference ``ggx_mc`` (``samples`` per pixel, MIS) with
the G-buffer AO, SSAO and one-bounce indirect light when the renderer has them (see
:func:`target_settings`) - so the shadow stage has occlusion to learn; otherwise ``ggx_split_sum``.

Deterministic for a seed (sample i draws from ``default_rng([seed, i])``; its split is fixed by i),
resumable (a finished sample is a folder; one being written is ``<name>.tmp`` and is redone), and
shows a tqdm progress bar.
"""
from __future__ import annotations

import json
import math
import os
import shutil
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np

SPLIT_PATTERN = ("train",) * 8 + ("val", "test")  # sample i -> SPLIT_PATTERN[i % 10]
FORMAT = "relight-ffhq-pbr-synthetic/1"


@dataclass(frozen=True)
class GeneratorConfig:
    count: int = 24
    size: int = 64  # square images
    samples: int = 256  # Monte-Carlo samples per pixel of the target
    seed: int = 0
    env_width: int = 128
    env_paths: tuple[str, ...] = ()  # extra equirect HDR/EXR files to draw from
    meshes: bool = True


def split_of(index: int) -> str:
    return SPLIT_PATTERN[index % len(SPLIT_PATTERN)]


def target_settings(samples: int) -> dict:
    """Render settings of the targets: ggx_mc + AO + SSAO + indirect when available."""
    from viewer.models import MODELS
    from viewer.scene import RenderSettings

    names = {f.name for f in RenderSettings.__dataclass_fields__.values()}
    if "ggx_mc" in MODELS:
        kw = {"model": "ggx_mc", "samples": int(samples), "sampling": "mis", "ao": True}
    else:  # pragma: no cover - before the Monte-Carlo model existed
        kw = {"model": "ggx_split_sum", "ao": True}
    for k in ("ssao", "indirect"):
        if k in names:
            kw[k] = True
    kw.update({"background": "environment", "tonemap": "none"})
    return kw


def _mesh_files(cache: Path) -> dict[str, Path]:
    import trimesh

    cache.mkdir(parents=True, exist_ok=True)
    makers = {"torus": lambda: trimesh.creation.torus(0.6, 0.25, 48, 24),
              "box": lambda: trimesh.creation.box((0.9, 0.9, 0.9)),
              "capsule": lambda: trimesh.creation.capsule(0.8, 0.35, count=(24, 24))}
    out = {}
    for name, make in makers.items():
        p = cache / f"{name}.obj"
        if not p.is_file():
            tmp = cache / f"{name}.tmp.obj"
            make().export(tmp)
            os.replace(tmp, p)
        out[name] = p
    return out


def _material(rng) -> dict:
    metal = rng.random() < 0.25
    return {"albedo": [float(x) for x in rng.uniform(0.05, 0.95, 3)],
            "roughness": float(rng.uniform(0.05, 1.0)),
            "metallic": 1.0 if metal else float(rng.uniform(0.0, 0.1)),
            "specular": float(rng.uniform(0.2, 1.0)),
            "ao": float(rng.uniform(0.6, 1.0))}


def _rotation(rng) -> list[list[float]]:
    a, b = rng.uniform(0, 2 * math.pi, 2)
    ca, sa, cb, sb = math.cos(a), math.sin(a), math.cos(b), math.sin(b)
    ry = np.array([[ca, 0, sa], [0, 1, 0], [-sa, 0, ca]])
    rx = np.array([[1, 0, 0], [0, cb, -sb], [0, sb, cb]])
    return (ry @ rx).tolist()


def random_scene(rng, config: GeneratorConfig, meshes: dict[str, Path]) -> dict:
    """A scene dict (``viewer.scene.scene_from_dict`` format) without its environment."""
    objects = []
    for k in range(int(rng.integers(1, 4))):
        center = [float(rng.uniform(-1.0, 1.0)), float(rng.uniform(-0.4, 0.6)),
                  float(rng.uniform(-4.5, -3.0))]
        radius = float(rng.uniform(0.4, 0.8))
        if meshes and config.meshes and rng.random() < 0.4:
            name = sorted(meshes)[int(rng.integers(0, len(meshes)))]
            rot = np.array(_rotation(rng)) * radius * 1.2
            m = np.eye(4)
            m[:3, :3] = rot
            m[:3, 3] = center
            objects.append({"type": "mesh", "path": str(meshes[name]), "transform": m.tolist(),
                            "material": _material(rng)})
        else:
            objects.append({"type": "sphere", "center": center, "radius": radius,
                            "material": _material(rng)})
    if rng.random() < 0.75:
        objects.append({"type": "plane", "center": [0.0, float(rng.uniform(-1.2, -0.7)), -4.0],
                        "size": [12.0, 12.0], "material": _material(rng)})
    fov = float(rng.uniform(30.0, 50.0))
    return {"camera": {"position": [0, 0, 0], "target": [0, 0, -1], "up": [0, 1, 0],
                       "fov_y": fov, "size": [config.size, config.size]},
            "objects": objects}


def random_environment(rng, config: GeneratorConfig) -> tuple[np.ndarray, dict]:
    """An equirect ``[H, W, 3]`` radiance image (intensity and rotation baked) and its recipe."""
    from viewer.environment import EnvironmentSpec, load_environment

    choices = ["sky", "sky", "studio"] + list(config.env_paths)
    pick = choices[int(rng.integers(0, len(choices)))]
    if pick in ("sky", "studio"):
        spec = EnvironmentSpec(procedural=pick, width=config.env_width,
                               sun_elevation_deg=float(rng.uniform(10.0, 70.0)),
                               sun_azimuth_deg=float(rng.uniform(-180.0, 180.0)))
    else:
        spec = EnvironmentSpec(path=pick, width=config.env_width)
    env = load_environment(spec)
    if env.shape[1] != config.env_width:
        from viewer.environment import resample

        env = resample(env, config.env_width, config.env_width // 2)
    intensity = float(rng.uniform(0.5, 1.5)) * (0.05 if pick == "sky" else 1.0) ** 0.5
    shift = int(rng.integers(0, env.shape[1]))  # a rotation about +Y by whole texels
    env = np.roll(env, shift, axis=1) * intensity
    return env.astype(np.float32), {"source": pick, "intensity": intensity,
                                    "rotation_texels": shift}


def generate(root: str | os.PathLike, config: GeneratorConfig = GeneratorConfig(),
             renderer=None, progress: bool = True) -> dict:
    """Write ``config.count`` samples under ``root/<split>/<name>``; finished ones are kept."""
    from tqdm import tqdm

    from viewer.imageio import write_exr
    from viewer.renderer import Renderer
    from viewer.scene import scene_from_dict

    root = Path(root)
    root.mkdir(parents=True, exist_ok=True)
    info = {"format": FORMAT, "config": asdict(config), "targets": target_settings(config.samples)}
    info_path = root / "dataset.json"
    if info_path.is_file():
        old = json.loads(info_path.read_text())
        new = json.loads(json.dumps(info["config"]))
        if old.get("config", {}) | {"count": 0} != new | {"count": 0}:
            from .reader import DatasetError

            raise DatasetError("was generated with another configuration; use a new folder "
                               "(nothing was overwritten)", where=info_path)
    tmp_info = root / "dataset.json.tmp"
    tmp_info.write_text(json.dumps(info, indent=1))
    os.replace(tmp_info, info_path)
    meshes = _mesh_files(root / "_meshes") if config.meshes else {}
    own = renderer is None
    renderer = renderer or Renderer()
    done = skipped = 0
    try:
        bar = tqdm(range(config.count), desc="generate", unit="sample", disable=not progress)
        for i in bar:
            name = f"{i:06d}"
            final = root / split_of(i) / name
            if final.is_dir():
                skipped += 1
                continue
            _write_sample(renderer, final, i, config, meshes, write_exr, scene_from_dict)
            done += 1
    finally:
        if own:
            renderer.release()
    return {"written": done, "kept": skipped, "root": str(root)}


def _write_sample(renderer, final: Path, index: int, config: GeneratorConfig, meshes, write_exr,
                  scene_from_dict) -> None:
    rng = np.random.default_rng([config.seed, index])
    tmp = final.with_name(final.name + ".tmp")
    if tmp.exists():
        shutil.rmtree(tmp)
    tmp.mkdir(parents=True)
    scene_dict = random_scene(rng, config, meshes)
    env, env_info = random_environment(rng, config)
    write_exr(tmp / "env.exr", env, ["R", "G", "B"])
    scene_dict["environment"] = {"path": str(tmp / "env.exr")}
    scene_dict["render"] = target_settings(config.samples) | {"seed": int(rng.integers(0, 1 << 30))}
    scene = scene_from_dict(scene_dict, file=str(tmp / "scene"))
    aovs = ("albedo", "normal", "roughness", "metallic", "specular", "depth", "ao", "alpha")
    frame = renderer.render(scene, aovs=aovs)
    a = frame.aovs
    fg = a["alpha"] > 0.0
    write_exr(tmp / "rgb.exr", frame.radiance[..., :3], ["R", "G", "B"])
    write_exr(tmp / "albedo.exr", a["albedo"], ["R", "G", "B"])
    normal = np.where(fg, a["normal"] * 0.5 + 0.5, 0.5)
    write_exr(tmp / "normal.exr", normal, ["R", "G", "B"])
    for name in ("roughness", "metallic", "specular", "depth", "ao"):
        write_exr(tmp / f"{name}.exr", a[name], ["Y"])
    write_exr(tmp / "mask.exr", a["alpha"], ["Y"])
    (tmp / "camera.json").write_text(json.dumps({"fov_y": scene_dict["camera"]["fov_y"]}))
    meta = {"index": index, "seed": config.seed, "environment": env_info,
            "objects": [{k: v for k, v in o.items() if k != "path"} | (
                {"mesh": Path(o["path"]).stem} if "path" in o else {})
                for o in scene_dict["objects"]],
            "render": scene_dict["render"]}
    (tmp / "meta.json").write_text(json.dumps(meta, indent=1))
    os.replace(tmp, final)
