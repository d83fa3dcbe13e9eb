"""Finding and describing libglovepose_c: the C ABI's structs and function signatures (glovepose_c.h,
ABI 1) for ctypes."""
from __future__ import annotations

import ctypes
import ctypes.util
import os
import sys
from pathlib import Path

DOF_COUNT, JOINT_COUNT = 25, 21


class EstimatorConfig(ctypes.Structure):
    _fields_ = [
        ("struct_size", ctypes.c_uint32),
        ("readout_mean_window", ctypes.c_int32),
        ("readout_solve_every", ctypes.c_int32),
        ("calibration_median_window", ctypes.c_int32),
        ("calibration_sample_period", ctypes.c_double),
        ("calibration_min_relative_range", ctypes.c_double),
        ("calibration_clamp_limit", ctypes.c_double),
        ("smoothing", ctypes.c_int32),
        ("joint_transforms", ctypes.c_int32),
        ("smoothing_frequency", ctypes.c_double),
        ("smoothing_min_cutoff", ctypes.c_double),
        ("smoothing_beta", ctypes.c_double),
        ("smoothing_d_cutoff", ctypes.c_double),
    ]


class Pose(ctypes.Structure):
    _fields_ = [
        ("struct_size", ctypes.c_uint32),
        ("flags", ctypes.c_uint32),
        ("angles", ctypes.c_double * DOF_COUNT),
        ("raw_angles", ctypes.c_double * DOF_COUNT),
        ("timestamp", ctypes.c_double),
        ("oldest_age", ctypes.c_double),
        ("compute_seconds", ctypes.c_double),
        ("sequence", ctypes.c_uint64),
        ("rejected", ctypes.c_uint32),
        ("valid", ctypes.c_int32),
    ]


class Joint(ctypes.Structure):
    _fields_ = [("position", ctypes.c_float * 3), ("rotation", ctypes.c_float * 4)]


class CalibrationProgress(ctypes.Structure):
    _fields_ = [
        ("struct_size", ctypes.c_uint32),
        ("collecting", ctypes.c_int32),
        ("frames", ctypes.c_int64),
        ("frames_needed", ctypes.c_int32),
        ("ready", ctypes.c_int32),
        ("source", ctypes.c_int32),
        ("flat_cells", ctypes.c_int32),
    ]


_SIZES = {EstimatorConfig: 80, Pose: 448, Joint: 28, CalibrationProgress: 32}

_P = ctypes.POINTER
_VOID = ctypes.c_void_p
_SIGNATURES = {
    "glovepose_version": (ctypes.c_char_p, []),
    "glovepose_abi_version": (ctypes.c_int32, []),
    "glovepose_last_error": (ctypes.c_char_p, []),
    "glovepose_result_name": (ctypes.c_char_p, [ctypes.c_int32]),
    "glovepose_dof_name": (ctypes.c_char_p, [ctypes.c_int32]),
    "glovepose_joint_name": (ctypes.c_char_p, [ctypes.c_int32]),
    "glovepose_model_load": (ctypes.c_int32, [ctypes.c_char_p, ctypes.c_int32, ctypes.c_char_p, _P(_VOID)]),
    "glovepose_model_free": (None, [_VOID]),
    "glovepose_model_cell_count": (ctypes.c_int32, [_VOID]),
    "glovepose_model_row_count": (ctypes.c_int32, [_VOID]),
    "glovepose_model_glove_id": (ctypes.c_char_p, [_VOID]),
    "glovepose_model_cell_name": (ctypes.c_char_p, [_VOID, ctypes.c_int32]),
    "glovepose_estimator_config_default": (ctypes.c_int32, [_P(EstimatorConfig)]),
    "glovepose_estimator_create": (ctypes.c_int32, [_VOID, _P(EstimatorConfig), _P(_VOID)]),
    "glovepose_estimator_free": (None, [_VOID]),
    "glovepose_estimator_push_row": (ctypes.c_int32, [_VOID, ctypes.c_int32, ctypes.c_double, ctypes.c_double]),
    "glovepose_estimator_push_measurements": (ctypes.c_int32, [_VOID, _P(ctypes.c_double), ctypes.c_int32, ctypes.c_double]),
    "glovepose_estimator_push_cells": (ctypes.c_int32, [_VOID, _P(ctypes.c_double), ctypes.c_int32, ctypes.c_double, ctypes.c_double]),
    "glovepose_estimator_get_pose": (ctypes.c_int32, [_VOID, _P(Pose)]),
    "glovepose_estimator_get_joints": (ctypes.c_int32, [_VOID, _P(Joint), ctypes.c_int32]),
    "glovepose_estimator_reset": (ctypes.c_int32, [_VOID]),
    "glovepose_calibration_start": (ctypes.c_int32, [_VOID]),
    "glovepose_calibration_finish": (ctypes.c_int32, [_VOID]),
    "glovepose_calibration_cancel": (ctypes.c_int32, [_VOID]),
    "glovepose_calibration_get_progress": (ctypes.c_int32, [_VOID, _P(CalibrationProgress)]),
    "glovepose_calibration_load": (ctypes.c_int32, [_VOID, ctypes.c_char_p]),
    "glovepose_calibration_save": (ctypes.c_int32, [_VOID, ctypes.c_char_p]),
}


def _candidates() -> list[str]:
    """Where the library may be: $GLOVEPOSE_LIBRARY, the system's search (an installed prefix),
    the lib/ of this Python's prefix (a virtual environment glovepose was installed into with
    `cmake --install build --prefix VENV`), then a build tree beside this package's source (python/
    in a clone: build/capi/)."""
    found = []
    if os.environ.get("GLOVEPOSE_LIBRARY"):
        found.append(os.environ["GLOVEPOSE_LIBRARY"])
    system = ctypes.util.find_library("glovepose_c")
    if system:
        found.append(system)
    found.append(str(Path(sys.prefix) / "lib" / "libglovepose_c.so"))
    clone = Path(__file__).resolve().parents[2]
    for build in ("build", "build-clang"):
        found.append(str(clone / build / "capi" / "libglovepose_c.so"))
    return found


def load() -> ctypes.CDLL:
    """libglovepose_c with the signatures above; raises OSError naming the places tried."""
    tried = []
    for path in _candidates():
        try:
            lib = ctypes.CDLL(path)
        except OSError as e:
            tried.append(f"{path} ({e})")
            continue
        for name, (restype, argtypes) in _SIGNATURES.items():
            fn = getattr(lib, name)
            fn.restype, fn.argtypes = restype, argtypes
        if lib.glovepose_abi_version() != 1:
            raise OSError(f"{path}: ABI version {lib.glovepose_abi_version()}, expected 1")
        for struct, size in _SIZES.items():
            assert ctypes.sizeof(struct) == size, f"{struct.__name__}: {ctypes.sizeof(struct)} bytes, expected {size}"
        return lib
    raise OSError("libglovepose_c not found; set GLOVEPOSE_LIBRARY to its path. Tried: " + "; ".join(tried))
