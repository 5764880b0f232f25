"""Export trained neural shaders to safetensors (format in :mod:`viewer.neural`) and load them back.

    export(student, "assets/weights/neural_student.safetensors", training={...})
    model = load_model("assets/weights/neural_student.safetensors")   # Student or Teacher (torch)

The file is written to a temporary name and renamed, so a failed export never leaves a partial
file or damages an existing one. Loading validates through :func:`viewer.neural.load_network` first,
so the torch side accepts exactly what the viewer accepts.
"""
from __future__ import annotations

import json
import os
import tempfile
from pathlib import Path

import numpy as np
import torch

from viewer.neural import (FORMAT, FORMAT_VERSION, STUDENT_FEATURES, TEACHER_INPUTS,
                           checkpoint_hash, expected_networks, load_network)

from .neural.student import Student
from .neural.teacher import Teacher


def network_tensors(model) -> dict[str, np.ndarray]:
    out = {}
    for name, layers in model.networks().items():
        for i, (w, b, _) in enumerate(layers):
            out[f"{name}.{i}.weight"] = w.detach().cpu().to(torch.float32).numpy().copy()
            out[f"{name}.{i}.bias"] = b.detach().cpu().to(torch.float32).numpy().copy()
    return out


def metadata(model, training: dict | None = None) -> dict[str, str]:
    tensors = network_tensors(model)
    cfg = model.config
    features = cfg.get("features", "base")
    output = cfg.get("output", "free6")
    arch = {"networks": expected_networks(model.kind, cfg["num_freqs"], cfg["hidden"], features,
                                          output),
            "hidden": cfg["hidden"], "num_freqs": cfg["num_freqs"],
            "inputs": list(STUDENT_FEATURES[features] if model.kind == "student"
                           else TEACHER_INPUTS)}
    if model.kind == "student":
        arch["features"] = features
        arch["output"] = output
    return {"format": FORMAT, "version": FORMAT_VERSION, "kind": model.kind,
            "architecture": json.dumps(arch),
            "encoding": json.dumps({"type": "fourier", "num_freqs": cfg["num_freqs"],
                                    "frequencies": "pi * 2^k", "order": "x, (sin, cos) per k"}),
            "checkpoint": checkpoint_hash(tensors),
            "training": json.dumps(training or {})}


def export(model, path: str | os.PathLike, training: dict | None = None) -> str:
    """Write ``model`` (Student or Teacher) to ``path``; returns the checkpoint hash."""
    from safetensors.numpy import save_file

    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    meta = metadata(model, training)
    fd, tmp = tempfile.mkstemp(prefix=path.name + ".", suffix=".tmp", dir=path.parent)
    os.close(fd)
    try:
        save_file(network_tensors(model), tmp, metadata=meta)
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise
    return meta["checkpoint"]


def load_model(path: str | os.PathLike, kind: str | None = None):
    """The torch module of an exported file (validated by the viewer's loader)."""
    net = load_network(path, kind)
    cfg = net.architecture
    if net.kind == "student":
        model = Student(hidden=tuple(cfg["hidden"]), num_freqs=cfg["num_freqs"],
                        features=net.features, output=net.output)
    else:
        model = Teacher(hidden=cfg["hidden"], num_freqs=cfg["num_freqs"])
    with torch.no_grad():
        for name, layers in model.networks().items():
            for i, (w, b, _) in enumerate(layers):
                w.copy_(torch.from_numpy(net.tensors[f"{name}.{i}.weight"]))
                b.copy_(torch.from_numpy(net.tensors[f"{name}.{i}.bias"]))
    model.checkpoint = net.checkpoint
    model.training_summary = net.training
    return model.eval()
