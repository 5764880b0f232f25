"""Torch side of the workbench: twins of every GLSL function (:mod:`learned.twins`), the parity
harness (:mod:`learned.parity`), and (later) datasets, the neural shader and its distillation.

Needs the ``learned`` extra (torch). The runtime viewer never imports this package.
"""
