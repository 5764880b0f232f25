"""The protocol's dataset: train / val / test split by scene seed AND by environment.

One folder, three generator configurations (:func:`protocol_configs`), one per split, each with
its own seed (so no scene is shared) and its own environments (so no test environment is seen in
train or val, and no val environment in train)::

    train  seed S      TRUTH_KINDS under the procedural sky and studio and the HDRI sky
    val    seed S + 1  TRUTH_KINDS under the HDRI esplanade alone
    test   seed S + 2  TRUTH_KINDS under the HDRI park alone

Why esplanade is val and park test: every design choice made before this protocol existed (the
student's design, its gain penalty and base) was compared on esplanade samples (the
``heldout-env`` and ``heldout-kinds`` presets): those choices read what is here the validation
environment. Park informed no choice; it was among the shipped student's training environments,
so the shipped student's test row is not held out (the protocol's own students never see park).

Targets are path-traced (``targets = "reference"``, the multiple-scattering BSDF of
``relight reference``), as in the presets. ``protocol.json`` at the root records the three
configurations; :func:`dataset_hash` is a sha256 over every sample's files, recorded beside
every score and in the metadata of weights trained on it.
"""
from __future__ import annotations

import hashlib
import json
from dataclasses import asdict, replace
from pathlib import Path

from ..data.generator import (ENVIRONMENTS, TRUTH_KINDS, GeneratorConfig, _env_identity,
                              check_config, generate)
from ..data.reader import SPLITS, DatasetError, list_samples

PROTOCOL_FILE = "protocol.json"
# split -> (procedural environments, environment files, seed offset)
SPLIT_ENVIRONMENTS = {
    "train": (("sky", "sky", "studio"), (ENVIRONMENTS["sky"],), 0),
    "val": ((), (ENVIRONMENTS["esplanade"],), 1),
    "test": ((), (ENVIRONMENTS["park"],), 2),
}
# the sizes of `relight data OUT --protocol` when none is given (the run in
# docs/measurements/students.md)
DEFAULT_COUNTS = {"train": 120, "val": 32, "test": 48}


def protocol_configs(counts: dict | None = None, size: int = 64, reference_spp: int = 256,
                     seed: int = 100, targets: str = "reference") -> dict[str, GeneratorConfig]:
    """split -> its :class:`GeneratorConfig` (``counts``: samples per split, default
    :data:`DEFAULT_COUNTS`; ``targets`` "rasteriser" for tests without the path tracer). A
    one-line :class:`DatasetError` if two splits could share an environment."""
    counts = DEFAULT_COUNTS | (counts or {})
    out = {}
    for split, (procedural, files, offset) in SPLIT_ENVIRONMENTS.items():
        out[split] = GeneratorConfig(
            count=int(counts[split]), size=int(size), samples=256, seed=int(seed) + offset,
            gbuffer_fraction=0.0, targets=targets, reference_spp=int(reference_spp),
            scene_kinds=TRUTH_KINDS, env_paths=files, env_procedural=procedural, split=split)
    check_disjoint(out)
    return out


def _environments(config: GeneratorConfig) -> set[str]:
    return {_env_identity(e) for e in (*config.env_procedural, *config.env_paths)}


def check_disjoint(configs: dict[str, GeneratorConfig]) -> None:
    """A one-line :class:`DatasetError` when two splits share a seed or an environment."""
    names = list(configs)
    for i, a in enumerate(names):
        for b in names[i + 1:]:
            if configs[a].seed == configs[b].seed:
                raise DatasetError(f"splits {a} and {b} share the seed {configs[a].seed}",
                                   where=PROTOCOL_FILE)
            shared = _environments(configs[a]) & _environments(configs[b])
            if shared:
                raise DatasetError(f"splits {a} and {b} share the environment "
                                   f"{sorted(shared)[0]!r}", where=PROTOCOL_FILE)


def generate_protocol(root, configs: dict[str, GeneratorConfig], tracer=None,
                      progress: bool = True, renderer=None) -> dict:
    """Generate (or complete: finished samples are kept) the three splits under ``root`` and
    write ``protocol.json``; an existing protocol of other configurations is a one-line
    :class:`DatasetError` (nothing overwritten)."""
    root = Path(root)
    root.mkdir(parents=True, exist_ok=True)
    check_disjoint(configs)
    record = {"format": "relight-protocol/1",
              "splits": {s: asdict(c) for s, c in configs.items()}}
    path = root / PROTOCOL_FILE
    if path.is_file():
        old = json.loads(path.read_text())
        if json.loads(json.dumps(record)) != {k: v for k, v in old.items() if k != "hash"}:
            raise DatasetError("was generated as another protocol; use a new folder "
                               "(nothing was overwritten)", where=path)
    path.write_text(json.dumps(record, indent=1))
    out = {}
    for split, config in configs.items():
        check_config(config, tracer)
        out[split] = generate(root, config, progress=progress, tracer=tracer,
                              renderer=renderer)
    record["hash"] = dataset_hash(root)
    path.write_text(json.dumps(record, indent=1))
    return out


def load_protocol(root) -> dict:
    """``protocol.json`` of a protocol dataset (a one-line :class:`DatasetError` for a folder
    that is not one)."""
    path = Path(root) / PROTOCOL_FILE
    if not path.is_file():
        raise DatasetError("not a protocol dataset (no protocol.json: make one with relight data "
                           "OUT --protocol)", where=root)
    try:
        return json.loads(path.read_text())
    except ValueError as exc:
        raise DatasetError(f"not valid JSON ({exc})", where=path) from None


def dataset_hash(root, splits=SPLITS) -> str:
    """sha256 over the names and bytes of every file of every sample of ``splits`` (sorted), so
    any changed, added or removed sample changes it."""
    h = hashlib.sha256()
    root = Path(root)
    for split in splits:
        if not (root / split).is_dir():
            continue
        for folder in list_samples(root, split):
            for f in sorted(p for p in folder.rglob("*") if p.is_file()):
                h.update(str(f.relative_to(root)).encode())
                h.update(f.read_bytes())
    return h.hexdigest()


def with_changes(configs: dict[str, GeneratorConfig], **changes) -> dict[str, GeneratorConfig]:
    """``configs`` with ``changes`` on every split (e.g. ``targets="rasteriser"``)."""
    return {s: replace(c, **changes) for s, c in configs.items()}
