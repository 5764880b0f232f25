"""Depth order of splats for back-to-front compositing (the CPU path; the GPU path is the
bitonic sort in ``shaders/passes/splat_sort.comp``). Both order by decreasing view depth and break
ties by index, so they agree exactly on distinct depths."""
from __future__ import annotations

import numpy as np


def view_depths(means: np.ndarray, view: np.ndarray) -> np.ndarray:
    """``[N]`` float32 positive view-space depth -z_vs of ``means [N, 3]`` under ``view [4, 4]``."""
    row = np.asarray(view, np.float32)[2]
    return -(np.asarray(means, np.float32) @ row[:3] + row[3])


def depth_order(means: np.ndarray, view: np.ndarray) -> np.ndarray:
    """``[N]`` uint32 indices, farthest first (stable: equal depths keep index order)."""
    return np.argsort(-view_depths(means, view), kind="stable").astype(np.uint32)
