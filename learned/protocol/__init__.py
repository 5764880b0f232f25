"""The evaluation protocol: learned components measured as a reviewer would.

Modules by job: :mod:`.data` (the dataset split by scene seed and by environment, its hash),
:mod:`.degrade` (estimated G-buffers at a level: the degradation model), :mod:`.classical`
(the classical model given the student's evidence, its variants), :mod:`.scores` (PSNR, the
paired bootstrap, the test split's ledger), :mod:`.run` (``relight eval --protocol``: students of
several seeds against the baseline chosen on val, scored on test, resumable),
:mod:`.shadow_net` (the viewer's shadow estimator against the same baseline) and
:mod:`.oracles` (white furnace, albedo scaling, linearity in the light, with bounds).
"""
