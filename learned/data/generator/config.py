"""The generator's configuration: :class:`GeneratorConfig`, the scene kinds and environments it
draws from, the render settings of the targets, the split of a sample, and the checks of a
configuration (:func:`check_config`, :func:`held_out_config`) made before anything is written."""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from assets import ASSET_ROOT
from viewer.models import MODELS
from viewer.scene.settings import RenderSettings

from ..reader import DatasetError

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
    gbuffer_fraction: float = 0.0  # share of samples whose geometry is an image G-buffer
    gbuffers: tuple[str, ...] = ()  # FFHQ256-PBR folders / 12-channel stack EXRs to draw from
    # sample i's scene: scene_kinds[i % len] (SCENE_KINDS; "random" = random_scene, as before)
    scene_kinds: tuple[str, ...] = ("random",)
    targets: str = "rasteriser"  # TARGETS: where rgb.exr comes from
    reference_spp: int = 256  # path-traced samples per pixel (targets = "reference")
    reference_depth: int = 4  # Mitsuba path depth (targets = "reference")
    # the procedural environments drawn from beside env_paths (repeats weight the draw; () = the
    # files alone, e.g. a held-out set of real HDRIs)
    env_procedural: tuple[str, ...] = ("sky", "sky", "studio")
    # degraded inputs (0 = off): the written G-buffer is wrong the way inverse-rendering estimates
    # are (noisy normals, shading baked into albedo, biased roughness) at this strength (<= 1);
    # the targets stay those of the true scene (degrade_inputs)
    degrade: float = 0.0
    # the share of samples whose environment loses its compact sun and lamps (its sun_strength
    # 0: viewer.environment.maps.scale_sun; a procedural sky keeps its sky, the studio its
    # softboxes); 0 draws nothing, 1 makes every sample's sunless (the same scenes as 0 gives)
    sunless_fraction: float = 0.0
    # the share of samples whose environment's lower hemisphere is a Lambertian ground of a
    # random albedo in GROUND_ALBEDO lit by the upper hemisphere (learned.data.generator.
    # environments.lambertian_ground: snow, sand or concrete under the sky; env_below about the
    # albedo, where the bundled skies' grounds give 0.05-0.2); 0 draws nothing
    ground_fraction: float = 0.0
    # "" (default): sample i goes to the split SPLIT_PATTERN[i % 10]; "train" | "val" | "test":
    # every sample goes there (the protocol's datasets, learned.protocol.data: one configuration
    # per split, its own seed and environments, its summary in dataset.<split>.json)
    split: str = ""


TARGETS = ("rasteriser", "reference")
# "convex": one sphere alone (truth = the unoccluded target: a control); "sphere_on_plane": a
# sphere resting on a floor (contact shadow); "touching_spheres": two spheres touching, resting on
# a floor (occlusion and inter-reflection between them); "cluster": 3-6 spheres and meshes
# resting on a floor, touching or close to each other; "concave": one concave mesh on a floor
# (CONCAVE_SHAPES: a bowl, an open box, a room corner of two walls, a torus lying flat: self-
# occlusion and inter-reflection); "gltf": 1-3 textured glTF models (GLTF_MODELS) and spheres on a
# floor (textures through both the rasteriser and the tracer); "nested": a concave mesh with a
# sphere resting inside it (in the bowl, the box, the corner, the torus's hole); "blocks": 2-5
# boxes of any proportions (cubes, slabs, posts, thin standing panels), open pipes lying or
# standing and arches, sometimes a sphere, resting on a floor (BLOCK_SHAPES: the flat faces,
# sharp edges, thin walls and tunnels of made objects, none of which the other kinds have)
SCENE_KINDS = ("random", "convex", "sphere_on_plane", "touching_spheres", "cluster", "concave",
               "gltf", "nested", "blocks")
# the kinds of `relight train --targets reference`: a third random scenes, the rest scenes where
# visibility and inter-reflection matter
TRUTH_KINDS = ("random", "sphere_on_plane", "cluster", "random", "touching_spheres", "concave",
               "random", "cluster", "gltf")
# kinds no training sample of TRUTH_KINDS sees (held_out_config): the convex control and the
# nested scenes (a sphere inside a concave mesh)
HELD_OUT_KINDS = ("nested", "convex")
CONCAVE_SHAPES = ("bowl", "open_box", "corner", "ring")
BLOCK_SHAPES = ("box", "tube", "arch")
GLTF_MODELS = ("vase", "crate")
# the real HDRIs (assets/environments: small, very bright suns), repository-relative; the
# training truth sees sky and park, the held-out sets esplanade
ENVIRONMENTS = {name: f"assets/environments/{name}.exr" for name in ("sky", "park", "esplanade")}
TRUTH_ENV_PATHS = (ENVIRONMENTS["sky"], ENVIRONMENTS["park"])
HELD_OUT_ENV_PATHS = (ENVIRONMENTS["esplanade"],)
PROCEDURAL_ENVIRONMENTS = ("sky", "studio")


def split_of(index: int, config: GeneratorConfig | None = None) -> str:
    """The split of sample ``index``: ``config.split`` when set, else ``SPLIT_PATTERN[i % 10]``."""
    if config is not None and config.split:
        return config.split
    return SPLIT_PATTERN[index % len(SPLIT_PATTERN)]


def target_settings(samples: int) -> dict:
    """Render settings of the targets: ggx_mc + AO + SSAO + indirect when available."""

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


def unoccluded_settings(samples: int) -> dict:
    """Render settings of the unoccluded targets: :func:`target_settings` without AO, SSAO or
    indirect light."""
    kw = target_settings(samples) | {"ao": False}
    for k in ("ssao", "indirect"):
        if k in kw:
            kw[k] = False
    return kw


def env_file(path: str) -> Path:
    """An environment file of ``env_paths``: as given, or (the repository-relative
    :data:`ENVIRONMENTS`) under the repository root, so datasets do not depend on the working
    directory and ``dataset.json`` holds no absolute path."""
    p = Path(path)
    if not p.is_file() and not p.is_absolute() and (ASSET_ROOT.parent / p).is_file():
        return ASSET_ROOT.parent / p
    return p


def _env_identity(pick: str) -> str:
    return pick if pick in PROCEDURAL_ENVIRONMENTS else str(env_file(pick).resolve())


def held_out_config(config: GeneratorConfig, env_paths: tuple[str, ...] = HELD_OUT_ENV_PATHS,
                    scene_kinds: tuple[str, ...] = HELD_OUT_KINDS, seed: int | None = None,
                    **changes) -> GeneratorConfig:
    """The configuration of an evaluation dataset that no training sample of ``config`` shares an
    environment or a scene kind with: ``env_paths`` (default the esplanade HDRI) with no
    procedural environment, ``scene_kinds`` (default :data:`HELD_OUT_KINDS`), another seed
    (default ``config.seed + 1``), the rest of ``config`` (``changes`` override fields: count,
    size...). A one-line :class:`DatasetError` when an environment file or a kind is shared.

        train = GeneratorConfig(targets="reference", env_paths=TRUTH_ENV_PATHS,
                                scene_kinds=TRUTH_KINDS)
        test = held_out_config(train, count=20)   # esplanade; nested and convex scenes"""
    from dataclasses import replace

    out = replace(config, env_paths=tuple(env_paths), env_procedural=(),
                  scene_kinds=tuple(scene_kinds),
                  seed=config.seed + 1 if seed is None else int(seed), **changes)
    train_envs = {_env_identity(e) for e in (*config.env_procedural, *config.env_paths)}
    shared = [e for e in out.env_paths if _env_identity(e) in train_envs]
    if shared:
        raise DatasetError(f"held-out environment {shared[0]!r} is one the training "
                           "configuration draws from", where="env_paths")
    kinds = sorted(set(out.scene_kinds) & set(config.scene_kinds))
    if kinds:
        raise DatasetError(f"held-out scene kind {kinds[0]!r} is one the training configuration "
                           "draws from", where="scene_kinds")
    check_config(replace(out, targets="rasteriser"))
    return out


def check_config(config: GeneratorConfig, tracer=None) -> None:
    """One-line :class:`DatasetError` for a configuration that cannot be generated (before any
    sample is written). ``targets = "reference"`` needs ``tracer``: ``learned`` does not import
    ``relight``, so the caller hands the path tracer in (``relight.commands.reference_tracer()``,
    which names what to install when Mitsuba or a libLLVM >= 19 is missing)."""
    if config.targets not in TARGETS:
        raise DatasetError(f"targets {config.targets!r} is not one of {', '.join(TARGETS)}",
                           where="targets")
    if not config.scene_kinds:
        raise DatasetError("scene_kinds is empty (use ('random',))", where="scene_kinds")
    for kind in config.scene_kinds:
        if kind not in SCENE_KINDS:
            raise DatasetError(f"unknown scene kind {kind!r} (known: {', '.join(SCENE_KINDS)})",
                               where="scene_kinds")
    for name in config.env_procedural:
        if name not in PROCEDURAL_ENVIRONMENTS:
            raise DatasetError(f"env_procedural {name!r} is not one of "
                               f"{', '.join(PROCEDURAL_ENVIRONMENTS)}", where="env_procedural")
    if not config.env_procedural and not config.env_paths:
        raise DatasetError("no environment to draw from: give env_paths or env_procedural",
                           where="env_paths")
    for path in config.env_paths:
        if not env_file(path).is_file():
            raise DatasetError("environment file not found", where=path)
    if config.split not in ("", "train", "val", "test"):
        raise DatasetError(f"split {config.split!r} is not one of train, val, test (or '' for "
                           "the fixed pattern)", where="split")
    if not 0.0 <= config.degrade <= 1.0:
        raise DatasetError(f"degrade {config.degrade} is not in [0, 1]", where="degrade")
    if not 0.0 <= config.sunless_fraction <= 1.0:
        raise DatasetError(f"sunless_fraction {config.sunless_fraction} is not in [0, 1]",
                           where="sunless_fraction")
    if not 0.0 <= config.ground_fraction <= 1.0:
        raise DatasetError(f"ground_fraction {config.ground_fraction} is not in [0, 1]",
                           where="ground_fraction")
    if config.targets == "reference":
        if config.gbuffer_fraction > 0:
            raise DatasetError("image G-buffers have no geometry to path-trace: use "
                               "gbuffer_fraction = 0 with targets = 'reference'",
                               where="gbuffer_fraction")
        if config.reference_spp < 2 or config.reference_depth < 2:
            raise DatasetError("reference_spp and reference_depth must be at least 2 (the "
                               "standard error needs 2 samples; depth 2 = direct light)",
                               where="reference_spp")
        if tracer is None:
            raise DatasetError("targets = 'reference' needs a path tracer: generate(..., "
                               "tracer=relight.commands.reference_tracer()) or relight train "
                               "--targets reference", where="targets")
