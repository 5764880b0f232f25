"""The tiny synthetic dataset the data, training and evaluation tests share (the session fixture
``dataset`` in tests/learned/conftest.py generates it once)."""
from learned.data.generator import GeneratorConfig

TINY = GeneratorConfig(count=10, size=16, samples=4, seed=3, env_width=32)
