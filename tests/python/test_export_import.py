#!/usr/bin/env python3
"""Checks of the Python reference (tools/python/glovepose_ref): container, model, export/import, fixtures.

Run: /usr/bin/python3 tests/python/test_export_import.py     (exit code 0 when every check passes;
the last line reads 'N passed, N failed'). Needs Debian's python3-torch and python3-numpy.
"""

from __future__ import annotations

import json
import struct
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "tools" / "python"))

import torch  # noqa: E402

from runner import Suite, expect_error  # noqa: E402
from glovepose_ref import UNet, count_parameters, export_model, import_model, randomize  # noqa: E402
from glovepose_ref import safetensors_io  # noqa: E402
from glovepose_ref.export import JOINT_LIMITS_MAX, JOINT_LIMITS_MIN  # noqa: E402

SUITE = Suite(prefix="glovepose_pytest_")
TMP = SUITE.tmp
test = SUITE.test


@test
def test_shapes_and_counts() -> None:
    m = UNet(64)
    c = count_parameters(m)
    assert c["conv_weights"] == 5_306_624, c
    assert c["learnable"] == 5_310_721, c
    assert c["stored"] == 5_313_409, c
    sd = m.state_dict()
    assert list(sd["dec1.weight"].shape) == [512, 256, 4, 4]
    assert list(sd["dec2.weight"].shape) == [512, 128, 3, 3]
    assert list(sd["out.weight"].shape) == [1, 128, 5, 5]
    assert list(sd["dbn3.running_var"].shape) == [64]
    # Spatial sizes of every stage.
    m = UNet(4).eval()
    x = torch.zeros(3, 2, 5, 5)
    sizes = {}
    for name in ("enc1", "enc2", "enc3", "enc4", "dec1", "dec2", "dec3", "out"):
        getattr(m, name).register_forward_hook(lambda mod, i, o, n=name: sizes.__setitem__(n, tuple(o.shape[1:])))
    with torch.no_grad():
        y = m(x)
    assert tuple(y.shape) == (3, 1, 5, 5)
    assert sizes == {
        "enc1": (4, 5, 5), "enc2": (8, 3, 3), "enc3": (16, 2, 2), "enc4": (32, 1, 1),
        "dec1": (16, 2, 2), "dec2": (8, 3, 3), "dec3": (4, 5, 5), "out": (1, 5, 5),
    }, sizes


@test
def test_randomize_deterministic() -> None:
    a = randomize(UNet(8), 7).state_dict()
    b = randomize(UNet(8), 7).state_dict()
    c = randomize(UNet(8), 8).state_dict()
    assert all(torch.equal(a[k], b[k]) for k in a)
    assert not torch.equal(a["enc2.weight"], c["enc2.weight"])
    sd = a
    assert float(sd["bn2.running_var"].min()) >= 0.5 and float(sd["bn2.running_var"].max()) <= 2.0
    assert float(sd["bn3.weight"].min()) >= 0.5 and float(sd["bn3.weight"].max()) <= 1.5
    assert float(sd["enc1.bias"].abs().max()) <= 0.1


@test
def test_roundtrip_f32() -> None:
    m = randomize(UNet(8), 3).eval()
    p = TMP / "m.safetensors"
    export_model(m, p, calibration_min=[0.0] * 44, calibration_max=[1.5] * 44)
    r = import_model(p)
    assert not r.training
    a, b = m.state_dict(), r.state_dict()
    assert set(a) == set(b)
    for k in a:
        if k.endswith("num_batches_tracked"):
            continue
        assert a[k].dtype == b[k].dtype and torch.equal(a[k], b[k]), k
    x = torch.rand(5, 2, 5, 5, generator=torch.Generator().manual_seed(0)) * 2.4 - 1.2
    with torch.no_grad():
        assert torch.equal(m(x), r(x))
    tensors, meta = safetensors_io.load(p)
    assert not any(k.endswith("num_batches_tracked") for k in tensors)
    assert len(tensors) == 8 * 2 + 6 * 4
    assert meta["format"] == "glovepose-model" and meta["format_version"] == "1"
    assert meta["architecture"] == "unet" and meta["width"] == "8"
    assert meta["glove"] == "glauser2019-44" and meta["bn_eps"] == "1e-05"
    assert json.loads(meta["joint_limits_min"]) == list(JOINT_LIMITS_MIN)
    assert json.loads(meta["joint_limits_max"]) == list(JOINT_LIMITS_MAX)
    assert json.loads(meta["calibration_max"]) == [1.5] * 44
    assert len(JOINT_LIMITS_MIN) == 25 and all(lo < hi for lo, hi in zip(JOINT_LIMITS_MIN, JOINT_LIMITS_MAX))


@test
def test_roundtrip_16bit() -> None:
    m = randomize(UNet(4), 5).eval()
    for dtype, tdt in (("F16", torch.float16), ("BF16", torch.bfloat16)):
        p = TMP / f"m_{dtype}.safetensors"
        export_model(m, p, dtype=dtype)
        tensors, _ = safetensors_io.load(p)
        assert all(t.dtype == tdt for t in tensors.values())
        r = import_model(p)
        for k, v in m.state_dict().items():
            if not k.endswith("num_batches_tracked"):
                assert torch.equal(r.state_dict()[k], v.to(tdt).float()), (dtype, k)


@test
def test_container_layout() -> None:
    t = {"b": torch.arange(3, dtype=torch.float32), "a": torch.ones(2, 3, dtype=torch.float16),
         "c": torch.tensor([1.5, -2.0], dtype=torch.bfloat16), "d": torch.tensor([-1, 2**40], dtype=torch.int64)}
    data = safetensors_io.serialize(t, {"k": "v"})
    (n,) = struct.unpack_from("<Q", data)
    assert n % 8 == 0, n
    header = json.loads(data[8 : 8 + n])
    assert header["__metadata__"] == {"k": "v"}
    names = [k for k in header if k != "__metadata__"]
    assert names == ["a", "b", "c", "d"]
    assert header["a"] == {"dtype": "F16", "shape": [2, 3], "data_offsets": [0, 12]}
    assert header["b"]["data_offsets"] == [12, 24]
    assert header["c"]["dtype"] == "BF16" and header["c"]["data_offsets"] == [24, 28]
    assert header["d"]["dtype"] == "I64" and header["d"]["data_offsets"] == [28, 44]
    assert len(data) == 8 + n + 44
    # Little-endian raw values.
    assert struct.unpack_from("<3f", data, 8 + n + 12) == (0.0, 1.0, 2.0)
    assert data[8 + n + 24 : 8 + n + 26] == struct.pack("<H", 0x3FC0)  # bf16 1.5
    back, meta = safetensors_io.deserialize(data)
    assert meta == {"k": "v"}
    for k in t:
        assert back[k].dtype == t[k].dtype and torch.equal(back[k], t[k]), k


@test
def test_container_errors() -> None:
    def make(header: dict, data: bytes = b"") -> bytes:
        h = json.dumps(header).encode()
        return struct.pack("<Q", len(h)) + h + data

    d = safetensors_io.deserialize
    E = safetensors_io.FormatError
    expect_error(lambda: d(b"\x01\0\0\0\0\0\0\0{"), E, "at least 2")
    expect_error(lambda: d(struct.pack("<Q", 100) + b"{}"), E, "only 2 bytes")
    expect_error(lambda: d(make([])), E, "expected an object")
    expect_error(lambda: d(make({"x": {"dtype": "C64", "shape": [1], "data_offsets": [0, 8]}}, bytes(8))), E, "'x'")
    expect_error(lambda: d(make({"x": {"dtype": "F32", "shape": [-1], "data_offsets": [0, 4]}}, bytes(4))), E, "shape")
    expect_error(lambda: d(make({"x": {"dtype": "F32", "shape": [2], "data_offsets": [0, 4]}}, bytes(4))), E, "expected 8")
    expect_error(lambda: d(make({"x": {"dtype": "F32", "shape": [1], "data_offsets": [0, 8]}}, bytes(4))), E, "data_offsets")
    expect_error(lambda: d(make({"x": {"dtype": "F32", "shape": [1], "data_offsets": [4, 8]}}, bytes(8))), E, "gap")
    expect_error(lambda: d(make({"x": {"dtype": "F32", "shape": [2], "data_offsets": [0, 8]},
                                 "y": {"dtype": "F32", "shape": [1], "data_offsets": [4, 8]}}, bytes(8))), E, "overlaps")
    expect_error(lambda: d(make({"x": {"dtype": "F32", "shape": [1], "data_offsets": [0, 4]}}, bytes(8))), E, "cover only 4")
    expect_error(lambda: d(make({"__metadata__": {"a": 1}})), E, "strings")


@test
def test_import_rejects() -> None:
    m = randomize(UNet(4), 1)
    tensors = {k: v for k, v in m.state_dict().items() if not k.endswith("num_batches_tracked")}
    from glovepose_ref.export import ModelFileError, model_metadata

    meta = model_metadata(4)
    p = TMP / "bad.safetensors"
    bad = dict(tensors)
    del bad["dbn2.running_mean"]
    safetensors_io.save(p, bad, meta)
    expect_error(lambda: import_model(p), ModelFileError, "dbn2.running_mean")
    bad = dict(tensors, extra=torch.zeros(1))
    safetensors_io.save(p, bad, meta)
    expect_error(lambda: import_model(p), ModelFileError, "extra")
    safetensors_io.save(p, tensors, dict(meta, width="5"))
    expect_error(lambda: import_model(p), ModelFileError, "shape")
    safetensors_io.save(p, tensors, dict(meta, architecture="resnet"))
    expect_error(lambda: import_model(p), ModelFileError, "architecture")
    bad = dict(tensors)
    bad["enc1.bias"] = bad["enc1.bias"].clone()
    bad["enc1.bias"][0] = float("nan")
    safetensors_io.save(p, bad, meta)
    expect_error(lambda: import_model(p), ModelFileError, "non-finite")


@test
def test_fixtures_consistent() -> None:
    model_path = ROOT / "tests" / "fixtures" / "unet_w4.safetensors"
    io_path = ROOT / "tests" / "fixtures" / "unet_w4_io.safetensors"
    m = import_model(model_path)
    assert m.width == 4
    # The fixture is exactly what make_fixtures.py writes for width 4, seed 1.
    ref = randomize(UNet(4), 1).state_dict()
    for k, v in m.state_dict().items():
        if not k.endswith("num_batches_tracked"):
            assert torch.equal(v, ref[k]), k
    io, meta = safetensors_io.load(io_path)
    x, y = io["input"], io["output"]
    assert x.dtype == torch.float32 and list(x.shape) == [16, 2, 5, 5]
    assert y.dtype == torch.float32 and list(y.shape) == [16, 1, 5, 5]
    assert float(x.abs().max()) <= 1.2
    import copy

    with torch.no_grad():
        y64 = copy.deepcopy(m).double()(x.double())
        y32 = m(x)
    # Equal up to a last-bit flip of the final F32 rounding (float64 summation order may differ).
    assert float((y64.float() - y).abs().max()) <= 2.0**-23, "float64 reference does not reproduce"
    assert float((y32 - y).abs().max()) < 1e-5
    assert float(y.std()) > 0.01, "outputs are nearly constant: the fixture would test little"


if __name__ == "__main__":
    sys.exit(SUITE.run())
