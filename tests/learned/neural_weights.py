"""Weights files for the neural-shader tests: random students exported to a temporary file
(:func:`student_file`) and files with changed metadata, a changed tensor or cut short
(:func:`tamper`)."""
import json
import struct

import torch

from learned.export import export
from learned.neural.student import Student


def student_file(tmp_path_factory, name: str, seed: int, **design):
    """A random student with ``design`` exported to a temporary weights file; its last layer is
    scaled by 3 to move the outputs away from the sigmoid's flat ends."""
    d = tmp_path_factory.mktemp(name)
    torch.manual_seed(seed)
    s = Student(hidden=(8, 12), num_freqs=1, **design)
    with torch.no_grad():
        s.layers[-1].weight.mul_(3.0)
    export(s, d / "s.safetensors")
    return d / "s.safetensors"


def tamper(src, dst, meta_change=None, tensor_change=None, truncate=None):
    data = src.read_bytes()
    n = struct.unpack("<Q", data[:8])[0]
    header = json.loads(data[8:8 + n])
    body = bytearray(data[8 + n:])
    if meta_change:
        header["__metadata__"].update(meta_change)
    if tensor_change:
        start = header[tensor_change]["data_offsets"][0]
        body[start:start + 4] = struct.pack("<f", 123.0)
    h = json.dumps(header).encode()
    h += b" " * ((8 - len(h) % 8) % 8)
    out = struct.pack("<Q", len(h)) + h + bytes(body)
    dst.write_bytes(out[:truncate] if truncate else out)
    return dst
