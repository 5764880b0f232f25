"""The real-asset bench's splat capture (issue 38: "a splat capture" among the real assets): a
bundled glTF model tiled with flat Gaussians of its true materials, standing on the same slab
floor under the same HDRI, against the path-traced truth of the model itself.

The cloud is what a perfect capture and decomposition of the model would give
(:func:`learned.data.splat_tiling.scene_splats`: about one splat per pixel of the camera,
each with its surface's albedo, roughness, metallic and interpolated vertex normal; the gun's
normal map is not applied), written once per model, size and tiler version under the bench's
truth cache (one ``.ply`` per model and size: the cache's bound). The floor stays the slab mesh,
so the truth is the mesh scene's, already cached. Rays see the cloud as its Gaussians' opaque
cores (:mod:`viewer.raytrace.splat_proxies`), so the cases drawn (:data:`SPLAT_CASES`) are
split-sum and the student with rays (the default render), and the screen-space ones: split-sum,
the student, and the shadow estimator, each with SSAO and the indirect light, and split-sum and
the student with the estimator's visibility in place of SSAO's.
"""
from __future__ import annotations

import hashlib
import json
import os
from dataclasses import replace
from pathlib import Path

# (name, the model of relight.bench.real_assets.ASSETS whose scene is tiled)
SPLAT_ASSETS: tuple[tuple[str, str], ...] = (("cge_plasma_gun_splats", "cge_plasma_gun"),)
ESTIMATOR_CASE = "split-sum, screen + "  # the label of an estimator's case, + its name
SPLAT_CASES = ("split-sum, rays", "neural, rays", "split-sum, screen", "neural, screen",
               "neural S(x), screen", "split-sum, screen + estimator",
               "split-sum, estimator's V", "neural, estimator's V")


def splat_scene(scene, cache: Path, name: str):
    """``scene`` with its mesh objects replaced by one cloud tiling them (module doc), its other
    objects (the slab floor, a plane) kept."""
    from learned.data.splat_tiling import SPACING, scene_splats
    from viewer.environment.disk_cache import file_digest
    from viewer.scene.description import ObjectSpec
    from viewer.splats.ply import write_ply

    models = [o for o in scene.objects if o.type == "mesh"]
    rest = tuple(o for o in scene.objects if o.type != "mesh")
    if not models:
        raise ValueError(f"{name}: no mesh object to tile with splats")
    files = sorted(o.path for o in models if o.path)
    key = hashlib.sha256(json.dumps(
        [SPACING, list(scene.camera.size), [repr(o) for o in models],
         [file_digest(f) for f in files]], sort_keys=True).encode()).hexdigest()[:16]
    folder = Path(cache) / "splats"
    path = folder / f"{name}_{scene.camera.size[0]}x{scene.camera.size[1]}_{key}.ply"
    if not path.is_file():
        cloud = scene_splats(replace(scene, objects=tuple(models)), SPACING)
        folder.mkdir(parents=True, exist_ok=True)
        for old in folder.glob(f"{name}_{scene.camera.size[0]}x{scene.camera.size[1]}_*.ply"):
            old.unlink()  # another version of the same cloud: one file per model and size
        tmp = path.with_suffix(f".{os.getpid()}.tmp")
        write_ply(tmp, cloud, comments=[f"tiled from {files[0] if files else name}"])
        os.replace(tmp, path)
    return replace(scene, objects=(ObjectSpec(type="splats", path=str(path)),) + rest)


def splat_cases(case_list):
    """The cases of ``case_list`` a splat scene is drawn with (:data:`SPLAT_CASES`, the
    candidate estimators' of ``--estimator`` and students' of ``--student``, and the
    ``--variant`` cases of any of them)."""
    drawn = {c.label for c in case_list if c.label in SPLAT_CASES
             or c.label.startswith(ESTIMATOR_CASE)  # candidate estimators too
             or ("weights" in c.render and c.baseline in SPLAT_CASES)}  # candidate students
    return tuple(c for c in case_list if c.label in drawn or c.baseline in drawn
                 and c.label.startswith(c.baseline + "; "))


def splat_scenes(options, envs, cache: Path, files: dict, scene_of):
    """(name, the splat scene, its model's cached truth) of every :data:`SPLAT_ASSETS` entry
    that ``options.assets`` selects (:class:`relight.bench.real_assets.Options`), under each
    lighting of ``envs`` (``(name, HDRI, sun_strength)``, :func:`~relight.bench.real_assets.lightings`);
    ``files``: model name -> glTF file, ``scene_of(file, env, size, sun_strength)``: its mesh
    scene (:func:`relight.bench.real_assets.asset_scene`)."""
    from relight.gallery.cases import GalleryOptions
    from relight.gallery.panels import cached_truth

    truth_options = GalleryOptions(cache=cache, progress=options.progress)
    for name, asset in SPLAT_ASSETS:
        if options.assets is not None and name not in options.assets:
            continue
        for env_name, env_path, sun in envs:
            scene = scene_of(files[asset], env_path, options.size, sun)
            truth = cached_truth(scene, f"{asset}_{env_name}", truth_options, options.spp)
            yield f"{name}/{env_name}", splat_scene(scene, cache, name), truth
