"""What the panel's widgets offer: the fixed choices of the [render] fields and their ranges."""
from __future__ import annotations

from viewer.models import MODELS, SAMPLINGS
from viewer.scene import description as scene_module
from viewer.scene.description import BACKGROUNDS, TONEMAPS
from viewer.scene.settings import (
                             AA_MODES,
                             ENV_SHADOWS_MAX,
                             LOD_ERROR_MAX,
                             RAY_SCALE_MAX,
                             SHADOW_BUDGET_MAX,
                             SSAA_MAX,
                             SSAO_SCALE_MAX,
)

# RenderSettings fields with a fixed set of values (others get a text field)
CHOICES = {"model": lambda: tuple(MODELS), "sampling": lambda: SAMPLINGS,
           "tonemap": lambda: TONEMAPS, "background": lambda: BACKGROUNDS, "aa": lambda: AA_MODES,
           "precision": lambda: getattr(scene_module, "PRECISIONS", None),
           "mis_heuristic": lambda: getattr(scene_module, "MIS_HEURISTICS", None)}
QUICK_FIELDS = ("model", "exposure", "tonemap")  # shown at the top, not again under Shading
LIMITS = {"exposure": (-10.0, 10.0), "samples": (1, 1 << 16), "seed": (0, (1 << 31) - 1),
          # the ranges viewer.scene.checks.validate_render accepts
          "ssao_rays": (1, 1024), "ssao_steps": (1, 256), "ssao_scale": (1, SSAO_SCALE_MAX),
          "ssaa": (1, SSAA_MAX), "shadow_size": (64, 8192), "shadow_cube_size": (32, 4096),
          "env_shadows": (0, ENV_SHADOWS_MAX), "shadow_lod_error": (0.0, LOD_ERROR_MAX),
          "shadow_budget": (0.0, SHADOW_BUDGET_MAX), "raytrace_rays": (1, 64),
          "ray_frames": (1, 4096), "ray_still_frames": (1, 4096),
          "ray_scale": (1, RAY_SCALE_MAX)}
ERROR_COLOUR = (1.0, 0.45, 0.4, 1.0)
