"""GLSL sources, shipped as package data.

``lib/``    pure functions (BRDF terms, IBL lookups, colour, sampling): no uniforms, no ``main``.
``passes/`` entry points (G-buffer fill, lighting, tone mapping, precomputation).

Every function in ``lib/`` has a torch twin of the same name in :mod:`learned.twins` and a case in
:mod:`learned.parity`; ``tests/shaders/test_parity.py`` compares them.
"""
from pathlib import Path

SHADER_ROOT = Path(__file__).resolve().parent
