"""Datasets in the FFHQ256-PBR layout: :mod:`.reader` (load samples and splits) and
:mod:`.generator` (synthetic samples rendered by the workbench itself)."""
from .reader import DatasetError, Sample, list_samples, load_sample

__all__ = ["DatasetError", "Sample", "list_samples", "load_sample"]
