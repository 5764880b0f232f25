"""The ``relight`` sub-commands, one function each (``cmd_<name>(args) -> exit code``) in a module
of the command's name (``relight render``: :mod:`.render`, ..., ``relight data``: :mod:`.data`);
what several share is in :mod:`.common` (opening a scene file or asset files: :mod:`.scene`,
also ``relight scene``), the options' argparse types in :mod:`.argtypes`. The
parser that maps the command line onto them is :mod:`relight.cli`. Torch-side commands import
:mod:`learned` when they run, so ``relight render`` and ``relight view`` work without torch.
Every name below is importable from ``relight.commands`` itself."""
from __future__ import annotations

from .argtypes import _fraction, _hidden, _nonnegative_float, _positive_int, _seeds
from .bench import cmd_bench
from .common import DEMO_SCENE, _context_options, _demo_path, _learned, _parse_size
from .data import _data_config, cmd_data
from .decompose import cmd_decompose
from .eval import cmd_eval
from .info import cmd_info
from .parity import cmd_parity
from .reference import cmd_reference, reference_tracer
from .render import cmd_render
from .scene import cmd_scene
from .train import TRAIN_OVERRIDES, _truth_config, _truth_data, cmd_train
from .view import cmd_view

__all__ = [
    "DEMO_SCENE", "TRAIN_OVERRIDES", "cmd_bench", "cmd_data", "cmd_decompose", "cmd_eval",
    "cmd_info", "cmd_parity", "cmd_reference", "cmd_render", "cmd_scene", "cmd_train",
    "cmd_view", "reference_tracer",
    # private, for relight.cli and the tests
    "_context_options", "_data_config", "_demo_path", "_hidden", "_learned",
    "_fraction", "_nonnegative_float", "_parse_size", "_positive_int", "_seeds", "_truth_config",
    "_truth_data",
]
