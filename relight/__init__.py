"""The commands: the `relight` CLI, the benchmarks and the interactive viewer application.

They sit above both libraries - :mod:`viewer` (the torch-free runtime: GL context, scene, passes,
renderer) and :mod:`learned` (torch twins, parity, datasets, training) - and may import either;
neither library imports this package.
"""
