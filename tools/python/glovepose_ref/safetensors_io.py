"""Reader and writer of the glovepose weight-file container (see weights_format.md).

The container is safetensors-compatible:

    bytes 0..7      N, the header length, unsigned 64-bit little-endian
    bytes 8..8+N-1  UTF-8 JSON header, possibly padded at the end with spaces
    bytes 8+N..     data buffer: raw little-endian row-major tensors

The header maps each tensor name to {"dtype", "shape", "data_offsets": [begin, end]} (offsets relative
to the data buffer); the optional key "__metadata__" maps strings to strings.

This module does not use the `safetensors` package. The writer emits tensors sorted by name,
contiguous, and pads the header with spaces so the data buffer starts at a multiple of 8 bytes.
The reader enforces the container rules of weights_format.md (dtype, shapes, offsets, no overlap,
no gap); the rules about tensor names and finiteness belong to the model loader (export.py).
"""

from __future__ import annotations

import json
import struct
from pathlib import Path
from typing import Dict, Mapping, Tuple, Union

import numpy as np
import torch

from .whole_file import write_whole

PathLike = Union[str, Path]

#: dtype name -> (torch dtype, little-endian numpy dtype of the raw bytes, bytes per element).
#: BF16 has no numpy dtype: its bytes are read as little-endian int16 and reinterpreted by torch.
#: The set is the container's (weights_format.md): F64, F32, F16, BF16, I64, I32, U8. Model files
#: use only the float types F32/F16/BF16; F64 holds reference values (grad fixtures, timestamps),
#: the integer types dataset columns.
DTYPES: Dict[str, Tuple[torch.dtype, str, int]] = {
    "F64": (torch.float64, "<f8", 8),
    "F32": (torch.float32, "<f4", 4),
    "F16": (torch.float16, "<f2", 2),
    "BF16": (torch.bfloat16, "<i2", 2),
    "I64": (torch.int64, "<i8", 8),  # datasets only; glovepose refuses it in model files
    "I32": (torch.int32, "<i4", 4),
    "U8": (torch.uint8, "<u1", 1),
}

_TORCH_TO_NAME: Dict[torch.dtype, str] = {v[0]: k for k, v in DTYPES.items()}

METADATA_KEY = "__metadata__"


class FormatError(ValueError):
    """A file that breaks the container rules; the message names the tensor or byte offset."""


def dtype_name(dtype: torch.dtype) -> str:
    """The container's name of a torch dtype (a key of DTYPES); raises for others."""
    try:
        return _TORCH_TO_NAME[dtype]
    except KeyError:
        raise FormatError(f"dtype {dtype} is not supported, expected one of {sorted(_TORCH_TO_NAME.values())}")


def _tensor_bytes(t: torch.Tensor) -> bytes:
    """Raw little-endian row-major bytes of a CPU tensor."""
    t = t.detach().to("cpu").contiguous()
    name = dtype_name(t.dtype)
    _, np_dtype, _ = DTYPES[name]
    if t.dtype == torch.bfloat16:
        arr = t.view(torch.int16).numpy()
    else:
        arr = t.numpy()
    return arr.astype(np_dtype, copy=False).tobytes(order="C")


def serialize(tensors: Mapping[str, torch.Tensor], metadata: Mapping[str, str] | None = None) -> bytes:
    """The file content for `tensors` (name -> tensor) and string->string `metadata`."""
    header: Dict[str, object] = {}
    if metadata:
        for k, v in metadata.items():
            if not isinstance(k, str) or not isinstance(v, str):
                raise FormatError(f"metadata must map strings to strings, got {k!r}: {v!r}")
        header[METADATA_KEY] = dict(metadata)
    chunks = []
    offset = 0
    for name in sorted(tensors):
        if name == METADATA_KEY:
            raise FormatError(f"a tensor cannot be named {METADATA_KEY!r}")
        t = tensors[name]
        raw = _tensor_bytes(t)
        header[name] = {
            "dtype": dtype_name(t.dtype),
            "shape": [int(d) for d in t.shape],
            "data_offsets": [offset, offset + len(raw)],
        }
        chunks.append(raw)
        offset += len(raw)
    text = json.dumps(header, separators=(",", ":"), ensure_ascii=False).encode("utf-8")
    text += b" " * ((-len(text)) % 8)  # data buffer starts at 8 + N, a multiple of 8
    return struct.pack("<Q", len(text)) + text + b"".join(chunks)


def save(path: PathLike, tensors: Mapping[str, torch.Tensor], metadata: Mapping[str, str] | None = None) -> None:
    """Writes `tensors` and `metadata` to `path` (tensors sorted by name, header 8-byte padded),
    whole or not at all."""
    write_whole(path, serialize(tensors, metadata))


def deserialize(data: bytes, source: str = "<bytes>") -> Tuple[Dict[str, torch.Tensor], Dict[str, str]]:
    """Parses a whole file's content; returns (tensors, metadata). Raises FormatError on any rule break."""
    if len(data) < 8:
        raise FormatError(f"{source}: file has {len(data)} bytes, expected at least 8 for the header length")
    (n,) = struct.unpack_from("<Q", data, 0)
    if n < 2:
        raise FormatError(f"{source}: header length at byte 0 is {n}, expected at least 2")
    if 8 + n > len(data):
        raise FormatError(f"{source}: header length at byte 0 is {n}, but the file has only {len(data) - 8} bytes after it")
    try:
        header = json.loads(data[8 : 8 + n].decode("utf-8"))
    except (UnicodeDecodeError, json.JSONDecodeError) as e:
        raise FormatError(f"{source}: header (bytes 8..{8 + n}) is not valid UTF-8 JSON: {e}")
    if not isinstance(header, dict):
        raise FormatError(f"{source}: header is a JSON {type(header).__name__}, expected an object")
    buf = memoryview(data)[8 + n :]

    metadata: Dict[str, str] = {}
    raw_meta = header.pop(METADATA_KEY, None)
    if raw_meta is not None:
        if not isinstance(raw_meta, dict) or not all(isinstance(k, str) and isinstance(v, str) for k, v in raw_meta.items()):
            raise FormatError(f"{source}: {METADATA_KEY} must map strings to strings")
        metadata = dict(raw_meta)

    spans = []
    tensors: Dict[str, torch.Tensor] = {}
    for name, info in header.items():
        if not isinstance(info, dict):
            raise FormatError(f"{source}: tensor '{name}': entry is not an object")
        dt = info.get("dtype")
        if dt not in DTYPES:
            raise FormatError(f"{source}: tensor '{name}': dtype {dt!r}, expected one of {sorted(DTYPES)}")
        shape = info.get("shape")
        if not isinstance(shape, list) or not all(isinstance(d, int) and not isinstance(d, bool) and d >= 0 for d in shape):
            raise FormatError(f"{source}: tensor '{name}': shape {shape!r}, expected a list of non-negative integers")
        offs = info.get("data_offsets")
        if (
            not isinstance(offs, list)
            or len(offs) != 2
            or not all(isinstance(o, int) and not isinstance(o, bool) for o in offs)
            or not (0 <= offs[0] <= offs[1] <= len(buf))
        ):
            raise FormatError(
                f"{source}: tensor '{name}': data_offsets {offs!r}, expected [begin, end] with 0 <= begin <= end <= {len(buf)}"
            )
        torch_dtype, np_dtype, size = DTYPES[dt]
        count = int(np.prod(shape, dtype=np.int64)) if shape else 1
        if offs[1] - offs[0] != count * size:
            raise FormatError(
                f"{source}: tensor '{name}': {offs[1] - offs[0]} bytes, expected {count * size} for {dt} {shape}"
            )
        arr = np.frombuffer(buf[offs[0] : offs[1]], dtype=np_dtype).astype(np_dtype[1:], copy=True)
        t = torch.from_numpy(arr)
        if torch_dtype == torch.bfloat16:
            t = t.view(torch.bfloat16)
        tensors[name] = t.reshape(shape)
        spans.append((offs[0], offs[1], name))

    # Tensors must tile the data buffer: no overlap, no gap (safetensors' own rule).
    pos = 0
    for begin, end, name in sorted(spans):
        if begin != pos:
            what = "overlaps the previous tensor" if begin < pos else f"leaves a gap at data byte {pos}"
            raise FormatError(f"{source}: tensor '{name}' at data byte {begin} {what}")
        pos = end
    if pos != len(buf):
        raise FormatError(f"{source}: data buffer has {len(buf)} bytes but the tensors cover only {pos}")
    return tensors, metadata


def load(path: PathLike) -> Tuple[Dict[str, torch.Tensor], Dict[str, str]]:
    """Reads `path`; returns (tensors, metadata), tensors as CPU torch tensors of the stored dtype."""
    return deserialize(Path(path).read_bytes(), str(path))
