"""What the gallery shows: the columns (:data:`CASES`), the lights (:data:`ENVIRONMENTS`), the
fidelity scenes of ``spheres.png`` (:data:`SPHERE_SCENES`), the error colour map's top
(:data:`ERROR_MAX`) and the options of a run (:class:`GalleryOptions`)."""
from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

from assets import ASSET_ROOT

# the neural shadow estimator trained on mesh frames (assets/weights/shadow_net_mesh.json)
SHADOW_NET_MESH = ASSET_ROOT / "weights" / "shadow_net_mesh.safetensors"
ERROR_MAX = 0.5  # relative error at the top of the error colour map
DEFAULT_OUT = "assets/docs/gallery"
DEFAULT_CACHE = "out/gallery-cache"


@dataclass(frozen=True)
class Case:
    """One column of the gallery: a label and the ``[render]`` settings it changes."""

    label: str
    render: dict = field(default_factory=dict)
    hero: bool = False  # shown in the README picture


CASES: tuple[Case, ...] = (
    Case("unlit", {"model": "unlit"}),
    Case("blinn_phong", {"model": "blinn_phong"}, hero=True),
    Case("ggx_split_sum", {"model": "ggx_split_sum"}, hero=True),
    Case("ggx_split_sum + SSAO + indirect",
         {"model": "ggx_split_sum", "ssao": True, "indirect": True}),
    Case("ggx_split_sum + SSAO + indirect, no rays",
         {"model": "ggx_split_sum", "ssao": True, "indirect": True, "raytrace": False}),
    Case("ggx_split_sum + SSAO + indirect + shadow estimator",
         {"model": "ggx_split_sum", "ssao": True, "indirect": True, "raytrace": False,
          "shadow_net": str(SHADOW_NET_MESH)}),
    Case("ggx_mc 256 spp", {"model": "ggx_mc", "samples": 256}, hero=True),
    Case("neural", {"model": "neural"}, hero=True),
    Case("neural_teacher 128 spp", {"model": "neural_teacher", "samples": 128}),
)

# (name, file under assets/environments, rotation_deg): each HDRI turned so that its sun lights
# the side of the asset the camera sees
ENVIRONMENTS: tuple[tuple[str, str, float], ...] = (
    ("park", "park.exr", 336.0),
    ("sky", "sky.exr", 334.0),
    ("esplanade", "esplanade.exr", 0.0),
)

# fidelity scenes shown in spheres.png (all of assets/scenes/reference are scored in the table)
SPHERE_SCENES = ("park_diffuse", "park_conductor_r005", "park_conductor_r03",
                 "sky_conductor_r08", "esplanade_conductor_r03", "park_sphere_on_plane")


@dataclass(frozen=True)
class GalleryOptions:
    out: Path = Path(DEFAULT_OUT)
    cache: Path = Path(DEFAULT_CACHE)
    size: tuple[int, int] | None = None  # None: the gallery scene's own
    spp: int = 512                       # path-traced samples per pixel of the asset's truth
    quick: bool = False                  # 64 spp, one environment (a smoke run)
    spheres: bool = True                 # also the fidelity-sphere panel
    progress: bool = True
