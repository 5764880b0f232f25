"""Pass-level parity checks: each renders with GL, runs the torch twin of the whole pass on the same
inputs and returns :class:`~learned.parity.results.ParityResult` s. Each module's ``checks()``
lists its checks; :mod:`learned.parity.registry` names the modules."""
