"""Torch twins of the GLSL library and passes.

One module per GLSL file: ``shaders/lib/brdf.glsl`` <-> ``learned/twins/brdf.py``. A twin has the same
snake_case name as its GLSL function, takes tensors whose trailing dimension is the GLSL vector size
(scalars are ``[...]``, ``vec3`` is ``[..., 3]``), and its docstring names the GLSL function it
mirrors. Twins of whole passes are named after their pass files (``shade.shade`` for the
lighting passes, ``ibl.prefilter_environment`` ...). Twins import torch and each other, nothing from
``viewer``: the GL side of the comparison lives in :mod:`learned.parity`.
"""
import importlib
import pkgutil


def twin_modules():
    """All twin modules, imported."""
    return [importlib.import_module(f"{__name__}.{m.name}")
            for m in pkgutil.iter_modules(__path__) if not m.name.startswith("_")]


def find_twin(name: str):
    """The torch function named ``name`` in any twin module, or ``None``."""
    for mod in twin_modules():
        fn = getattr(mod, name, None)
        if callable(fn):
            return fn
    return None
