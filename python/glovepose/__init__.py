"""glovepose for Python: hand poses from a stretch-sensing glove through the C library
(libglovepose_c, loaded with ctypes; no compiled extension), numpy arrays in and out.

    import glovepose
    model = glovepose.PoseModel("models/glovepose_fcn512.safetensors")
    estimator = glovepose.Estimator(model, joint_transforms=True)
    estimator.start_calibration()
    ...  # estimator.push_row(row, value, timestamp) for every reading; SOLVED means a new pose
    estimator.finish_calibration()
    angles = estimator.angles()    # (25,) radians, DOF_NAMES order
    joints = estimator.joints()    # (21, 7): position x, y, z (m), rotation quaternion x, y, z, w
    hand = estimator.xr_joints(t)  # OpenXR's 26 joints at time t (wrist frame): positions, orientations, ...
    aim = estimator.xr_aim()       # XR_FB_hand_tracking_aim: pinch strengths and flags, the aim pose (wrist frame)

The library is found through $GLOVEPOSE_LIBRARY, the system's library path (an installed
glovepose), the lib/ of this Python's prefix (a virtual environment glovepose was installed into),
or a build tree of the clone this package sits in (build/capi/). glovepose.evaluate calls a second
library, libglovepose_eval (the training code engines do not ship), loaded at its first call: from
$GLOVEPOSE_EVAL_LIBRARY, else beside libglovepose_c, else the same places.
"""
from __future__ import annotations

import ctypes
import enum
import json
import math

import numpy as np

from . import _library
from .dataset import load_dataset

__all__ = ["PoseModel", "Estimator", "Pose", "PredictedPose", "XrHand", "XrAim", "XrAimFlag", "Latest", "LatestHand", "CalibrationStep",
           "CalibrationProgress", "CalibrationSource", "PoseFlag", "GloveposeError", "InputError", "load_dataset", "evaluate", "row_time", "Status", "OK", "SOLVED",
           "NOT_READY", "UNCALIBRATED", "DOF_NAMES", "JOINT_NAMES", "JOINT_PARENTS", "XR_JOINT_NAMES", "XR_JOINT_PARENTS",
           "XR_ORIENTATION_VALID", "XR_POSITION_VALID", "XR_ORIENTATION_TRACKED", "XR_POSITION_TRACKED", "XR_LINEAR_VELOCITY_VALID",
           "XR_ANGULAR_VELOCITY_VALID"]

_lib = _library.load()



class Status(enum.IntEnum):
    """Per-frame statuses (glovepose_c.h's GLOVEPOSE_* >= 0): what push_row, push_measurements and
    push_cells return. Equal to their ints; str() gives the library's name ("size mismatch")."""
    OK = 0
    SOLVED = 1
    NOT_READY = 2
    NON_FINITE = 3
    NEGATIVE = 4
    UNKNOWN_INDEX = 5
    TIMESTAMP_BACKWARDS = 6
    SIZE_MISMATCH = 7
    UNCALIBRATED = 8

    def __str__(self) -> str:
        return _lib.glovepose_result_name(self.value).decode()


# The library names every status and none past the last: the enum is complete.
if any(str(s) == "unknown result" for s in Status) or _lib.glovepose_result_name(len(Status)).decode() != "unknown result":
    raise ImportError("glovepose: the C library's per-frame statuses differ from glovepose.Status (a library of another version)")
OK, SOLVED, NOT_READY, UNCALIBRATED = Status.OK, Status.SOLVED, Status.NOT_READY, Status.UNCALIBRATED
_WEIGHTS = {"f32": 0, "f16": 1, "bf16": 2, "fixed16": 3}
_MODEL_WEIGHTS = {**_WEIGHTS, "realtime": 4}  # realtime: the fastest within 0.1 degree of F32 for `isa`


class PoseFlag(enum.IntFlag):
    """Bits of Pose.flags and PredictedPose.flags (glovepose_c.h's GLOVEPOSE_POSE_*); 0: nothing to
    distrust. A pose with any FAULT_FLAGS bit cannot be trusted (Pose.trusted)."""
    READINGS_REJECTED = 0x1      #: readings were rejected since the previous pose (their rows kept older values)
    INPUT_CLAMPED = 0x2          #: a calibrated cell lay beyond the clamp limit
    TRAINING_CALIBRATION = 0x4   #: normalised with the model's training-set range, not the user's own
    CALIBRATING = 0x8            #: produced while an on-the-fly calibration was collecting
    STALE_READINGS = 0x10        #: (fault) some rows stopped arriving
    RECOVERING = 0x20            #: (fault) some rows hold fewer readings than the mean window
    STUCK_ROWS = 0x40            #: (fault) a row repeats one value: a stuck sensor
    DISCONNECTED_ROWS = 0x80     #: (fault) a row reads (near) zero: a disconnected trace
    OUTLIER_ROWS = 0x100         #: (fault) a row disagrees with the least-squares solve
    MASKED_CELLS = 0x200         #: cells stopped being measured (a torn trace): stood in for from the others
    GLOVE_OFF = 0x400            #: (fault) the cells look like the glove lying off the hand
    FAULT_FLAGS = 0x5F0          #: the fault bits together


class XrAimFlag(enum.IntFlag):
    """Bits of XrAim.status: OpenXR's XrHandTrackingAimFlagsFB (XR_FB_hand_tracking_aim; glovepose_c.h's
    GLOVEPOSE_XR_AIM_*). The library never sets COMPUTED, SYSTEM_GESTURE, DOMINANT_HAND, MENU_PRESSED."""
    COMPUTED = 0x1          #: aim from sources beyond the hand data (never set: the glove has none)
    VALID = 0x2             #: the aim data is valid: a pose exists and has no fault flag
    INDEX_PINCHING = 0x4    #: thumb and index pinch (closer than 15 mm, until 18 mm apart)
    MIDDLE_PINCHING = 0x8   #: thumb and middle
    RING_PINCHING = 0x10    #: thumb and ring
    LITTLE_PINCHING = 0x20  #: thumb and little finger
    SYSTEM_GESTURE = 0x40   #: (never set)
    DOMINANT_HAND = 0x80    #: (never set)
    MENU_PRESSED = 0x100    #: (never set)


class CalibrationSource(enum.IntEnum):
    """Where the calibration range in use comes from (glovepose_c.h's GLOVEPOSE_CALIBRATION_*)."""
    NONE = 0        #: none yet: no pose can be computed
    ON_THE_FLY = 1  #: this user's on-the-fly calibration (start_calibration ... finish_calibration)
    USER = 2        #: set or loaded by the caller (load_calibration)
    TRAINING = 3    #: the model's training-set range (expect larger errors than with the user's own)
    CONTINUOUS = 4  #: kept from the wearer's free motion by the model's range map (no calibration step)


#: The 25 DoFs of the hand model, in the order of every angle array.
DOF_NAMES = tuple(_lib.glovepose_dof_name(d).decode() for d in range(_library.DOF_COUNT))
#: The 21 joints of joints(), in order.
JOINT_NAMES = tuple(_lib.glovepose_joint_name(j).decode() for j in range(_library.JOINT_COUNT))
#: The parent of each of the 21 joints (-1 for the palm).
JOINT_PARENTS = tuple(_lib.glovepose_joint_parent(j) for j in range(_library.JOINT_COUNT))
#: OpenXR's 26 hand joints of xr_joints(), in XrHandJointEXT order ("palm", "wrist", "thumb_metacarpal", ...).
XR_JOINT_NAMES = tuple(_lib.glovepose_xr_joint_name(j).decode() for j in range(_library.XR_JOINT_COUNT))
#: The parent of each OpenXR joint (-1 for the wrist; the palm and the metacarpals hang off the wrist).
XR_JOINT_PARENTS = tuple(_lib.glovepose_xr_joint_parent(j) for j in range(_library.XR_JOINT_COUNT))
#: Bits of XrHand.location_flags (OpenXR's XrSpaceLocationFlags) and XrHand.velocity_flags (XrSpaceVelocityFlags).
XR_ORIENTATION_VALID, XR_POSITION_VALID = _library.XR_ORIENTATION_VALID, _library.XR_POSITION_VALID
XR_ORIENTATION_TRACKED, XR_POSITION_TRACKED = _library.XR_ORIENTATION_TRACKED, _library.XR_POSITION_TRACKED
XR_LINEAR_VELOCITY_VALID, XR_ANGULAR_VELOCITY_VALID = _library.XR_LINEAR_VELOCITY_VALID, _library.XR_ANGULAR_VELOCITY_VALID
_HANDS = {"right": _library.HAND_RIGHT, "left": _library.HAND_LEFT}

version = _lib.glovepose_version().decode()


def _process_isa() -> str:
    isa = _lib.glovepose_isa()
    if isa is None:
        raise ImportError("glovepose: " + _lib.glovepose_last_error().decode())
    return isa.decode()


#: The instruction set the library's networks run in this process: "sse2", "avx2", "avx512" or
#: "neon" (the best the CPU executes, or the environment variable GLOVEPOSE_ISA's).
isa = _process_isa()


class GloveposeError(RuntimeError):
    """A call the library refused; `code` is its glovepose_result, the message the library's."""

    def __init__(self, code: int, message: str):
        super().__init__(message)
        self.code = code


class InputError(GloveposeError, ValueError):
    """A value the call cannot take: an array of the wrong length (code Status.SIZE_MISMATCH, the
    message names the expected length) or a non-finite time (code Status.NON_FINITE). Both a
    GloveposeError and a ValueError."""


def _check(code: int, last_error=None) -> int:
    """`code` if not an error, else GloveposeError with the message of `last_error` (the failing
    library's function; default glovepose_c's). Both libraries share glovepose_c.h's codes."""
    if code < 0:
        name = _lib.glovepose_result_name(code).decode()
        raise GloveposeError(code, f"{(last_error or _lib.glovepose_last_error)().decode()} ({name})")
    return code


def _vector(values, expected: int, call: str, what: str) -> np.ndarray:
    """`values` as a contiguous float64 array of shape (expected,), else InputError naming `expected`."""
    v = np.asarray(values, dtype=np.float64)
    if v.shape != (expected,):
        raise InputError(int(Status.SIZE_MISMATCH), f"{call}: an array of shape {v.shape}, expected {expected} values ({what}) "
                         f"({Status.SIZE_MISMATCH})")
    return np.ascontiguousarray(v)


def _status(code: int, call: str, time: float, not_ready_ok: bool = False) -> None:
    """The result of a call locating the hand at `time`: errors, a non-finite time and (unless
    not_ready_ok) no pose yet raise; OK passes."""
    _check(code)
    if code == Status.NON_FINITE:
        raise InputError(code, f"{call}: time {time!r}, expected a finite time (s) ({Status(code)})")
    if code == Status.NOT_READY and not not_ready_ok:
        raise GloveposeError(code, f"no pose yet: {call}() before any push returned SOLVED ({Status(code)})")
    if code not in (Status.OK, Status.NOT_READY):
        raise GloveposeError(code, f"{call}: unexpected status {Status(code)}")


def _new(struct: type):
    """A struct of the ABI zeroed, with struct_size set, as its *_init function leaves it."""
    value = struct()
    value.struct_size = ctypes.sizeof(struct)
    return value


class _Closing:
    """close() on leaving a with-block and when collected."""

    def close(self) -> None:
        raise NotImplementedError

    def __enter__(self):
        return self

    def __exit__(self, *_):
        self.close()

    def __del__(self):
        self.close()


class CalibrationStep:
    """One step of a model's guided calibration sequence (docs/calibration.md), what to show the
    user: index (0-based) of step_count; name (a short id, e.g. "flat_on_table"); instruction
    (what to tell the user); pose (25,) radians, DOF_NAMES order: the pose to copy; start_seconds
    (after the sequence's first calibration frame) and seconds (how long it lasts)."""

    def __init__(self, raw: _library.CalibrationStep):
        self.index, self.step_count = raw.step, raw.step_count
        self.name, self.instruction = raw.name.decode("utf-8"), raw.instruction.decode("utf-8")
        self.pose = np.array(raw.pose[:], dtype=np.float64)
        self.start_seconds, self.seconds = raw.start_seconds, raw.seconds

    def __repr__(self) -> str:
        return f"CalibrationStep({self.index}, {self.name!r}, {self.start_seconds:g}..{self.start_seconds + self.seconds:g} s)"


class PoseModel(_Closing):
    """A model file (weights_format.md) with its glove; shared by any number of estimators.
    cell_count, row_count (0: no wiring known, push_cells only), glove_id, cell_names,
    has_training_range (Estimator.use_training_calibration works), has_range_map (new estimators
    calibrate from the wearer's free motion, Estimator.use_continuous_calibration works), has_pose_error (the model
    carries its own measured errors, behind Estimator.confidence), and calibration_steps: the
    model's guided calibration sequence, a tuple of CalibrationStep (empty when the model's
    calibration is min-max only). weights: how the network holds them, "f32" (exact), "f16",
    "bf16", "fixed16", or "realtime": the fastest within 0.1 degree of F32 for `isa`."""

    def __init__(self, path: str, weights: str = "f32", glove: str | None = None):
        if weights not in _MODEL_WEIGHTS:
            raise ValueError(f"weights {weights!r}, expected one of {sorted(_MODEL_WEIGHTS)}")
        self._handle = ctypes.c_void_p()
        _check(_lib.glovepose_model_load(str(path).encode(), _MODEL_WEIGHTS[weights], str(glove).encode() if glove else None,
                                         ctypes.byref(self._handle)))
        self.cell_count = _lib.glovepose_model_cell_count(self._handle)
        self.row_count = _lib.glovepose_model_row_count(self._handle)
        self.glove_id = _lib.glovepose_model_glove_id(self._handle).decode()
        self.cell_names = tuple(_lib.glovepose_model_cell_name(self._handle, c).decode() for c in range(self.cell_count))
        self.has_training_range = _lib.glovepose_model_has_training_range(self._handle) == 1
        self.has_range_map = _lib.glovepose_model_has_range_map(self._handle) == 1
        self.has_pose_error = _lib.glovepose_model_has_pose_error(self._handle) == 1
        steps = []
        for k in range(_lib.glovepose_model_calibration_step_count(self._handle)):
            step = _new(_library.CalibrationStep)
            _check(_lib.glovepose_model_get_calibration_step(self._handle, k, ctypes.byref(step)))
            steps.append(CalibrationStep(step))
        self.calibration_steps = tuple(steps)

    def close(self) -> None:
        """Releases the model (estimators made from it keep it alive until they are closed)."""
        if getattr(self, "_handle", None):
            _lib.glovepose_model_free(self._handle)
            self._handle = ctypes.c_void_p()


class Pose:
    """One pose: angles and raw_angles (25,) radians, timestamp and oldest_age (s), flags (PoseFlag),
    trusted (no fault flag), sequence, rejected (readings since the pose before), valid (False
    before the first pose), compute_seconds (wall time the estimator spent on it)."""

    def __init__(self, raw: _library.Pose):
        self.angles = np.array(raw.angles[:], dtype=np.float64)
        self.raw_angles = np.array(raw.raw_angles[:], dtype=np.float64)
        self.timestamp, self.oldest_age, self.compute_seconds = raw.timestamp, raw.oldest_age, raw.compute_seconds
        self.flags, self.sequence, self.rejected, self.valid = PoseFlag(raw.flags), raw.sequence, raw.rejected, bool(raw.valid)
        self.trusted = not self.flags & PoseFlag.FAULT_FLAGS


def _joint_array(joints) -> np.ndarray:
    """A ctypes array of glovepose_joint as (n, 7): position x, y, z, quaternion x, y, z, w."""
    a = np.ctypeslib.as_array(joints)
    return np.concatenate([a["position"], a["rotation"]], axis=1).astype(np.float64)


class PredictedPose:
    """The hand at a requested time (Estimator.pose_at): angles (25,) radians, within the joint
    limits; rate (25,) rad/s, the recent poses' least-squares slope; time (s, the stream's clock)
    as asked; horizon (s): the time located minus the newest pose's timestamp (> 0: predicted
    ahead, at most max_prediction); predicted (extrapolated past the newest pose), clamped (asked
    further ahead than max_prediction: located at the bound), has_rate (rate from two poses or
    more), trusted (the newest pose has no fault flag), flags (the newest pose's PoseFlag bits)."""

    def __init__(self, raw: _library.PredictedPose):
        self.angles = np.array(raw.angles[:], dtype=np.float64)
        self.rate = np.array(raw.rate[:], dtype=np.float64)
        self.time, self.horizon, self.flags = raw.time, raw.horizon, PoseFlag(raw.flags)
        self.predicted, self.clamped, self.has_rate, self.trusted = (bool(raw.predicted), bool(raw.clamped), bool(raw.has_rate),
                                                                     bool(raw.trusted))


class XrHand:
    """One hand's 26 OpenXR joints (XR_EXT_hand_tracking, XR_JOINT_NAMES order) at one time, in the
    wrist joint's frame: metres, right-handed, the wrist the identity pose, fingers along -Z, the
    back of the hand +Y, the thumb towards +X on a right hand and -X on a left one (an engine
    composes them with the wrist pose its tracker reports). numpy arrays (float64 holding the
    library's float32 values):

    - positions (26, 3) m; orientations (26, 4) unit quaternions x, y, z, w (+Z along the bone away
      from the tip, +Y out of the back of the finger); radii (26,) m; location_flags (26,) uint64,
      XR_*_VALID / XR_*_TRACKED bits (tracked when the newest pose is trusted and not clamped and
      the joint's confidence, the product of its digit's DoF confidences up to it, is at least 0.5);
    - linear_velocities (26, 3) m/s; angular_velocities (26, 3) rad/s (axis times rate);
      velocity_flags (26,) uint64, XR_*_VELOCITY_VALID bits (0 before two poses give a rate);
    - active (False before the first pose: every flag 0, nothing to show, like OpenXR's isActive),
      predicted, clamped (as PredictedPose), hand ("right" or "left"), time and horizon (s);
    - data_source: XR_EXT_hand_tracking_data_source's source, 1 (unobstructed: a data glove)."""

    def __init__(self, raw: _library.XrHand):
        locations, velocities = np.ctypeslib.as_array(raw.locations), np.ctypeslib.as_array(raw.velocities)
        self.positions = locations["position"].astype(np.float64)
        self.orientations = locations["orientation"].astype(np.float64)
        self.radii = locations["radius"].astype(np.float64)
        self.location_flags = locations["location_flags"].astype(np.uint64)
        self.linear_velocities = velocities["linear_velocity"].astype(np.float64)
        self.angular_velocities = velocities["angular_velocity"].astype(np.float64)
        self.velocity_flags = velocities["velocity_flags"].astype(np.uint64)
        self.active, self.predicted, self.clamped = bool(raw.active), bool(raw.predicted), bool(raw.clamped)
        self.hand = "left" if raw.handedness == _library.HAND_LEFT else "right"
        self.time, self.horizon = raw.time, raw.horizon
        self.data_source = raw.data_source


class XrAim:
    """One hand's pinch and aim state as XR_FB_hand_tracking_aim gives it (glovepose_xr_aim_state):

    - status (XrAimFlag), valid (its VALID bit: a pose exists and is trusted), active (False before
      the first pose: status 0, strengths 0);
    - pinching: four bools, thumb with index, middle, ring, little: closer than 15 mm between the
      tips, until they part to 18 mm (the hysteresis is the estimator's, kept from pose to pose);
    - pinch_strength (4,) in [0, 1], same order: 1 at or below 15 mm, 0 at or beyond 40 mm, a
      smoothstep between;
    - aim_position (3,) m and aim_orientation (4,) quaternion x, y, z, w: the aim pose in the wrist
      joint's frame, like XrHand's joints: the index's proximal joint at the rest pose, -Z along the
      straight index, +Y the back of the hand; fixed in that frame (a pinch does not move the ray):
      an engine composes it with the wrist pose its tracker reports;
    - sequence: the pose's sequence (Latest.xr_aim; None from Estimator.xr_aim, whose pose() tells)."""

    def __init__(self, raw: _library.XrAimState, active: bool, sequence: int | None = None):
        self.status = XrAimFlag(raw.status)
        self.valid, self.active, self.sequence = bool(self.status & XrAimFlag.VALID), active, sequence
        self.pinching = tuple(bool(self.status & bit) for bit in (XrAimFlag.INDEX_PINCHING, XrAimFlag.MIDDLE_PINCHING,
                                                                  XrAimFlag.RING_PINCHING, XrAimFlag.LITTLE_PINCHING))
        self.pinch_strength = np.array([raw.pinch_strength_index, raw.pinch_strength_middle, raw.pinch_strength_ring,
                                        raw.pinch_strength_little], dtype=np.float64)
        self.aim_position = np.array(raw.aim_position[:], dtype=np.float64)
        self.aim_orientation = np.array(raw.aim_orientation[:], dtype=np.float64)


def _aim_state() -> _library.XrAimState:
    """A glovepose_xr_aim_state as glovepose_xr_aim_state_init leaves it (its type set)."""
    out = _library.XrAimState()
    _lib.glovepose_xr_aim_state_init(ctypes.byref(out))
    return out


class CalibrationProgress:
    """How far an on-the-fly calibration has come, and the range in use: collecting (between
    start_calibration and finish/cancel), frames (taken so far), frames_needed (before
    finish_calibration can succeed), ready (it would now), source (CalibrationSource of the range in
    use), flat_cells (cells of that range too flat to normalise by; 0 without a range); with a
    guided sequence, step (the CalibrationStep under way; None before the first frame, after the
    last step, when not collecting or without a sequence) and sequence_seconds (stream time since
    the sequence's first frame, 0 before it)."""

    def __init__(self, raw: _library.CalibrationProgress, step: CalibrationStep | None, sequence_seconds: float):
        self.collecting, self.frames, self.frames_needed, self.ready = bool(raw.collecting), raw.frames, raw.frames_needed, bool(raw.ready)
        self.source, self.flat_cells = CalibrationSource(raw.source), raw.flat_cells
        self.step, self.sequence_seconds = step, sequence_seconds

    def __repr__(self) -> str:
        return (f"CalibrationProgress(collecting={self.collecting}, frames={self.frames}/{self.frames_needed}, ready={self.ready}, "
                f"source={self.source.name}, flat_cells={self.flat_cells}, step={self.step!r}, sequence_seconds={self.sequence_seconds:g})")


class Estimator(_Closing):
    """One glove stream through a model, for a right (default) or left hand: hand="left" mirrors
    the joints (x -> -x) for the same readings, as a left glove is the right one's sensor sheet
    turned over; the angles are the same. Settings not given keep the library's defaults
    (glovepose_estimator_config_default, glovepose_hand_options_default): readout_mean_window,
    readout_solve_every, calibration_median_window, calibration_sample_period,
    calibration_min_relative_range, calibration_clamp_limit, smoothing (bool), joint_transforms
    (bool), smoothing_frequency, smoothing_min_cutoff, smoothing_beta, smoothing_d_cutoff, and for
    pose_at / xr_joints: prediction_window (s of recent poses whose slope predicts ahead, 0.15) and
    max_prediction (s past the newest pose predicted at most, 0.05)."""

    def __init__(self, model: PoseModel, hand: str = "right", **settings):
        if hand not in _HANDS:
            raise ValueError(f"hand {hand!r}, expected one of {sorted(_HANDS)}")
        config, options = _library.EstimatorConfig(), _library.HandOptions()
        _check(_lib.glovepose_estimator_config_default(ctypes.byref(config)))
        _check(_lib.glovepose_hand_options_default(ctypes.byref(options)))
        options.handedness = _HANDS[hand]
        fields = {name: struct for struct in (config, options) for name, _ in struct._fields_}
        for name in ("struct_size", "handedness"):
            del fields[name]
        for name, value in settings.items():
            if name not in fields:
                raise TypeError(f"unknown setting {name!r}, expected one of {sorted(fields)}")
            setattr(fields[name], name, int(value) if isinstance(value, bool) else value)
        self._model = model  # kept alive with the estimator
        self.hand = hand
        self._handle = ctypes.c_void_p()
        _check(_lib.glovepose_estimator_create_for_hand(model._handle, ctypes.byref(config), ctypes.byref(options),
                                                        ctypes.byref(self._handle)))
        self._pose = _library.Pose()
        self._pose.struct_size = ctypes.sizeof(_library.Pose)
        self._joints = (_library.Joint * _library.JOINT_COUNT)()

    # Streaming. Each push returns the per-frame Status, as in C: SOLVED (a new pose), OK or
    # NOT_READY (accepted, no new pose yet), UNCALIBRATED (solved, but no calibration range), or a
    # rejected reading: NON_FINITE (NaN or infinite value or timestamp), NEGATIVE, UNKNOWN_INDEX (a
    # row outside the wiring, or a model without wiring), TIMESTAMP_BACKWARDS. Returned, not raised:
    # a glitch in one frame of a real-time stream is reported and the stream goes on.
    # An array of the wrong length is the caller's mistake, the same on every frame: push_measurements
    # and push_cells raise InputError (a ValueError, code SIZE_MISMATCH) naming the expected length,
    # and never return SIZE_MISMATCH.
    def push_row(self, row: int, value: float, timestamp: float) -> Status:
        """One reading of measurement row `row` (0 .. row_count-1) at `timestamp` (s, increasing);
        returns the per-frame Status (a NaN value: NON_FINITE)."""
        return Status(_check(_lib.glovepose_estimator_push_row(self._handle, row, value, timestamp)))

    def push_measurements(self, values, timestamp: float) -> Status:
        """A whole frame of row_count compound measurements, solved at once; returns the per-frame
        Status (NaN values: their rows are skipped and counted). An array whose shape is not
        (row_count,) raises InputError naming row_count."""
        rows = self._model.row_count
        v = _vector(values, rows, "push_measurements", "the model's row_count") if rows else np.ascontiguousarray(values, np.float64)
        return Status(_check(_lib.glovepose_estimator_push_measurements(self._handle, v.ctypes.data_as(ctypes.POINTER(ctypes.c_double)),
                                                                        v.size, timestamp)))

    def push_cells(self, cells, timestamp: float, oldest_age: float = 0.0) -> Status:
        """A frame of cell_count solved cell capacitances (pF) at `timestamp`; `oldest_age` (s) is
        the age of its oldest reading (0 if unknown). Returns the per-frame Status (a NaN anywhere:
        NON_FINITE, the frame rejected). An array whose shape is not (cell_count,) raises InputError
        naming cell_count."""
        c = _vector(cells, self._model.cell_count, "push_cells", "the model's cell_count")
        return Status(_check(_lib.glovepose_estimator_push_cells(self._handle, c.ctypes.data_as(ctypes.POINTER(ctypes.c_double)), c.size,
                                                                 timestamp, oldest_age)))

    def pose(self) -> Pose:
        """The latest pose."""
        _check(_lib.glovepose_estimator_get_pose(self._handle, ctypes.byref(self._pose)))
        return Pose(self._pose)

    def angles(self) -> np.ndarray:
        """The latest pose's (25,) angles, radians, DOF_NAMES order. Before the first pose (no push
        has returned SOLVED) raises GloveposeError with code NOT_READY: there are no angles yet."""
        pose = self.pose()
        if not pose.valid:
            raise GloveposeError(int(Status.NOT_READY), "no pose yet: angles() before any push returned SOLVED (not ready)")
        return pose.angles

    def joints(self) -> np.ndarray:
        """The latest (21, 7) joints: position x, y, z (metres), rotation quaternion x, y, z, w
        (needs joint_transforms=True). Before the first pose raises as angles() does."""
        _check(_lib.glovepose_estimator_get_joints(self._handle, self._joints, _library.JOINT_COUNT))
        if not self.pose().valid:
            raise GloveposeError(int(Status.NOT_READY), "no pose yet: joints() before any push returned SOLVED (not ready)")
        return _joint_array(self._joints)

    def pose_at(self, time: float) -> PredictedPose:
        """The pose at `time` (s, the stream's clock of the timestamps pushed): at or before the
        newest pose, interpolated between the recent poses (the newest pose itself at its
        timestamp); after it, extrapolated along their slope for at most max_prediction seconds and
        held within the joint limits. Before the first pose raises GloveposeError with code
        NOT_READY, as angles() does; a NaN or infinite time raises InputError (code NON_FINITE)."""
        out = _new(_library.PredictedPose)
        _status(_lib.glovepose_estimator_get_pose_at(self._handle, time, ctypes.byref(out)), "pose_at", time)
        return PredictedPose(out)

    def xr_joints(self, time: float) -> XrHand:
        """OpenXR's 26 hand joints at `time` (s, the stream's clock), located from pose_at(time),
        with velocities. Before the first pose returns an XrHand with active False and every flag
        0 (an engine polls every frame; OpenXR's isActive); a NaN or infinite time raises InputError."""
        out = _new(_library.XrHand)
        _status(_lib.glovepose_estimator_get_xr_joints(self._handle, time, ctypes.byref(out)), "xr_joints", time, not_ready_ok=True)
        return XrHand(out)

    def xr_aim(self) -> XrAim:
        """The pinch and aim state of the latest pose (XR_FB_hand_tracking_aim). Before the first
        pose: active False, status 0, strengths 0 (the aim pose is already the hand's)."""
        out = _aim_state()
        code = _check(_lib.glovepose_estimator_get_xr_aim(self._handle, ctypes.byref(out)))
        return XrAim(out, active=code == Status.OK)

    def confidence(self) -> np.ndarray:
        """The latest pose's per-DoF confidence (25,), 0..1 (DOF_NAMES order): the probability that
        the angle is within 10 degrees of the truth, from the model's own errors measured on new people
        (PoseModel.has_pose_error; without them 1 for a trusted pose); 0 for a pose with a fault flag."""
        out = np.zeros(25, dtype=np.float64)
        _check(_lib.glovepose_estimator_get_confidence(self._handle, out.ctypes.data_as(ctypes.POINTER(ctypes.c_double)), out.size))
        return out

    def cells(self) -> np.ndarray:
        """The latest solved cell capacitances (cell_count,), pF: the network's input before
        calibration (cell_names order; zeros before the first frame), each input the glove
        description conditions (demean_seconds) less its rolling mean, as training saw them."""
        out = np.zeros(self._model.cell_count, dtype=np.float64)
        _check(_lib.glovepose_estimator_get_cells(self._handle, out.ctypes.data_as(ctypes.POINTER(ctypes.c_double)), out.size))
        return out

    def reset(self) -> None:
        """Forgets the stream (readings, filter, timestamps), e.g. after the glove was unplugged;
        keeps the calibration and the last pose."""
        _check(_lib.glovepose_estimator_reset(self._handle))

    # Calibration.
    def start_calibration(self) -> None:
        """Starts (or restarts) an on-the-fly calibration: solved frames also feed the per-cell
        range, and a guided sequence's clock starts at the first frame (calibration_progress()).
        Poses keep coming from the previous range, if any, flagged PoseFlag.CALIBRATING."""
        _check(_lib.glovepose_calibration_start(self._handle))

    def finish_calibration(self) -> None:
        """Ends the calibration and uses its range (source ON_THE_FLY). GloveposeError when none is
        running or fewer than frames_needed frames arrived (it then keeps collecting)."""
        _check(_lib.glovepose_calibration_finish(self._handle))

    def cancel_calibration(self) -> None:
        """Stops collecting and keeps the previous range."""
        _check(_lib.glovepose_calibration_cancel(self._handle))

    def calibration_progress(self) -> CalibrationProgress:
        """How far the calibration has come, the range in use, and the guided step under way (what
        to show the user now: progress.step.instruction, progress.step.pose)."""
        p, step, seconds = _new(_library.CalibrationProgress), ctypes.c_int32(), ctypes.c_double()
        _check(_lib.glovepose_calibration_get_progress(self._handle, ctypes.byref(p)))
        _check(_lib.glovepose_calibration_get_step(self._handle, ctypes.byref(step), ctypes.byref(seconds)))
        return CalibrationProgress(p, self._model.calibration_steps[step.value] if step.value >= 0 else None, seconds.value)

    def use_training_calibration(self) -> None:
        """Uses the model's training-set range (the paper's "without calibration"; poses are flagged
        PoseFlag.TRAINING_CALIBRATION). GloveposeError when the model records none
        (PoseModel.has_training_range)."""
        _check(_lib.glovepose_calibration_use_training(self._handle))

    def use_continuous_calibration(self) -> None:
        """Calibrates from the wearer's free motion from now on (CalibrationSource.CONTINUOUS: the
        model's prior range at once, refined as the wearer moves), what a new estimator does when
        the model carries a range map. GloveposeError when it carries none (PoseModel.has_range_map)."""
        _check(_lib.glovepose_calibration_use_continuous(self._handle))

    def clear_calibration(self) -> None:
        """Forgets the calibration in use: no pose (Status.UNCALIBRATED) until a calibration
        finishes or a range is set or loaded (CalibrationSource.NONE)."""
        _check(_lib.glovepose_calibration_clear(self._handle))

    def set_calibration_range(self, minimum, maximum) -> None:
        """Uses the range minimum[c] .. maximum[c] of each cell (pF, cell_names order); source
        USER. Arrays whose shape is not (cell_count,) raise InputError naming cell_count;
        non-finite values or a minimum above its maximum raise GloveposeError naming the cell."""
        low = _vector(minimum, self._model.cell_count, "set_calibration_range", "the model's cell_count")
        high = _vector(maximum, self._model.cell_count, "set_calibration_range", "the model's cell_count")
        _check(_lib.glovepose_calibration_set_range(self._handle, low.ctypes.data_as(ctypes.POINTER(ctypes.c_double)),
                                                    high.ctypes.data_as(ctypes.POINTER(ctypes.c_double)), low.size))

    def calibration_range(self) -> tuple[np.ndarray, np.ndarray]:
        """The range in use as (minimum, maximum), each (cell_count,) pF. Before any range is set
        raises GloveposeError with code UNCALIBRATED (there is none to give)."""
        low, high = np.zeros(self._model.cell_count), np.zeros(self._model.cell_count)
        code = _check(_lib.glovepose_calibration_get_range(self._handle, low.ctypes.data_as(ctypes.POINTER(ctypes.c_double)),
                                                           high.ctypes.data_as(ctypes.POINTER(ctypes.c_double)), low.size))
        if code == Status.UNCALIBRATED:
            raise GloveposeError(code, f"calibration_range: no calibration range yet ({Status(code)})")
        return low, high

    def save_calibration(self, path: str) -> None:
        """Saves the range in use as a text file (an exact round trip); GloveposeError before any range."""
        _check(_lib.glovepose_calibration_save(self._handle, str(path).encode()))

    def load_calibration(self, path: str) -> None:
        """Uses a range file save_calibration wrote for the same glove (source USER)."""
        _check(_lib.glovepose_calibration_load(self._handle, str(path).encode()))

    def close(self) -> None:
        if getattr(self, "_handle", None):  # also when __init__ stopped before creating it
            _lib.glovepose_estimator_free(self._handle)
            self._handle = ctypes.c_void_p()


class LatestHand:
    """One hand published to a Latest: number (1 for the first publish, counting up), pose (the
    estimator's Pose then) and joints ((21, 7) as Estimator.joints(); rest values when the
    estimator has no joint_transforms)."""

    def __init__(self, number: int, pose: Pose, joints: np.ndarray):
        self.number, self.pose, self.joints = number, pose, joints


class Latest(_Closing):
    """The newest hand of one estimator for any number of reader threads (glovepose_latest): the
    estimator's thread publish()es after each push that returned SOLVED; readers on other threads
    read() it or locate its OpenXR joints, never blocking the writer and never seeing a torn hand
    (the library's calls run without the GIL, so Python threads really do run side by side).
    close() it after every thread has stopped using it."""

    def __init__(self):
        self._handle = ctypes.c_void_p()
        _check(_lib.glovepose_latest_create(ctypes.byref(self._handle)))

    def publish(self, estimator: Estimator) -> None:
        """Writer (the estimator's thread, one writer): makes the estimator's current pose, joint
        list, rate and pinch and aim state the newest."""
        _check(_lib.glovepose_latest_publish(self._handle, estimator._handle))

    def read(self) -> LatestHand | None:
        """Reader, any thread: the newest published hand, None before the first publish."""
        pose, joints, number = _new(_library.Pose), (_library.Joint * _library.JOINT_COUNT)(), ctypes.c_uint64()
        _check(_lib.glovepose_latest_read(self._handle, ctypes.byref(pose), joints, _library.JOINT_COUNT, ctypes.byref(number)))
        return LatestHand(number.value, Pose(pose), _joint_array(joints)) if number.value else None

    def xr_joints(self, estimator: Estimator, time: float) -> XrHand:
        """Reader, any thread: OpenXR's 26 joints at `time` (s, the stream's clock), predicted from
        the newest published hand with `estimator`'s hand model, side and max_prediction (only its
        immutable parts are read: its own thread may stream meanwhile). As Estimator.xr_joints:
        active False before the first publish, InputError for a non-finite time."""
        out = _new(_library.XrHand)
        _status(_lib.glovepose_latest_get_xr_joints(self._handle, estimator._handle, time, ctypes.byref(out)), "xr_joints", time,
                not_ready_ok=True)
        return XrHand(out)

    def xr_aim(self) -> XrAim:
        """Reader, any thread: the pinch and aim state published with the newest pose (as
        Estimator.xr_aim, with that pose's sequence); active False before the first publish."""
        out, sequence = _aim_state(), ctypes.c_uint64()
        code = _check(_lib.glovepose_latest_get_xr_aim(self._handle, ctypes.byref(out), ctypes.byref(sequence)))
        return XrAim(out, active=code == Status.OK, sequence=sequence.value)

    def close(self) -> None:
        if getattr(self, "_handle", None):
            _lib.glovepose_latest_free(self._handle)
            self._handle = ctypes.c_void_p()


def row_time(cycle_end: float, row: int, rows: int, cycle_rate: float) -> float:
    """When row `row` of a readout cycle that ends at `cycle_end` (s) was read, `rows` rows per cycle at
    `cycle_rate` cycles/s: each row completes at the end of its slot (glovepose_row_time). Timestamps
    for Estimator.push_row when the firmware stamps whole cycles only. Raises ValueError when invalid."""
    t = _lib.glovepose_row_time(float(cycle_end), int(row), int(rows), float(cycle_rate))
    if math.isnan(t):
        raise ValueError(f"row {row} of {rows} at {cycle_rate} cycles/s, expected 0 <= row < rows and a positive rate")
    return t


def evaluate(model, data, *, subjects=None, exclude_subjects=None, sessions=None, gloves=None, stride: int = 1,
             calibration_mode: str | None = None, replay_rows: bool = False, mean_window: int | None = None, contact: bool = False,
             threads: int = 0, weights: str = "f32", glove=None) -> dict:
    """Scores model file `model` on dataset file `data` (glovepose simulate or import): the report
    `glovepose eval --json` prints, as a dict (the library's train::evaluate through
    glovepose_evaluate, in libglovepose_eval). The options are eval's: subjects, exclude_subjects,
    sessions, gloves (lists of ids; None: all), stride, calibration_mode ("none", "training",
    "onthefly", "guided", "continuous"; None: the model's), replay_rows with mean_window, contact, threads (0: all
    cores), weights (how the network holds them, as PoseModel's: "f32", "f16", "bf16" or "fixed16";
    the report's "weights") and glove (a glove description file the data was recorded with: refused
    unless it is the model's). Raises GloveposeError with the library's message, OSError when
    libglovepose_eval is not found (naming the places tried)."""
    if weights not in _WEIGHTS:
        raise ValueError(f"weights {weights!r}, expected one of {sorted(_WEIGHTS)}")
    options = {"stride": stride, "replay_rows": replay_rows, "contact": contact, "threads": threads, "weights": weights}
    if glove is not None:
        options["glove"] = str(glove)
    for key, ids in (("subjects", subjects), ("exclude_subjects", exclude_subjects), ("sessions", sessions), ("gloves", gloves)):
        if ids is not None:
            options[key] = [int(i) for i in ids]
    if calibration_mode is not None:
        options["calibration_mode"] = calibration_mode
    if mean_window is not None:
        options["mean_window"] = mean_window
    lib = _eval_library()
    report = ctypes.c_char_p()
    _check(lib.glovepose_evaluate(str(model).encode(), str(data).encode(), json.dumps(options).encode(), ctypes.byref(report)),
           lib.glovepose_eval_last_error)
    return json.loads(report.value.decode())


_eval_lib = None


def _eval_library() -> ctypes.CDLL:
    """libglovepose_eval, loaded at the first evaluate: importing glovepose needs libglovepose_c only.
    Raises OSError naming the places tried."""
    global _eval_lib
    if _eval_lib is None:
        _eval_lib = _library.load_eval(_lib)
    return _eval_lib
