"""Datasets in the FFHQ256-PBR layout: :mod:`.reader` (load samples and splits),
:mod:`.generator` (synthetic samples rendered by the workbench itself) and :mod:`.scene` (a
sample as a scene the viewer draws: from its image-space stack, from its meshes, or from those
tiled with splats of their true materials, :mod:`.splat_tiling`)."""
from .reader import DatasetError, Sample, list_samples, load_sample

__all__ = ["DatasetError", "Sample", "list_samples", "load_sample"]
