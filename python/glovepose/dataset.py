"""Dataset files (weights_format.md, "Dataset files") as numpy arrays, read without the library."""
from __future__ import annotations

import json
import struct

import numpy as np

_DTYPES = {"F64": np.float64, "F32": np.float32, "F16": np.float16, "I64": np.int64, "I32": np.int32, "U8": np.uint8}


def load_dataset(path: str) -> dict:
    """The tensors of a dataset (or any safetensors) file as numpy arrays by name ("cells" (N, C),
    "angles" (N, 25) with NaN for DoFs not labelled, "true_angles" (N, 25) for simulated data, "timestamps", "subject", "session", "glove",
    "donning", "kind", "outlier", "raw_rows" when recorded), plus "metadata" (a dict of strings).
    Raises ValueError naming what is malformed."""
    with open(path, "rb") as f:
        head = f.read(8)
        if len(head) != 8:
            raise ValueError(f"{path}: shorter than the 8-byte header length")
        size = struct.unpack("<Q", head)[0]
        header_bytes = f.read(size)
        if len(header_bytes) != size:
            raise ValueError(f"{path}: header length {size} runs past the end of the file")
        try:
            header = json.loads(header_bytes)
        except ValueError as e:
            raise ValueError(f"{path}: the header is not JSON ({e})") from None
        data = f.read()
    out = {"metadata": dict(header.pop("__metadata__", {}))}
    for name, t in header.items():
        if t.get("dtype") not in _DTYPES:
            raise ValueError(f"{path}: tensor {name!r} has dtype {t.get('dtype')!r}, expected one of {sorted(_DTYPES)}")
        begin, end = t["data_offsets"]
        dtype = np.dtype(_DTYPES[t["dtype"]]).newbyteorder("<")
        count = int(np.prod(t["shape"])) if t["shape"] else 1
        if end > len(data) or end - begin != count * dtype.itemsize:
            raise ValueError(f"{path}: tensor {name!r} data [{begin}, {end}) does not fit its shape {t['shape']} or the file")
        out[name] = np.frombuffer(data[begin:end], dtype=dtype).reshape(t["shape"]).astype(_DTYPES[t["dtype"]])
    return out
