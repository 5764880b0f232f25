"""Loaded networks: a validated weights file (:mod:`.format`) with its generated GLSL
(:mod:`.glsl`), cached per file, and the network a lighting pass of a neural model needs."""
from __future__ import annotations

import os
import warnings
from dataclasses import dataclass, field
from pathlib import Path

from ..cache import BoundedCache, CacheStats
from .contract import STUDENT_SSAO_FEATURES
from .format import (MODEL_KINDS, STUDENT_FEATURES, NetworkFile, WeightsError, default_weights,
                     read_weights)
from .glsl import WEIGHT_STORAGES, NetworkCode, generate_glsl
from .shadow_net import load_shadow_net, reads_env_visibility


@dataclass(frozen=True)
class Network(NetworkFile):
    """A validated exported network (numpy, float32) and its generated GLSL."""

    _code: dict = field(default_factory=dict, repr=False, compare=False)  # storage -> NetworkCode

    @property
    def glsl(self) -> str:
        """The text of the virtual file ``include_name`` with weights baked as constants."""
        return self.code("const").glsl

    def code(self, storage: str = "const") -> NetworkCode:
        """The generated GLSL and weight data for ``storage`` (:data:`WEIGHT_STORAGES`; cached)."""
        if storage not in WEIGHT_STORAGES:
            raise ValueError(f"weight storage {storage!r} (known: {', '.join(WEIGHT_STORAGES)})")
        if storage not in self._code:
            self._code[storage] = generate_glsl(self, storage)
        return self._code[storage]


MAX_NETWORKS = 16  # loaded networks kept per process (least recently used forgotten)
# (resolved path, size, modification time) -> Network: a rewritten file is a new key, the old one
# ages out
_CACHE = BoundedCache("networks", max_items=MAX_NETWORKS)


def cache_stats() -> CacheStats:
    """The process-wide cache of loaded networks (:func:`load_network`)."""
    return _CACHE.stats()


def load_network(path: str | os.PathLike, kind: str | None = None) -> Network:
    """Read, validate and generate GLSL for the weights file ``path`` (cached by path, size and
    modification time). ``kind`` (``"student"``/``"teacher"``) is required to match when given.
    Every problem is a one-line :class:`WeightsError` naming the file."""
    path = Path(path)
    if not path.is_file():
        raise WeightsError("weights file not found", where=path)
    st = path.stat()
    key = (str(path.resolve()), st.st_size, st.st_mtime_ns)
    def load():
        net = read_weights(path, Network)
        net.code("const")  # generation errors belong to loading
        return net
    net = _CACHE.get_or_create(key, load)
    if kind is not None and net.kind != kind:
        raise WeightsError(f"holds a {net.kind} network, expected a {kind} "
                           f"(model {'neural' if kind == 'student' else 'neural_teacher'})",
                           where=path)
    return net


def model_network(model: str, settings) -> tuple[Network, NetworkCode] | None:
    """The network of a lighting pass of ``model`` under the render ``settings`` (its weights file
    and ``neural_storage``) and its generated code; ``None`` for classical models."""
    kind = MODEL_KINDS.get(model)
    if kind is None:
        return None
    if kind == "student":
        path = student_path(settings)
        net = load_network(path, kind)
        check_student_frame(net, settings)
    else:
        net = load_network(settings.neural.teacher_weights or default_weights(kind), kind)
    return net, net.code(settings.neural.storage)


def takes_estimator_visibility(settings) -> bool:
    """Whether the frame takes the shadow estimator's V in place of SSAO's O(x) and S(x)
    (``[render] shadow_net`` set and ``shadow_net_use = "visibility"``)."""
    return settings.neural.shadow_net is not None and \
        settings.neural.shadow_net_use == "visibility"


def student_path(settings) -> Path:
    """The student's weights: ``[render] weights``, else the shipped file for the frame: the
    student trained on frames whose O(x) is the shadow estimator's V
    (``neural_student_visibility``, ``relight train --student-visibility``) when the frame takes
    V (:func:`takes_estimator_visibility`), else the shipped student."""
    if settings.neural.weights:
        return Path(settings.neural.weights)
    return default_weights("student_visibility" if takes_estimator_visibility(settings)
                           else "student")


_WARNED: set = set()  # (file, trained on V) already warned about: check_student_frame


def check_student_frame(net: NetworkFile, settings) -> None:
    """Warn (one line naming the file) when the student was trained on the other kind of frame:
    on SSAO's O(x) and used where the frame takes the estimator's V, or the other way round
    (its training record's ``student_visibility``); its learned corrections were fitted to the
    other frame's brightness."""
    trained = bool((net.training.get("config") or {}).get("student_visibility"))
    key = (net.path, trained)
    if trained == takes_estimator_visibility(settings) or key in _WARNED:
        return
    _WARNED.add(key)  # once per file and process (model_network is asked from several passes)
    if trained:
        warnings.warn(f"{net.path}: the student was trained on frames that take the shadow "
                      f"estimator's V in place of SSAO (shadow_net_use = \"visibility\"); this "
                      f"frame does not, so its corrections are fitted to another frame's light",
                      stacklevel=3)
    else:
        warnings.warn(f"{net.path}: the student was trained on frames with SSAO's O(x); this "
                      f"frame takes the shadow estimator's V in its place (shadow_net_use), so "
                      f"its corrections are fitted to another frame's light (the shipped "
                      f"{default_weights('student_visibility').name} is trained for it)",
                      stacklevel=3)


def virtual_files(found: tuple[Network, NetworkCode] | None) -> dict[str, str]:
    """The generated include file of a :func:`model_network` result (empty for ``None``: a
    classical model)."""
    if found is None:
        return {}
    net, code = found
    return {net.include_name: code.glsl}


def reads_visibility(settings) -> bool:
    """Whether the lighting pass of ``settings.model`` reads the screen-space visibility of the
    environment's light (a student with ``vis`` features): it then needs the SSAO pass with
    ``SSAO_ENV_VIS``, whatever ``[render] ssao`` says."""
    found = model_network(settings.model, settings)
    return found is not None and found[0].kind == "student" and \
        "vis" in STUDENT_FEATURES.get(found[0].features, ())


def reads_occlusion(settings) -> bool:
    """Whether the lighting pass of ``settings.model`` is a student trained with the SSAO pass's
    occlusion O(x) in its ao input (``ssao``, ``vis`` or ``dfg-vis`` features,
    :data:`~viewer.neural.contract.STUDENT_SSAO_FEATURES`): it then needs the SSAO pass, whatever
    ``[render] ssao`` says (and S(x) only if it :func:`reads_visibility`)."""
    found = model_network(settings.model, settings)
    return found is not None and found[0].kind == "student" and \
        found[0].features in STUDENT_SSAO_FEATURES


def needs_env_visibility(settings) -> bool:
    """Whether the frame's SSAO pass writes S(x) (``SSAO_ENV_VIS``): for a student that reads it
    (:func:`reads_visibility`) or a neural shadow estimator (``[render] shadow_net``) that takes
    it as an input (its architecture's ``"env_visibility"``, true when absent)."""
    if reads_visibility(settings):
        return True
    path = settings.neural.shadow_net
    if path is None:
        return False
    return reads_env_visibility(load_shadow_net(path).architecture)


def learns_indirect(settings) -> bool:
    """Whether the lighting pass of ``settings.model`` is a student with a learned factor on the
    screen-space indirect light (architecture ``"indirect": "factor"``): it writes the factor to a
    second target, and the indirect pass (``passes/ssao.frag``, ``SSAO_INDIRECT_FACTOR``) scales
    its one-bounce light by it, whatever ``[render] indirect`` says."""
    found = model_network(settings.model, settings)
    return found is not None and found[0].kind == "student" and found[0].indirect != "none"


def shades_sun(settings) -> bool:
    """Whether the lighting pass of ``settings.model`` is a student whose split-sum base shades the
    environment's sun analytically (architecture ``"sun": true``): the renderer then compiles
    ``SUN_LIGHT`` into it and binds the IBL without the sun, exactly as for ``ggx_split_sum``,
    when the environment has one."""
    found = model_network(settings.model, settings)
    return found is not None and found[0].kind == "student" and found[0].sun


def required_settings(settings):
    """``settings`` with what the model's network needs switched on: SSAO for a student that reads
    its occlusion (and visibility) inputs from it (:func:`reads_occlusion`: it was trained on them;
    without the pass its ao input would be the material's alone and its vis input 1), the indirect pass for a student that
    learned a factor on its light (trained on direct + factor x indirect), the analytic sun for a
    student whose base shades it (``render.sun = false`` would leave its sun out); SSAO, too, for
    the neural shadow estimator (``render.shadow_net``), which reads its occlusion. Unchanged for
    every other model."""
    flat = {}
    if (reads_occlusion(settings) or settings.neural.shadow_net is not None) \
            and not settings.ssao.enabled:  # the shadow estimator reads O(x) too
        flat["ssao"] = True
    if learns_indirect(settings) and not settings.ssao.indirect:
        flat["indirect"] = True
    if shades_sun(settings) and not settings.sun:  # its base was trained with the sun's light
        flat["sun"] = True
    return settings.with_flat(**flat) if flat else settings
