"""Export trained neural shaders to safetensors and load them back; the file format (key names,
metadata, architecture) is :mod:`viewer.neural.format`'s, the one the viewer reads.

    export(student, "assets/weights/neural_student.safetensors", training={...})
    model = load_model("assets/weights/neural_student.safetensors")   # Student or Teacher (torch)

The file is written to a temporary name and renamed, so a failed export never leaves a partial
file or damages an existing one. Loading validates through :func:`viewer.neural.load_network` first,
so the torch side accepts exactly what the viewer accepts.
"""
from __future__ import annotations

import os
import tempfile
from pathlib import Path

import numpy as np
import torch
from safetensors.numpy import save_file

from viewer.neural import load_network
from viewer.neural.contract import architecture
from viewer.neural.format import metadata as file_metadata, tensor_name

from .neural.student import Student
from .neural.teacher import Teacher


def network_tensors(model) -> dict[str, np.ndarray]:
    """The file's tensors of ``model``: float32 numpy, keyed by :func:`tensor_name`."""
    out = {}
    for name, layers in model.networks().items():
        for i, (w, b, _) in enumerate(layers):
            out[tensor_name(name, i, "weight")] = w.detach().cpu().to(torch.float32).numpy().copy()
            out[tensor_name(name, i, "bias")] = b.detach().cpu().to(torch.float32).numpy().copy()
    return out


def metadata(model, training: dict | None = None,
             tensors: dict[str, np.ndarray] | None = None) -> dict[str, str]:
    """The file's metadata of ``model`` (``viewer.neural.format.metadata``); ``tensors``:
    :func:`network_tensors` of ``model`` when already computed."""
    cfg = model.config
    arch = architecture(model.kind, cfg["num_freqs"], cfg["hidden"], cfg.get("features"),
                        cfg.get("output"), cfg.get("occlusion"), cfg.get("indirect"),
                        bool(cfg.get("sun", False)), bool(cfg.get("multiscatter", False)),
                        bool(cfg.get("light_input", True)))
    return file_metadata(model.kind, arch,
                         network_tensors(model) if tensors is None else tensors, training)


def export(model, path: str | os.PathLike, training: dict | None = None) -> str:
    """Write ``model`` (Student or Teacher) to ``path``; returns the checkpoint hash."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tensors = network_tensors(model)
    meta = metadata(model, training, tensors)
    fd, tmp = tempfile.mkstemp(prefix=path.name + ".", suffix=".tmp", dir=path.parent)
    os.close(fd)
    try:
        save_file(tensors, tmp, metadata=meta)
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
                        features=net.features, output=net.output, occlusion=net.occlusion,
                        indirect=net.indirect, sun=net.sun, multiscatter=net.multiscatter)
    else:
        model = Teacher(hidden=cfg["hidden"], num_freqs=cfg["num_freqs"],
                        light_input=net.light_input)
    with torch.no_grad():
        for name, layers in model.networks().items():
            for i, (w, b, _) in enumerate(layers):
                w.copy_(torch.from_numpy(net.tensors[tensor_name(name, i, "weight")]))
                b.copy_(torch.from_numpy(net.tensors[tensor_name(name, i, "bias")]))
    model.checkpoint = net.checkpoint
    model.training_summary = net.training
    return model.eval()
