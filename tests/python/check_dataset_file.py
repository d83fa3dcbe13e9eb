#!/usr/bin/env python3
"""Reads a glovepose dataset file the way the `safetensors` library does (json + numpy, no glovepose
code) and checks the dtypes, shapes and values written by tests/test_dataset.cpp (make_dataset(12)).

Run by the C++ test "dataset: a dataset file parses with plain json + numpy": python3 check_dataset_file.py FILE
Exit code 0 when every check passes.
"""

from __future__ import annotations

import json
import struct
import sys

import numpy as np

NUMPY = {"F64": "<f8", "F32": "<f4", "F16": "<f2", "I64": "<i8", "I32": "<i4", "U8": "u1"}


def load(path: str):
    with open(path, "rb") as f:
        data = f.read()
    (n,) = struct.unpack("<Q", data[:8])
    assert (8 + n) % 8 == 0, "data buffer not 8-byte aligned"
    header = json.loads(data[8 : 8 + n].decode("utf-8"))
    meta = header.pop("__metadata__", {})
    buffer = data[8 + n :]
    tensors, covered = {}, 0
    for name, entry in sorted(header.items(), key=lambda kv: kv[1]["data_offsets"][0]):
        begin, end = entry["data_offsets"]
        assert begin == covered, f"{name}: gap or overlap at data byte {begin}"
        covered = end
        array = np.frombuffer(buffer[begin:end], dtype=NUMPY[entry["dtype"]])
        tensors[name] = (entry["dtype"], array.reshape(entry["shape"]))
    assert covered == len(buffer), "trailing data bytes"
    return meta, tensors


def main() -> int:
    meta, t = load(sys.argv[1])
    assert meta["format"] == "glovepose-dataset" and meta["version"] == "1", meta
    assert meta["glove_layout"] == "test-5" and float(meta["frame_rate"]) == 59.94, meta
    n = 12
    expected = {
        "cells": ("F32", (n, 5)),
        "raw_rows": ("F32", (n, 7)),
        "angles": ("F32", (n, 25)),
        "true_angles": ("F32", (n, 25)),
        "timestamps": ("F64", (n,)),
        "subject": ("I32", (n,)),
        "session": ("I32", (n,)),
        "glove": ("I32", (n,)),
        "donning": ("I32", (n,)),
        "kind": ("U8", (n,)),
        "outlier": ("U8", (n,)),
    }
    assert set(t) == set(expected), sorted(t)
    for name, (dtype, shape) in expected.items():
        assert t[name][0] == dtype and t[name][1].shape == shape, (name, t[name][0], t[name][1].shape)
    i = np.arange(n)
    s = i // 3
    assert np.array_equal(t["timestamps"][1], 1e-3 + i / 59.94)
    assert np.array_equal(t["subject"][1], s // 2)
    assert np.array_equal(t["session"][1], s % 2)
    assert np.array_equal(t["glove"][1], s % 2)
    assert np.array_equal(t["donning"][1], s % 2)
    assert np.array_equal(t["kind"][1], (i % 3 == 0).astype(np.uint8))
    assert np.array_equal(t["outlier"][1], (i % 4 == 1).astype(np.uint8))
    dropped = (i[:, None] + np.arange(7)[None, :]) % 5 == 0
    raw = t["raw_rows"][1]
    assert np.array_equal(np.isnan(raw), dropped), "NaN (dropped rows) not where written"
    assert np.all(np.abs(raw[~dropped] - 100.0) <= 1.0)
    cells = t["cells"][1]
    c = np.arange(5)[None, :]
    assert np.all(np.abs(cells - 20.0 * c) <= 2.0 ** (7 * c - 14) * 1.001 + 1e-3)
    assert np.all(np.abs(t["angles"][1]) <= 1.5)
    assert np.all(np.abs(t["true_angles"][1]) <= 1.5) and not np.array_equal(t["true_angles"][1], t["angles"][1])
    print("dataset file OK:", ", ".join(f"{k} {v[0]} {list(v[1].shape)}" for k, v in sorted(t.items())))
    return 0


if __name__ == "__main__":
    sys.exit(main())
