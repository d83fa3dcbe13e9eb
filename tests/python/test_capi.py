#!/usr/bin/env python3
"""The C ABI (libglovepose_c) from Python ctypes gives the C++ API's angles on the same input.

A short session is simulated with raw readout rows (`glovepose simulate --raw-rows --seed 41`: a
3 s calibration sequence, then 6 s of recording; the subject of tests/test_estimator.cpp). Its rows are streamed twice with the same protocol:
- here, through ctypes and the C ABI;
- by capi_cpp_reference (capi/tests/cpp_reference.cpp), through glovepose::GlovePoseEstimator,
  which prints every pose with %.17g (an exact round trip of a double).
Protocol: the paper's readout (mean of 5, a solve every 16 rows), 1-euro smoothing (60, 1, 0.5, 1)
and joint transforms on; calibration frames (kind 1) between start and finish of the on-the-fly
calibration; row r of frame f at glovepose_row_time(timestamps[f], r, R, the dataset's frame rate).

Both run the same code built with the same flags (neither uses -march=native), on the same doubles
(the dataset's float32 rows widened exactly), so the assertion is exact equality: the largest
difference over every pose's 25 angles, 25 raw angles, timestamp, oldest_age and 21 x 7 joint
floats must be 0.0, and flags, rejected counts, sequences and the rows that completed a pose must
match. Also: the struct sizes match the header, errors reach Python with their message, the
last-error string is per thread, and the poses track the simulated hand.

Run by CTest (`python_capi`) with GLOVEPOSE_C_LIBRARY, GLOVEPOSE_CPP_REFERENCE, GLOVEPOSE_CLI set
(and optionally GLOVEPOSE_C_TEST_DIR for scratch files). Last line: 'N passed, N failed'.
"""

from __future__ import annotations

import ctypes
import importlib.util
import math
import os
import subprocess
import sys
import tempfile
import threading
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "tools" / "python"))

import numpy as np  # noqa: E402

from glovepose_ref import safetensors_io  # noqa: E402

MODEL = ROOT / "models" / "glovepose_fcn512.safetensors"
DOFS, JOINTS = 25, 21
OK, SOLVED = 0, 1
ERROR_FILE_NOT_FOUND = -4


def _structs():
    """The ctypes structs of glovepose_c.h, as the Python package declares them (python/glovepose/
    _library.py, loaded by path: the package's __init__ would look for the library itself)."""
    spec = importlib.util.spec_from_file_location("glovepose_library", ROOT / "python" / "glovepose" / "_library.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module.EstimatorConfig, module.Pose, module.Joint, module.CalibrationProgress


EstimatorConfig, Pose, Joint, CalibrationProgress = _structs()


def load_library(path: str) -> ctypes.CDLL:
    """The library with the signatures of glovepose_c.h for the functions used here."""
    lib = ctypes.CDLL(path)
    p = ctypes.POINTER
    signatures = {
        "glovepose_abi_version": (ctypes.c_int32, []),
        "glovepose_row_time": (ctypes.c_double, [ctypes.c_double, ctypes.c_int32, ctypes.c_int32, ctypes.c_double]),
        "glovepose_last_error": (ctypes.c_char_p, []),
        "glovepose_model_load": (ctypes.c_int32, [ctypes.c_char_p, ctypes.c_int32, ctypes.c_char_p, p(ctypes.c_void_p)]),
        "glovepose_model_free": (None, [ctypes.c_void_p]),
        "glovepose_model_cell_count": (ctypes.c_int32, [ctypes.c_void_p]),
        "glovepose_model_row_count": (ctypes.c_int32, [ctypes.c_void_p]),
        "glovepose_estimator_config_default": (ctypes.c_int32, [p(EstimatorConfig)]),
        "glovepose_estimator_create": (ctypes.c_int32, [ctypes.c_void_p, p(EstimatorConfig), p(ctypes.c_void_p)]),
        "glovepose_estimator_free": (None, [ctypes.c_void_p]),
        "glovepose_estimator_push_row": (ctypes.c_int32, [ctypes.c_void_p, ctypes.c_int32, ctypes.c_double, ctypes.c_double]),
        "glovepose_estimator_get_pose": (ctypes.c_int32, [ctypes.c_void_p, p(Pose)]),
        "glovepose_estimator_get_joints": (ctypes.c_int32, [ctypes.c_void_p, p(Joint), ctypes.c_int32]),
        "glovepose_calibration_start": (ctypes.c_int32, [ctypes.c_void_p]),
        "glovepose_calibration_finish": (ctypes.c_int32, [ctypes.c_void_p]),
        "glovepose_calibration_get_progress": (ctypes.c_int32, [ctypes.c_void_p, p(CalibrationProgress)]),
    }
    for name, (restype, argtypes) in signatures.items():
        fn = getattr(lib, name)
        fn.restype = restype
        fn.argtypes = argtypes
    return lib


class Checks:
    def __init__(self) -> None:
        self.passed = 0
        self.failed = 0

    def check(self, condition: bool, what: str) -> None:
        if condition:
            self.passed += 1
        else:
            self.failed += 1
            print(f"FAILED: {what}")


def required_env(name: str) -> str:
    value = os.environ.get(name)
    if not value or not Path(value).exists():
        raise SystemExit(f"test_capi.py: {name} is {value!r}, expected the path of the built file (CTest sets it)")
    return value


def pose_record(frame: int, row: int, pose: Pose, joints) -> list:
    """The numbers capi_cpp_reference prints for a pose, in its order."""
    record = [frame, row, pose.sequence, pose.timestamp, pose.oldest_age, pose.flags, pose.rejected]
    record += list(pose.angles) + list(pose.raw_angles)
    for j in joints:
        record += list(j.position) + list(j.rotation)
    return record


def stream_through_capi(lib, model, rows: np.ndarray, timestamps: np.ndarray, kind: np.ndarray, rate: float):
    """The session protocol of cpp_reference.cpp, through the C ABI. Returns (records, last pose per frame)."""
    config = EstimatorConfig()
    assert lib.glovepose_estimator_config_default(ctypes.byref(config)) == OK
    config.smoothing = 1
    config.smoothing_frequency, config.smoothing_min_cutoff, config.smoothing_beta, config.smoothing_d_cutoff = 60.0, 1.0, 0.5, 1.0
    config.joint_transforms = 1
    estimator = ctypes.c_void_p()
    if lib.glovepose_estimator_create(model, ctypes.byref(config), ctypes.byref(estimator)) != OK:
        raise RuntimeError(lib.glovepose_last_error().decode())
    frames, row_count = rows.shape
    calibration_end = 0
    while calibration_end < frames and kind[calibration_end] == 1:
        calibration_end += 1
    if calibration_end > 0:
        assert lib.glovepose_calibration_start(estimator) == OK
    pose = Pose()
    pose.struct_size = ctypes.sizeof(Pose)
    joints = (Joint * JOINTS)()
    push_row = lib.glovepose_estimator_push_row
    records, frame_poses = [], {}
    row_values = rows.tolist()  # float32 -> Python float: exact, as the C++ side's float -> double
    stamps = timestamps.tolist()
    for f in range(frames):
        if f == calibration_end and calibration_end > 0:
            if lib.glovepose_calibration_finish(estimator) != OK:
                raise RuntimeError(lib.glovepose_last_error().decode())
        for r in range(row_count):
            timestamp = lib.glovepose_row_time(stamps[f], r, row_count, rate)
            if push_row(estimator, r, row_values[f][r], timestamp) == SOLVED:
                assert lib.glovepose_estimator_get_pose(estimator, ctypes.byref(pose)) == OK
                assert lib.glovepose_estimator_get_joints(estimator, joints, JOINTS) == OK
                records.append(pose_record(f, r, pose, joints))
        if f >= calibration_end:
            frame_poses[f] = list(pose.raw_angles)
    progress = CalibrationProgress()
    progress.struct_size = ctypes.sizeof(CalibrationProgress)
    assert lib.glovepose_calibration_get_progress(estimator, ctypes.byref(progress)) == OK
    lib.glovepose_estimator_free(estimator)
    return records, frame_poses, progress.source


def parse_reference(text: str):
    records, end = [], None
    for line in text.splitlines():
        fields = line.split()
        if fields[0] == "pose":
            ints = [int(x) for x in fields[1:4]]
            floats = [float(x) for x in fields[4:6]]
            record = ints + floats + [int(fields[6]), int(fields[7])] + [float(x) for x in fields[8:]]
            records.append(record)
        elif fields[0] == "end":
            end = (int(fields[1]), int(fields[2]))
    return records, end


def main() -> int:
    checks = Checks()
    library = required_env("GLOVEPOSE_C_LIBRARY")
    reference = required_env("GLOVEPOSE_CPP_REFERENCE")
    cli = required_env("GLOVEPOSE_CLI")
    lib = load_library(library)

    # The struct layouts of the header (ABI 1).
    checks.check(lib.glovepose_abi_version() == 1, "ABI version 1")
    for struct, size in ((EstimatorConfig, 80), (Pose, 448), (Joint, 28), (CalibrationProgress, 32)):
        checks.check(ctypes.sizeof(struct) == size, f"ctypes.sizeof({struct.__name__}) == {size}")

    # Errors reach Python with their message; the last-error string is per thread.
    model = ctypes.c_void_p()
    missing = b"/nonexistent/glovepose/model.safetensors"
    checks.check(lib.glovepose_model_load(missing, 0, None, ctypes.byref(model)) == ERROR_FILE_NOT_FOUND, "missing model: file not found")
    checks.check(model.value is None, "missing model: no handle")
    checks.check(missing in lib.glovepose_last_error(), "missing model: the message names the file")
    seen_in_thread = []

    def other_thread() -> None:
        seen_in_thread.append(lib.glovepose_last_error())
        lib.glovepose_model_cell_count(None)  # fails on this thread only
        seen_in_thread.append(lib.glovepose_last_error())

    worker = threading.Thread(target=other_thread)
    worker.start()
    worker.join()
    checks.check(seen_in_thread[0] == b"", "a new thread starts with an empty last error")
    checks.check(b"invalid model handle" in seen_in_thread[1], "the thread's own error")
    checks.check(missing in lib.glovepose_last_error(), "the main thread's error is untouched by the other thread's")

    if lib.glovepose_model_load(str(MODEL).encode(), 0, None, ctypes.byref(model)) != OK:
        print(f"cannot load {MODEL}: {lib.glovepose_last_error().decode()}")
        return 1
    checks.check(lib.glovepose_model_cell_count(model) == 44 and lib.glovepose_model_row_count(model) == 180, "44 cells, 180 rows")

    scratch = os.environ.get("GLOVEPOSE_C_TEST_DIR") or tempfile.mkdtemp(prefix="glovepose_capi_")
    dataset = Path(scratch) / "python_capi_session.safetensors"
    subprocess.run([cli, "simulate", "--world", "clean", "--seed", "41", "--subjects", "1", "--sessions", "1", "--gloves", "1",
                    "--minutes", "0.1", "--calibration-seconds", "3", "--raw-rows", "--threads", "1", "--out", str(dataset)],
                   check=True, stdout=subprocess.DEVNULL)
    tensors, metadata = safetensors_io.load(dataset)
    rate = float(metadata["frame_rate"])
    rows = tensors["raw_rows"].numpy()
    timestamps = tensors["timestamps"].numpy()
    kind = tensors["kind"].numpy()
    truth = tensors["angles"].numpy().astype(np.float64)

    reference_run = subprocess.run([reference, "session", str(MODEL), str(dataset)], check=True, capture_output=True, text=True)
    expected, expected_end = parse_reference(reference_run.stdout)
    got, frame_poses, source = stream_through_capi(lib, model, rows, timestamps, kind, rate)
    lib.glovepose_model_free(model)

    checks.check(len(got) > 100, f"the session gives poses (got {len(got)})")
    checks.check(len(got) == len(expected) and expected_end is not None and expected_end[0] == len(expected),
                 f"as many poses through the C ABI ({len(got)}) as through the C++ API ({len(expected)})")
    checks.check(expected_end is not None and expected_end[1] == source == 1, "both end calibrated on the fly")
    same_header = all(g[0:3] == e[0:3] and g[5:7] == e[5:7] for g, e in zip(got, expected))
    checks.check(same_header, "every pose: the same frame, row, sequence, flags and rejected count")
    worst = {"angles": 0.0, "raw_angles": 0.0, "timestamp/oldest_age": 0.0, "joints": 0.0}
    for g, e in zip(got, expected):
        worst["timestamp/oldest_age"] = max(worst["timestamp/oldest_age"], abs(g[3] - e[3]), abs(g[4] - e[4]))
        worst["angles"] = max(worst["angles"], max(abs(a - b) for a, b in zip(g[7:7 + DOFS], e[7:7 + DOFS])))
        worst["raw_angles"] = max(worst["raw_angles"], max(abs(a - b) for a, b in zip(g[7 + DOFS:7 + 2 * DOFS], e[7 + DOFS:7 + 2 * DOFS])))
        worst["joints"] = max(worst["joints"], max(abs(a - b) for a, b in zip(g[7 + 2 * DOFS:], e[7 + 2 * DOFS:])))
    print(f"C ABI (Python ctypes) vs C++ API over {len(got)} poses: largest differences " +
          ", ".join(f"{k} {v:.3g}" for k, v in worst.items()))
    for name, value in worst.items():
        checks.check(value == 0.0, f"{name}: C ABI equals the C++ API exactly (largest difference {value})")

    # The comparison is not vacuous: the poses move, smoothing acts, and they track the simulated hand.
    angles = np.array([g[7:7 + DOFS] for g in got])
    raw = np.array([g[7 + DOFS:7 + 2 * DOFS] for g in got])
    checks.check(float(angles.std(axis=0).max()) > 0.05, "the angles move over the session")
    checks.check(float(np.abs(angles - raw).max()) > 1e-3, "smoothing changes the angles")
    frames = sorted(frame_poses)[10:]  # past the readout's ring of calibration rows
    error = np.mean([np.abs(np.array(frame_poses[f]) - truth[f]).mean() for f in frames]) * 180.0 / math.pi
    print(f"mean angle error vs the simulated hand over {len(frames)} frames: {error:.2f} degrees")
    checks.check(error < 10.0, f"the poses track the simulated hand (mean error {error:.2f} < 10 degrees)")

    print(f"{checks.passed} passed, {checks.failed} failed")
    return 0 if checks.failed == 0 else 1


if __name__ == "__main__":
    sys.exit(main())
