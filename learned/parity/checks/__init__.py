"""Pass-level parity checks: each renders with GL, runs the torch twin of the whole pass on the same
inputs and returns :class:`~learned.parity.results.ParityResult` s. Each module's ``checks()``
lists its checks; :mod:`learned.parity.registry` names the modules."""
from __future__ import annotations


def collector():
    """A fresh dict and the decorator that fills it, for a module's ``checks()``:
    ``@register(name, model=None)`` on ``check(programs) -> list[ParityResult]``."""
    found: dict = {}

    def register(name: str, model: str | None = None):
        def deco(fn):
            found[name] = (model, fn)
            return fn

        return deco

    return found, register
