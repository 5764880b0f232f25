"""Synthetic datasets in the FFHQ256-PBR layout, rendered by the workbench.

    relight-style use:  generate("data/quick", GeneratorConfig(count=24, size=64), progress=True)

Every sample is a random scene seen from a camera at the origin looking down -Z (so camera space is
world space, as the layout wants): 1-3 spheres and meshes (torus, box, capsule made with trimesh)
with random materials, usually a floor plane, under a procedural sky (random sun) or studio, or
one of ``env_paths``, at a random intensity and rotation (baked into the written ``env.exr``).
The target ``rgb.exr`` is the Monte-Carlo reference ``ggx_mc`` (``samples`` per pixel, MIS) with
the G-buffer AO, SSAO and one-bounce indirect light when the renderer has them (see
:func:`target_settings`) - so the shadow stage has occlusion to learn; otherwise ``ggx_split_sum``.
``rgb_unoccluded.exr`` is the same render without any occlusion (no AO, SSAO or indirect light:
for convex objects the exact single-bounce integral): the unshadowed image I_unshadow of thesis
eq. 4.3, the teacher's target in phase 1 (issue 14: trained on ``rgb``, the teacher learned the
training set's mean occlusion as part of the BRDF, and every distilled student inherited it).

Image G-buffers as geometry: a ``gbuffer_fraction`` of the samples (drawn per sample from its own
stream ``default_rng([seed, i, 1])``, so datasets made without them are unchanged) takes its
geometry from an image-space G-buffer instead: one of ``gbuffers`` (FFHQ256-PBR folders or
12-channel ShadingFusion stack EXRs, resampled to ``size`` by nearest neighbour) or, when none is
given, the G-buffer of a freshly rendered random scene. Its materials are perturbed per pixel
(:func:`perturb_materials`: smooth random fields on albedo, roughness, metallic, specular and AO -
spatially varying materials that the primitives cannot produce), it is written as an FFHQ256-PBR
folder and rendered as a ``gbuffer`` object with the same target settings.

Targets from truth (issue 14): with ``targets = "reference"`` the target ``rgb.exr`` is
path-traced by ``relight reference`` (Mitsuba 3, our BSDF, visibility and inter-reflection;
pixel-centre rays, so pixels align with the G-buffer; ``reference_depth``, ``reference_spp``),
with its per-pixel standard error in ``rgb_stderr.exr``; the G-buffer inputs and
``rgb_unoccluded.exr`` come from one rasteriser render as before, and ``meta.json``'s ``target``
records the source (``rasteriser`` | ``reference``, with spp, depth, seed, backend, seconds).
Material AO is set to 1 there (the path tracer computes visibility itself). ``learned`` does not
import ``relight``: the caller passes the tracer (``relight.commands.reference_tracer()``).
``scene_kinds`` adds scenes where visibility matters (:data:`SCENE_KINDS`: a sphere resting on a
floor, two touching spheres on a floor, clusters of 3-6 spheres and meshes touching or close to
each other, concave meshes (a bowl, an open box, a room corner of two walls, a torus lying flat),
textured glTF models, a sphere nested inside a concave mesh, and a lone sphere as the convex
control), sample i of kind ``scene_kinds[i % len]``; the default ``("random",)`` leaves datasets
unchanged. Every object of these kinds rests on the floor: its lowest point, after its transform,
on the plane. The concave shapes (OBJ: double-sided, made of closed parts) and the glTF models
(``.glb``, base-colour and metallic-roughness textures, double-sided) are written once into the
dataset's ``_meshes`` cache; a glTF object keeps its file's material, so its textures go through
the rasteriser and the path tracer alike.

Environments: ``env_procedural`` (default sky, sky, studio) and the files ``env_paths`` (the real
HDRIs :data:`ENVIRONMENTS`, small very bright suns; repository-relative paths resolve against the
repository). :func:`held_out_config` turns a training configuration into an evaluation one that
shares no environment and no scene kind with it (default: esplanade alone, :data:`HELD_OUT_KINDS`;
the training truth of ``relight train --targets reference`` draws sky and park,
:data:`TRUTH_ENV_PATHS`, and :data:`TRUTH_KINDS`).

Degraded inputs: ``degrade`` > 0 writes G-buffer inputs that are wrong the way inverse rendering's
estimates are (:func:`degrade_inputs`: noisy normals, shading baked into albedo, biased
roughness; drawn from the sample's stream ``default_rng([seed, i, 2])``, the recipe in
``meta.json``'s ``degrade``), while ``rgb.exr`` and ``rgb_unoccluded.exr`` stay those of the true
scene (thesis ch. 4's setting). With ``shard=True`` every torchrun rank writes the samples i with
i % WORLD_SIZE == RANK and then waits for the others' (a file-system barrier).

Deterministic for a seed (sample i draws from ``default_rng([seed, i])``; its split is fixed by i),
resumable (a finished sample is a folder; one being written is ``<name>.tmp`` and is redone), and
shows a tqdm progress bar.

One module per job (every name below is importable from ``learned.data.generator`` itself):
``config`` (:class:`GeneratorConfig`, the scene kinds and environments, target settings, the
configuration checks), ``shapes`` (the mesh files: trimesh primitives, concave shapes, glTF
models), ``scenes`` (the scene dict of each kind), ``environments`` (:func:`random_environment`),
``perturb`` (:func:`perturb_materials`, :func:`degrade_inputs`), ``gbuffers`` (image G-buffers
as geometry) and ``write`` (:func:`generate` and one sample).
"""
from .config import (
    BLOCK_SHAPES,
    CONCAVE_SHAPES,
    ENVIRONMENTS,
    FORMAT,
    GLTF_MODELS,
    HELD_OUT_ENV_PATHS,
    HELD_OUT_KINDS,
    PROCEDURAL_ENVIRONMENTS,
    SCENE_KINDS,
    SPLIT_PATTERN,
    TARGETS,
    TRUTH_ENV_PATHS,
    TRUTH_KINDS,
    GeneratorConfig,
    check_config,
    env_file,
    held_out_config,
    split_of,
    target_settings,
    unoccluded_settings,
)
from .environments import random_environment
from .perturb import degrade_inputs, perturb_materials
from .scenes import kind_scene, random_scene
from .write import generate, shard_of

# private helpers the tests reach through the package, as before the split
from .config import _env_identity  # noqa: F401
from .shapes import _mesh_files, _shape_files  # noqa: F401

__all__ = [
    "BLOCK_SHAPES", "CONCAVE_SHAPES", "ENVIRONMENTS", "FORMAT", "GLTF_MODELS", "HELD_OUT_ENV_PATHS",
    "HELD_OUT_KINDS", "PROCEDURAL_ENVIRONMENTS", "SCENE_KINDS", "SPLIT_PATTERN", "TARGETS",
    "TRUTH_ENV_PATHS", "TRUTH_KINDS", "GeneratorConfig", "check_config", "degrade_inputs",
    "env_file", "generate", "held_out_config", "kind_scene", "perturb_materials",
    "random_environment", "random_scene", "shard_of", "split_of", "target_settings",
    "unoccluded_settings",
]
