"""Finding and describing libglovepose_c: the C ABI's structs and function signatures (glovepose_c.h,
ABI 1) for ctypes; and libglovepose_eval (glovepose_eval.h), the offline evaluation beside it."""
from __future__ import annotations

import ctypes
import ctypes.util
import os
import sys
from pathlib import Path

DOF_COUNT, JOINT_COUNT = 25, 21
#: GLOVEPOSE_XR_JOINT_COUNT: OpenXR's hand joints (XR_HAND_JOINT_COUNT_EXT).
XR_JOINT_COUNT = 26
#: GLOVEPOSE_HAND_RIGHT / GLOVEPOSE_HAND_LEFT.
HAND_RIGHT, HAND_LEFT = 0, 1
#: GLOVEPOSE_XR_*: OpenXR's XrSpaceLocationFlags and XrSpaceVelocityFlags bits.
XR_ORIENTATION_VALID, XR_POSITION_VALID, XR_ORIENTATION_TRACKED, XR_POSITION_TRACKED = 0x1, 0x2, 0x4, 0x8
XR_LINEAR_VELOCITY_VALID, XR_ANGULAR_VELOCITY_VALID = 0x1, 0x2
#: GLOVEPOSE_XR_TYPE_HAND_TRACKING_AIM_STATE_FB: XR_TYPE_HAND_TRACKING_AIM_STATE_FB, XrAimState.type.
XR_TYPE_HAND_TRACKING_AIM_STATE_FB = 1000111001


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


class HandOptions(ctypes.Structure):
    _fields_ = [
        ("struct_size", ctypes.c_uint32),
        ("handedness", ctypes.c_int32),
        ("prediction_window", ctypes.c_double),
        ("max_prediction", ctypes.c_double),
    ]


class PredictedPose(ctypes.Structure):
    _fields_ = [
        ("struct_size", ctypes.c_uint32),
        ("flags", ctypes.c_uint32),
        ("angles", ctypes.c_double * DOF_COUNT),
        ("rate", ctypes.c_double * DOF_COUNT),
        ("time", ctypes.c_double),
        ("horizon", ctypes.c_double),
        ("predicted", ctypes.c_int32),
        ("clamped", ctypes.c_int32),
        ("has_rate", ctypes.c_int32),
        ("trusted", ctypes.c_int32),
    ]


class CalibrationStep(ctypes.Structure):
    _fields_ = [
        ("struct_size", ctypes.c_uint32),
        ("step", ctypes.c_int32),
        ("step_count", ctypes.c_int32),
        ("pose", ctypes.c_float * DOF_COUNT),
        ("start_seconds", ctypes.c_double),
        ("seconds", ctypes.c_double),
        ("name", ctypes.c_char * 32),
        ("instruction", ctypes.c_char * 1024),
    ]


class XrJointLocation(ctypes.Structure):
    _fields_ = [
        ("location_flags", ctypes.c_uint64),
        ("orientation", ctypes.c_float * 4),
        ("position", ctypes.c_float * 3),
        ("radius", ctypes.c_float),
    ]


class XrJointVelocity(ctypes.Structure):
    _fields_ = [
        ("velocity_flags", ctypes.c_uint64),
        ("linear_velocity", ctypes.c_float * 3),
        ("angular_velocity", ctypes.c_float * 3),
    ]


class XrHand(ctypes.Structure):
    _fields_ = [
        ("struct_size", ctypes.c_uint32),
        ("active", ctypes.c_int32),
        ("predicted", ctypes.c_int32),
        ("clamped", ctypes.c_int32),
        ("handedness", ctypes.c_int32),
        ("data_source", ctypes.c_int32),
        ("time", ctypes.c_double),
        ("horizon", ctypes.c_double),
        ("locations", XrJointLocation * XR_JOINT_COUNT),
        ("velocities", XrJointVelocity * XR_JOINT_COUNT),
    ]


class XrAimState(ctypes.Structure):
    """glovepose_xr_aim_state, laid out as OpenXR's XrHandTrackingAimStateFB (padding included)."""
    _fields_ = [
        ("type", ctypes.c_int32),
        ("next", ctypes.c_void_p),
        ("status", ctypes.c_uint64),
        ("aim_orientation", ctypes.c_float * 4),
        ("aim_position", ctypes.c_float * 3),
        ("pinch_strength_index", ctypes.c_float),
        ("pinch_strength_middle", ctypes.c_float),
        ("pinch_strength_ring", ctypes.c_float),
        ("pinch_strength_little", ctypes.c_float),
    ]


# The sizes glovepose_c.h documents for ABI 1 (and its static_asserts hold the C compiler to).
_SIZES = {EstimatorConfig: 80, Pose: 448, Joint: 28, CalibrationProgress: 32, HandOptions: 24, PredictedPose: 440,
          CalibrationStep: 1184, XrJointLocation: 40, XrJointVelocity: 32, XrHand: 1912}
# The function that fills each struct with the library's own sizeof(struct) in struct_size.
_INITS = {EstimatorConfig: "glovepose_estimator_config_default", HandOptions: "glovepose_hand_options_default", Pose: "glovepose_pose_init",
          CalibrationProgress: "glovepose_calibration_progress_init", CalibrationStep: "glovepose_calibration_step_init",
          XrHand: "glovepose_xr_hand_init", PredictedPose: "glovepose_predicted_pose_init"}

_P = ctypes.POINTER
_VOID = ctypes.c_void_p
_SIGNATURES = {
    "glovepose_version": (ctypes.c_char_p, []),
    "glovepose_isa": (ctypes.c_char_p, []),
    "glovepose_abi_version": (ctypes.c_int32, []),
    "glovepose_row_time": (ctypes.c_double, [ctypes.c_double, ctypes.c_int32, ctypes.c_int32, ctypes.c_double]),
    "glovepose_last_error": (ctypes.c_char_p, []),
    "glovepose_result_name": (ctypes.c_char_p, [ctypes.c_int32]),
    "glovepose_dof_name": (ctypes.c_char_p, [ctypes.c_int32]),
    "glovepose_joint_name": (ctypes.c_char_p, [ctypes.c_int32]),
    "glovepose_joint_parent": (ctypes.c_int32, [ctypes.c_int32]),
    "glovepose_xr_joint_name": (ctypes.c_char_p, [ctypes.c_int32]),
    "glovepose_xr_joint_parent": (ctypes.c_int32, [ctypes.c_int32]),
    "glovepose_model_load": (ctypes.c_int32, [ctypes.c_char_p, ctypes.c_int32, ctypes.c_char_p, _P(_VOID)]),
    "glovepose_model_free": (None, [_VOID]),
    "glovepose_model_cell_count": (ctypes.c_int32, [_VOID]),
    "glovepose_model_row_count": (ctypes.c_int32, [_VOID]),
    "glovepose_model_glove_id": (ctypes.c_char_p, [_VOID]),
    "glovepose_model_cell_name": (ctypes.c_char_p, [_VOID, ctypes.c_int32]),
    "glovepose_model_has_training_range": (ctypes.c_int32, [_VOID]),
    "glovepose_model_has_range_map": (ctypes.c_int32, [_VOID]),
    "glovepose_model_has_pose_error": (ctypes.c_int32, [_VOID]),
    "glovepose_model_calibration_step_count": (ctypes.c_int32, [_VOID]),
    "glovepose_model_get_calibration_step": (ctypes.c_int32, [_VOID, ctypes.c_int32, _P(CalibrationStep)]),
    "glovepose_estimator_config_default": (ctypes.c_int32, [_P(EstimatorConfig)]),
    "glovepose_estimator_create": (ctypes.c_int32, [_VOID, _P(EstimatorConfig), _P(_VOID)]),
    "glovepose_hand_options_default": (ctypes.c_int32, [_P(HandOptions)]),
    "glovepose_estimator_create_for_hand": (ctypes.c_int32, [_VOID, _P(EstimatorConfig), _P(HandOptions), _P(_VOID)]),
    "glovepose_estimator_free": (None, [_VOID]),
    "glovepose_estimator_push_row": (ctypes.c_int32, [_VOID, ctypes.c_int32, ctypes.c_double, ctypes.c_double]),
    "glovepose_estimator_push_measurements": (ctypes.c_int32, [_VOID, _P(ctypes.c_double), ctypes.c_int32, ctypes.c_double]),
    "glovepose_estimator_push_cells": (ctypes.c_int32, [_VOID, _P(ctypes.c_double), ctypes.c_int32, ctypes.c_double, ctypes.c_double]),
    "glovepose_estimator_get_pose": (ctypes.c_int32, [_VOID, _P(Pose)]),
    "glovepose_estimator_get_joints": (ctypes.c_int32, [_VOID, _P(Joint), ctypes.c_int32]),
    "glovepose_estimator_get_pose_at": (ctypes.c_int32, [_VOID, ctypes.c_double, _P(PredictedPose)]),
    "glovepose_estimator_get_xr_joints": (ctypes.c_int32, [_VOID, ctypes.c_double, _P(XrHand)]),
    "glovepose_estimator_get_cells": (ctypes.c_int32, [_VOID, _P(ctypes.c_double), ctypes.c_int32]),
    "glovepose_estimator_get_confidence": (ctypes.c_int32, [_VOID, _P(ctypes.c_double), ctypes.c_int32]),
    "glovepose_estimator_get_xr_aim": (ctypes.c_int32, [_VOID, _P(XrAimState)]),
    "glovepose_estimator_reset": (ctypes.c_int32, [_VOID]),
    "glovepose_latest_create": (ctypes.c_int32, [_P(_VOID)]),
    "glovepose_latest_free": (None, [_VOID]),
    "glovepose_latest_publish": (ctypes.c_int32, [_VOID, _VOID]),
    "glovepose_latest_read": (ctypes.c_int32, [_VOID, _P(Pose), _P(Joint), ctypes.c_int32, _P(ctypes.c_uint64)]),
    "glovepose_latest_get_xr_joints": (ctypes.c_int32, [_VOID, _VOID, ctypes.c_double, _P(XrHand)]),
    "glovepose_latest_get_xr_aim": (ctypes.c_int32, [_VOID, _P(XrAimState), _P(ctypes.c_uint64)]),
    "glovepose_calibration_start": (ctypes.c_int32, [_VOID]),
    "glovepose_calibration_finish": (ctypes.c_int32, [_VOID]),
    "glovepose_calibration_cancel": (ctypes.c_int32, [_VOID]),
    "glovepose_calibration_get_progress": (ctypes.c_int32, [_VOID, _P(CalibrationProgress)]),
    "glovepose_calibration_get_step": (ctypes.c_int32, [_VOID, _P(ctypes.c_int32), _P(ctypes.c_double)]),
    "glovepose_calibration_load": (ctypes.c_int32, [_VOID, ctypes.c_char_p]),
    "glovepose_calibration_save": (ctypes.c_int32, [_VOID, ctypes.c_char_p]),
    "glovepose_calibration_use_training": (ctypes.c_int32, [_VOID]),
    "glovepose_calibration_use_continuous": (ctypes.c_int32, [_VOID]),
    "glovepose_calibration_clear": (ctypes.c_int32, [_VOID]),
    "glovepose_calibration_set_range": (ctypes.c_int32, [_VOID, _P(ctypes.c_double), _P(ctypes.c_double), ctypes.c_int32]),
    "glovepose_calibration_get_range": (ctypes.c_int32, [_VOID, _P(ctypes.c_double), _P(ctypes.c_double), ctypes.c_int32]),
    "glovepose_pose_init": (None, [_P(Pose)]),
    "glovepose_calibration_progress_init": (None, [_P(CalibrationProgress)]),
    "glovepose_calibration_step_init": (None, [_P(CalibrationStep)]),
    "glovepose_xr_hand_init": (None, [_P(XrHand)]),
    "glovepose_predicted_pose_init": (None, [_P(PredictedPose)]),
    "glovepose_xr_aim_state_init": (None, [_P(XrAimState)]),
}
# glovepose_eval.h's functions (libglovepose_eval): what glovepose.evaluate calls.
_EVAL_SIGNATURES = {
    "glovepose_evaluate": (ctypes.c_int32, [ctypes.c_char_p, ctypes.c_char_p, ctypes.c_char_p, _P(ctypes.c_char_p)]),
    "glovepose_eval_last_error": (ctypes.c_char_p, []),
}


def _candidates(name: str, variable: str) -> list[str]:
    """Where lib`name`.so may be: $`variable`, the system's search (an installed prefix), the lib/ of
    this Python's prefix (a virtual environment glovepose was installed into with
    `cmake --install build --prefix VENV`), then a build tree beside this package's source (python/
    in a clone: build/capi/)."""
    found = []
    if os.environ.get(variable):
        found.append(os.environ[variable])
    system = ctypes.util.find_library(name)
    if system:
        found.append(system)
    found.append(str(Path(sys.prefix) / "lib" / f"lib{name}.so"))
    clone = Path(__file__).resolve().parents[2]
    for build in ("build", "build-clang"):
        found.append(str(clone / build / "capi" / f"lib{name}.so"))
    return found


def library_size(lib: ctypes.CDLL, struct: type) -> int:
    """sizeof(struct) in the library: what its init / _default function writes into struct_size,
    called on a buffer larger than any struct of the ABI."""
    buffer = (ctypes.c_uint8 * 8192)()
    init = getattr(lib, _INITS[struct])
    init(ctypes.cast(buffer, init.argtypes[0]))
    return ctypes.c_uint32.from_buffer(buffer).value


def _check_layouts(lib: ctypes.CDLL, path: str) -> None:
    """The structs above against the documented sizes and the library's own sizeof: a mismatch
    means a library of another ABI (or a mistake here), which would corrupt memory."""
    for struct, size in _SIZES.items():
        sizes = {ctypes.sizeof(struct), size} | ({library_size(lib, struct)} if struct in _INITS else set())
        if len(sizes) != 1:
            raise OSError(f"{path}: {struct.__name__} is {ctypes.sizeof(struct)} bytes here, {size} documented"
                          + (f", {library_size(lib, struct)} in the library" if struct in _INITS else ""))


def _open(places: list[str], signatures: dict, name: str, variable: str) -> ctypes.CDLL:
    """The first of `places` that loads, with `signatures` set; raises OSError naming the places tried."""
    tried = []
    for path in places:
        try:
            lib = ctypes.CDLL(path)
        except OSError as e:
            tried.append(f"{path} ({e})")
            continue
        for function, (restype, argtypes) in signatures.items():
            fn = getattr(lib, function)
            fn.restype, fn.argtypes = restype, argtypes
        return lib
    raise OSError(f"lib{name} not found; set {variable} to its path. Tried: " + "; ".join(tried))


def load() -> ctypes.CDLL:
    """libglovepose_c with _SIGNATURES; raises OSError naming the places tried."""
    lib = _open(_candidates("glovepose_c", "GLOVEPOSE_LIBRARY"), _SIGNATURES, "glovepose_c", "GLOVEPOSE_LIBRARY")
    if lib.glovepose_abi_version() != 1:
        raise OSError(f"{lib._name}: ABI version {lib.glovepose_abi_version()}, expected 1")
    _check_layouts(lib, lib._name)
    return lib


def load_eval(beside: ctypes.CDLL) -> ctypes.CDLL:
    """libglovepose_eval (glovepose.evaluate's library) with _EVAL_SIGNATURES: $GLOVEPOSE_EVAL_LIBRARY,
    else first the folder libglovepose_c `beside` was loaded from (the same install or build tree),
    then where load() looks. Raises OSError naming the places tried."""
    places = _candidates("glovepose_eval", "GLOVEPOSE_EVAL_LIBRARY")
    folder = os.path.dirname(beside._name)
    if folder and not os.environ.get("GLOVEPOSE_EVAL_LIBRARY"):
        places.insert(0, os.path.join(folder, "libglovepose_eval.so"))
    return _open(places, _EVAL_SIGNATURES, "glovepose_eval", "GLOVEPOSE_EVAL_LIBRARY")
