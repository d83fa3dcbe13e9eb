/**
 * @file glovepose_c.h
 * @brief The C ABI of glovepose: a stretch-sensing glove's readings in, 25 hand angles (a 21-joint
 * list, and OpenXR's 26 hand joints) out, for game engines, VR runtimes and any language with a C
 * foreign-function interface (C# P/Invoke, Python ctypes).
 *
 * Pure C (C89 with <stdint.h>, or C99 and later); no C++ types cross it. Two opaque handles:
 * - glovepose_model: a loaded model, immutable, shared by any number of estimators on any threads.
 * - glovepose_estimator: one glove stream (readout ring, calibration, filter, workspace); used by one
 *   thread at a time.
 *
 * Every function returns at once and never lets an exception out. Functions returning
 * glovepose_result answer with a GLOVEPOSE_* code: 0 and positive codes are the per-frame statuses
 * of the C++ API (glovepose::Status, same numbers), negative codes are errors, after which
 * glovepose_last_error() on the same thread says what went wrong. The per-frame functions (push_*,
 * get_*, calibration start / progress / cancel, reset) never allocate.
 *
 * Structs are plain: fixed-size fields of explicit width, doubles, floats, no bitfields, no unions,
 * no implicit padding. Structs that may grow start with `struct_size`, which the caller sets to
 * sizeof the struct it was compiled with (the *_init / *_default functions do that).
 * See capi/README.md for thread safety, ownership and the ABI stability rules.
 *
 * This library holds loading and the per-frame calls only; offline evaluation (a model scored on a
 * dataset file) is glovepose_eval.h's, a library of its own.
 */
#ifndef GLOVEPOSE_C_H
#define GLOVEPOSE_C_H

#include <stddef.h>
#include <stdint.h>

/** @brief Marks a public symbol: exported from the shared library (built with hidden visibility). */
#if defined(_WIN32)
#  if defined(GLOVEPOSE_C_BUILDING)
#    define GLOVEPOSE_C_API __declspec(dllexport)
#  else
#    define GLOVEPOSE_C_API __declspec(dllimport)
#  endif
#elif defined(__GNUC__) || defined(__clang__)
#  define GLOVEPOSE_C_API __attribute__((visibility("default")))
#else
#  define GLOVEPOSE_C_API
#endif

/** @brief In C++ the functions are declared noexcept: none lets an exception out. */
#if defined(__cplusplus)
#  define GLOVEPOSE_C_NOEXCEPT noexcept
#else
#  define GLOVEPOSE_C_NOEXCEPT
#endif

#ifdef __cplusplus
extern "C" {
#endif

/* ---- constants --------------------------------------------------------------------------- */

/** @brief Version of this ABI. Bumped only by incompatible changes (README, "ABI stability"). */
#define GLOVEPOSE_C_ABI_VERSION 1
/** @brief Number of hand angles (degrees of freedom) in a pose. */
#define GLOVEPOSE_DOF_COUNT 25
/** @brief Number of joints in the joint list. */
#define GLOVEPOSE_JOINT_COUNT 21
/** @brief Number of OpenXR hand joints (XR_HAND_JOINT_COUNT_EXT), in XrHandJointEXT order. */
#define GLOVEPOSE_XR_JOINT_COUNT 26

/** @brief Handedness: the glove is on the right hand (the hand model's side). */
#define GLOVEPOSE_HAND_RIGHT 0
/** @brief Handedness: the glove is on the left hand (outputs mirrored; the same model serves). */
#define GLOVEPOSE_HAND_LEFT 1

/** @brief OpenXR location flag bits (the values of XrSpaceLocationFlags). */
#define GLOVEPOSE_XR_ORIENTATION_VALID 0x1u
#define GLOVEPOSE_XR_POSITION_VALID 0x2u
#define GLOVEPOSE_XR_ORIENTATION_TRACKED 0x4u
#define GLOVEPOSE_XR_POSITION_TRACKED 0x8u
/** @brief OpenXR velocity flag bits (the values of XrSpaceVelocityFlags). */
#define GLOVEPOSE_XR_LINEAR_VELOCITY_VALID 0x1u
#define GLOVEPOSE_XR_ANGULAR_VELOCITY_VALID 0x2u
/** @brief XR_FB_hand_tracking_aim: the value of XR_TYPE_HAND_TRACKING_AIM_STATE_FB (glovepose_xr_aim_state::type). */
#define GLOVEPOSE_XR_TYPE_HAND_TRACKING_AIM_STATE_FB 1000111001
/** @brief Aim status bits (the values of XrHandTrackingAimFlagsFB). COMPUTED, SYSTEM_GESTURE,
 * DOMINANT_HAND and MENU_PRESSED are never set by this library. */
#define GLOVEPOSE_XR_AIM_COMPUTED 0x1u
#define GLOVEPOSE_XR_AIM_VALID 0x2u
#define GLOVEPOSE_XR_AIM_INDEX_PINCHING 0x4u
#define GLOVEPOSE_XR_AIM_MIDDLE_PINCHING 0x8u
#define GLOVEPOSE_XR_AIM_RING_PINCHING 0x10u
#define GLOVEPOSE_XR_AIM_LITTLE_PINCHING 0x20u
#define GLOVEPOSE_XR_AIM_SYSTEM_GESTURE 0x40u
#define GLOVEPOSE_XR_AIM_DOMINANT_HAND 0x80u
#define GLOVEPOSE_XR_AIM_MENU_PRESSED 0x100u

/** @brief Result of a call: one of the GLOVEPOSE_* codes below (32-bit on every platform). */
typedef int32_t glovepose_result;

/* Per-frame statuses (>= 0): the numbers of glovepose::Status. */
/** @brief Accepted; nothing new to report. */
#define GLOVEPOSE_OK 0
/** @brief Accepted, and a new pose is available (glovepose_estimator_get_pose). */
#define GLOVEPOSE_SOLVED 1
/** @brief Accepted, but not enough data has arrived yet to produce a result. */
#define GLOVEPOSE_NOT_READY 2
/** @brief Rejected: a value is NaN or infinite. */
#define GLOVEPOSE_NON_FINITE 3
/** @brief Rejected: a capacitance reading below zero. */
#define GLOVEPOSE_NEGATIVE 4
/** @brief Rejected: a row index outside the glove's wiring, or the model knows no wiring. */
#define GLOVEPOSE_UNKNOWN_INDEX 5
/** @brief Rejected: a timestamp earlier than the last accepted one. */
#define GLOVEPOSE_TIMESTAMP_BACKWARDS 6
/** @brief Rejected: a frame with the wrong number of values (or a null array). */
#define GLOVEPOSE_SIZE_MISMATCH 7
/** @brief A frame was solved but no calibration range is set: no pose. */
#define GLOVEPOSE_UNCALIBRATED 8

/* Errors (< 0): glovepose_last_error() holds the message. */
/** @brief An argument is invalid: a null pointer, an index out of range, a bad setting. */
#define GLOVEPOSE_ERROR_INVALID_ARGUMENT (-1)
/** @brief A null handle, or a handle of the other kind, or one already freed. */
#define GLOVEPOSE_ERROR_INVALID_HANDLE (-2)
/** @brief A struct's struct_size is not a size this library knows. */
#define GLOVEPOSE_ERROR_STRUCT_SIZE (-3)
/** @brief A file to read does not exist or cannot be opened. */
#define GLOVEPOSE_ERROR_FILE_NOT_FOUND (-4)
/** @brief A file was read but its contents are malformed or do not fit (model, glove, calibration). */
#define GLOVEPOSE_ERROR_INVALID_FILE (-5)
/** @brief A file could not be written. */
#define GLOVEPOSE_ERROR_IO (-6)
/** @brief The calibration is not in a state that allows the call (e.g. finish before enough frames). */
#define GLOVEPOSE_ERROR_CALIBRATION_STATE (-7)
/** @brief The estimator was created without the feature the call needs (joint transforms). */
#define GLOVEPOSE_ERROR_DISABLED (-8)
/** @brief Memory ran out. */
#define GLOVEPOSE_ERROR_OUT_OF_MEMORY (-9)
/** @brief An unexpected internal failure (a bug: please report the message). */
#define GLOVEPOSE_ERROR_INTERNAL (-10)

/** @brief In-memory weight precision: float32, the file's values exactly. */
#define GLOVEPOSE_WEIGHTS_F32 0
/** @brief In-memory weight precision: binary16, half the bytes; angles differ from F32 by rounding
 * (hundredths of a degree). Fast where the CPU converts binary16 (AVX2, AVX-512), slow (widened
 * in software) on SSE2-only x86-64 and ARM64: GLOVEPOSE_WEIGHTS_REALTIME chooses per CPU. */
#define GLOVEPOSE_WEIGHTS_F16 1
/** @brief In-memory weight precision: bfloat16, half the bytes and the fastest at batch 1; its
 * rounding moves angles by up to about 0.4 degree on the shipped model (F16: 0.03 degree). */
#define GLOVEPOSE_WEIGHTS_BF16 2
/** @brief In-memory weight precision: 16-bit codes with one scale per output channel (Fixed16):
 * half the bytes; angles within 0.005 degree of F32 on the shipped model (README, "Figures"). */
#define GLOVEPOSE_WEIGHTS_FIXED16 3
/** @brief The real-time choice: the fastest precision within 0.1 degree of F32 for the instruction
 * set this process runs (glovepose_isa()): F16 with AVX2, Fixed16 with AVX-512 and NEON, F32 with
 * SSE2 (measured: docs/performance.md). */
#define GLOVEPOSE_WEIGHTS_REALTIME 4

/** @brief Where the calibration range in use comes from: none yet (no pose can be computed). */
#define GLOVEPOSE_CALIBRATION_NONE 0
/** @brief From this user's on-the-fly calibration (start ... finish). */
#define GLOVEPOSE_CALIBRATION_ON_THE_FLY 1
/** @brief Set or loaded by the caller (e.g. a saved user calibration). */
#define GLOVEPOSE_CALIBRATION_USER 2
/** @brief The model's training-set range (expect larger errors than with the user's own). */
#define GLOVEPOSE_CALIBRATION_TRAINING 3
/** @brief Kept from the wearer's free motion by the model's range map: no calibration step (what
 * a new estimator uses when the model carries a range map, until a range is set or loaded). */
#define GLOVEPOSE_CALIBRATION_CONTINUOUS 4

/** @brief Pose flag: readings were rejected since the previous pose (their rows kept older values). */
#define GLOVEPOSE_POSE_READINGS_REJECTED 0x1u
/** @brief Pose flag: a calibrated cell lay beyond the clamp limit (stretched beyond the range, or a glitch). */
#define GLOVEPOSE_POSE_INPUT_CLAMPED 0x2u
/** @brief Pose flag: normalised with the model's training-set range, not the user's own. */
#define GLOVEPOSE_POSE_TRAINING_CALIBRATION 0x4u
/** @brief Pose flag: produced while an on-the-fly calibration was collecting. */
#define GLOVEPOSE_POSE_CALIBRATING 0x8u
/** @brief Pose flag (fault): some rows stopped arriving; their newest reading is several cycles old. */
#define GLOVEPOSE_POSE_STALE_READINGS 0x10u
/** @brief Pose flag (fault): some rows hold fewer readings than the mean window (start, gap, clock restart). */
#define GLOVEPOSE_POSE_RECOVERING 0x20u
/** @brief Pose flag (fault): a row repeats one value: a stuck sensor. */
#define GLOVEPOSE_POSE_STUCK_ROWS 0x40u
/** @brief Pose flag (fault): rows read (near) zero (a disconnected trace) and the solve could not leave them out. */
#define GLOVEPOSE_POSE_DISCONNECTED_ROWS 0x80u
/** @brief Pose flag (fault): a row disagrees with the least-squares solve: a spike or a failing cell. */
#define GLOVEPOSE_POSE_OUTLIER_ROWS 0x100u
/** @brief Pose flag: cells stopped being measured (a torn trace) and were stood in for from the others; not a fault. */
#define GLOVEPOSE_POSE_MASKED_CELLS 0x200u
/** @brief Pose flag (fault): the cells look like the glove lying off the hand; no hand to estimate. */
#define GLOVEPOSE_POSE_GLOVE_OFF 0x400u
/** @brief The fault flags: a pose with any of them set cannot be trusted. */
#define GLOVEPOSE_POSE_FAULT_FLAGS 0x5F0u

/* ---- handles and structs ----------------------------------------------------------------- */

/** @brief A loaded model (opaque). Immutable; thread-safe to share. */
typedef struct glovepose_model glovepose_model;
/** @brief One glove stream (opaque). One thread at a time. */
typedef struct glovepose_estimator glovepose_estimator;
/** @brief The newest hand of one estimator for any number of reader threads (opaque): the
 * estimator's thread publishes, an engine's update and render threads read. */
typedef struct glovepose_latest glovepose_latest;

/** @brief Settings of an estimator. Fill with glovepose_estimator_config_default(), then change fields. */
typedef struct glovepose_estimator_config {
  uint32_t struct_size;                  /**< sizeof(glovepose_estimator_config) (80 in ABI 1). */
  int32_t readout_mean_window;           /**< Readings per row averaged before a solve (default 1; the paper: 5). */
  int32_t readout_solve_every;           /**< Solve after this many accepted row readings (default 16; 180 = once per cycle). */
  int32_t calibration_median_window;     /**< Frames of the on-the-fly calibration's median; 0 (default): the glove's
                                              median_seconds over the period frames are taken (20 for the built-in glove). */
  double calibration_sample_period;      /**< Stream time between two frames the calibration takes, s (default 1/60;
                                              longer when the glove description gives a slower rate_hz). */
  double calibration_min_relative_range; /**< A cell whose range is below this fraction of its value is flat;
                                              negative (default -1): the glove's (0.01 unless its description says otherwise). */
  double calibration_clamp_limit;        /**< Normalised cells are clamped to +-this (default 1.5). */
  int32_t smoothing;                     /**< 1: 1-euro smoothing of the angles; 0: the network's output (default 0). */
  int32_t joint_transforms;              /**< 1: compute the 21-joint list with every pose (default 0). */
  double smoothing_frequency;            /**< 1-euro: initial sampling rate, Hz (default 60). */
  double smoothing_min_cutoff;           /**< 1-euro: cutoff at rest, Hz (default 1). */
  double smoothing_beta;                 /**< 1-euro: speed coefficient (default 0). */
  double smoothing_d_cutoff;             /**< 1-euro: cutoff of the derivative's low-pass, Hz (default 1). */
} glovepose_estimator_config;

/** @brief The hand an estimator serves and how it predicts ahead (glovepose_estimator_create_for_hand).
 * Fill with glovepose_hand_options_default(), then change fields. */
typedef struct glovepose_hand_options {
  uint32_t struct_size;     /**< sizeof(glovepose_hand_options) (24 in ABI 1). */
  int32_t handedness;       /**< GLOVEPOSE_HAND_RIGHT (default) or GLOVEPOSE_HAND_LEFT. */
  double prediction_window; /**< Seconds of recent poses whose slope predicts ahead (default 0.15). */
  double max_prediction;    /**< How far past the newest pose poses are predicted, s (default 0.05). */
} glovepose_hand_options;

/** @brief One estimated hand pose. Set struct_size (glovepose_pose_init) before asking for one. */
typedef struct glovepose_pose {
  uint32_t struct_size;                   /**< sizeof(glovepose_pose) (448 in ABI 1); set by the caller. */
  uint32_t flags;                         /**< GLOVEPOSE_POSE_* bits; 0: nothing to distrust. */
  double angles[GLOVEPOSE_DOF_COUNT];     /**< Radians, glovepose_dof_name() order; smoothed when smoothing is on. */
  double raw_angles[GLOVEPOSE_DOF_COUNT]; /**< The network's angles before smoothing. */
  double timestamp;                       /**< Timestamp of the newest reading behind the pose (the stream's clock, s). */
  double oldest_age;                      /**< timestamp minus the timestamp of the oldest reading behind it, s. */
  double compute_seconds;                 /**< Wall time the estimator spent on this pose, s. */
  uint64_t sequence;                      /**< Poses produced so far, this one included. */
  uint32_t rejected;                      /**< Readings rejected since the previous pose. */
  int32_t valid;                          /**< 0 until the first pose, then 1. */
} glovepose_pose;

/** @brief One joint of the joint list: position and orientation in the hand's root frame
 * (right-handed, metres; fingers along +Y at rest, palm facing -Z; include/glovepose/hand/joint_list.hpp). */
typedef struct glovepose_joint {
  float position[3]; /**< Metres: x, y, z. */
  float rotation[4]; /**< Unit quaternion: x, y, z, w. */
} glovepose_joint;

/** @brief One OpenXR hand joint, laid out as XrHandJointLocationEXT (copy it as it is): pose in the
 * wrist joint's frame (metres, right-handed, +Z along the bone away from the tip, +Y out of the
 * back of the hand; include/glovepose/hand/openxr_joints.hpp). An array element: never changes. */
typedef struct glovepose_xr_joint_location {
  uint64_t location_flags; /**< GLOVEPOSE_XR_ORIENTATION_* / POSITION_* bits. */
  float orientation[4];    /**< Unit quaternion x, y, z, w (XrQuaternionf). */
  float position[3];       /**< Metres (XrVector3f). */
  float radius;            /**< Metres. */
} glovepose_xr_joint_location;

/** @brief One OpenXR joint velocity, laid out as XrHandJointVelocityEXT (wrist frame). An array
 * element: never changes. */
typedef struct glovepose_xr_joint_velocity {
  uint64_t velocity_flags;   /**< GLOVEPOSE_XR_*_VELOCITY_VALID bits. */
  float linear_velocity[3];  /**< m/s. */
  float angular_velocity[3]; /**< rad/s, axis times rate. */
} glovepose_xr_joint_velocity;

/** @brief XR_HAND_TRACKING_DATA_SOURCE_UNOBSTRUCTED_EXT: the joints measured on the hand itself (a
 * data glove), glovepose_xr_hand::data_source. */
#define GLOVEPOSE_XR_DATA_SOURCE_UNOBSTRUCTED 1

/** @brief One hand's OpenXR joints at one time. Set struct_size (glovepose_xr_hand_init) first.
 * A joint's location_flags carry the TRACKED bits when the newest pose is trusted, the time is
 * within max_prediction and the joint's confidence (the product of its digit's DoF confidences up
 * to it, glovepose_estimator_get_confidence) is at least 0.5; the VALID bits whenever active. */
typedef struct glovepose_xr_hand {
  uint32_t struct_size; /**< sizeof(glovepose_xr_hand) (1912 in ABI 1); set by the caller. */
  int32_t active;       /**< 1 when a pose exists (XrHandJointLocationsEXT::isActive). */
  int32_t predicted;    /**< 1 when extrapolated past the newest pose. */
  int32_t clamped;      /**< 1 when asked further ahead than max_prediction: located at the bound. */
  int32_t handedness;   /**< GLOVEPOSE_HAND_*. */
  int32_t data_source;  /**< XR_EXT_hand_tracking_data_source's XrHandTrackingDataSourceEXT: GLOVEPOSE_XR_DATA_SOURCE_UNOBSTRUCTED. */
  double time;          /**< The time located (the glove stream's clock, s). */
  double horizon;       /**< time minus the newest pose's timestamp, s (> 0 predicted). */
  glovepose_xr_joint_location locations[GLOVEPOSE_XR_JOINT_COUNT]; /**< XrHandJointEXT order. */
  glovepose_xr_joint_velocity velocities[GLOVEPOSE_XR_JOINT_COUNT];
} glovepose_xr_hand;

/** @brief One hand's pinch and aim state, laid out as XR_FB_hand_tracking_aim's
 * XrHandTrackingAimStateFB (same fields, order, sizes and offsets, its padding included: 4 bytes
 * after `type` and at the end where pointers are 8 bytes: 72 bytes), so an OpenXR layer can pass the
 * application's struct itself. Never changes: its `type` is its version. Set type (and next) with
 * glovepose_xr_aim_state_init; the library fills the rest and leaves type and next alone.
 * - status: GLOVEPOSE_XR_AIM_* bits: VALID when a pose exists and has no fault flag;
 *   *_PINCHING per finger when the thumb tip and that fingertip came closer than 15 mm and have
 *   not parted beyond 18 mm since (hysteresis kept from pose to pose by the estimator).
 * - aim pose: in the wrist joint's frame like the XR joints (metres): the index finger's proximal
 *   joint at the rest pose (index straight), -Z along the straight index, +Y the back of the hand;
 *   fixed in that frame (a pinch does not move it). Compose it with the wrist pose the engine's
 *   tracker reports: world_from_aim = world_from_wrist * aim.
 * - pinch strengths: 1 at or below 15 mm between thumb tip and fingertip, 0 at or beyond 40 mm,
 *   a smoothstep between (include/glovepose/hand/pinch.hpp says why). */
typedef struct glovepose_xr_aim_state {
  int32_t type;                /**< GLOVEPOSE_XR_TYPE_HAND_TRACKING_AIM_STATE_FB (XrStructureType); the caller's. */
  void* next;                  /**< NULL or the caller's chain; never read or written by the library. */
  uint64_t status;             /**< GLOVEPOSE_XR_AIM_* bits (XrHandTrackingAimFlagsFB). */
  float aim_orientation[4];    /**< Unit quaternion x, y, z, w (XrPosef::orientation), wrist frame. */
  float aim_position[3];       /**< Metres (XrPosef::position), wrist frame. */
  float pinch_strength_index;  /**< [0, 1]: 1 when thumb and index touch. */
  float pinch_strength_middle; /**< [0, 1]. */
  float pinch_strength_ring;   /**< [0, 1]. */
  float pinch_strength_little; /**< [0, 1]. */
} glovepose_xr_aim_state;

/** @brief The hand at a requested time (glovepose_estimator_get_pose_at). */
typedef struct glovepose_predicted_pose {
  uint32_t struct_size;               /**< sizeof(glovepose_predicted_pose) (440 in ABI 1); set by the caller. */
  uint32_t flags;                     /**< The newest pose's GLOVEPOSE_POSE_* bits. */
  double angles[GLOVEPOSE_DOF_COUNT]; /**< Radians, within the joint limits. */
  double rate[GLOVEPOSE_DOF_COUNT];   /**< Rate of change, rad/s (the recent poses' slope). */
  double time;                        /**< The time asked for (the stream's clock, s). */
  double horizon;                     /**< Time located minus the newest pose's timestamp, s. */
  int32_t predicted;                  /**< 1 when extrapolated past the newest pose. */
  int32_t clamped;                    /**< 1 when asked further ahead than max_prediction. */
  int32_t has_rate;                   /**< 1 when rate comes from at least two poses. */
  int32_t trusted;                    /**< 1 when the newest pose has no fault flag. */
} glovepose_predicted_pose;

/** @brief How far an on-the-fly calibration has come, and the range in use. */
typedef struct glovepose_calibration_progress {
  uint32_t struct_size;  /**< sizeof(glovepose_calibration_progress) (32 in ABI 1); set by the caller. */
  int32_t collecting;    /**< 1 between start and finish/cancel. */
  int64_t frames;        /**< Frames taken so far. */
  int32_t frames_needed; /**< Frames before finish can succeed (the median window). */
  int32_t ready;         /**< 1 when finish would succeed now. */
  int32_t source;        /**< GLOVEPOSE_CALIBRATION_* of the range in use. */
  int32_t flat_cells;    /**< Cells of the range in use too flat to normalise by (they read 0); 0 without a range. */
} glovepose_calibration_progress;

/** @brief One step of the model's guided calibration sequence: what to show the user. */
typedef struct glovepose_calibration_step {
  uint32_t struct_size;   /**< sizeof(glovepose_calibration_step) (1184); set by glovepose_calibration_step_init. */
  int32_t step;           /**< Its index, 0-based. */
  int32_t step_count;     /**< Steps in the sequence. */
  float pose[25];         /**< The pose to copy, radians, in glovepose_dof_name order. */
  double start_seconds;   /**< When the step starts, seconds after the sequence's first calibration frame. */
  double seconds;         /**< How long it lasts. */
  char name[32];          /**< Short id, e.g. "flat_on_table"; NUL-terminated, cut to 31 bytes if longer. */
  char instruction[1024]; /**< What to tell the user; NUL-terminated UTF-8, cut at a character to 1023 bytes if longer. */
} glovepose_calibration_step;

/* ---- library ------------------------------------------------------------------------------- */

/** @brief The library version, "major.minor.patch" (static string). */
GLOVEPOSE_C_API const char* glovepose_version(void) GLOVEPOSE_C_NOEXCEPT;
/** @brief The ABI version the library was built with; compare with GLOVEPOSE_C_ABI_VERSION. */
GLOVEPOSE_C_API int32_t glovepose_abi_version(void) GLOVEPOSE_C_NOEXCEPT;
/** @brief The instruction set this process's networks run (static string): "sse2", "avx2" or
 * "avx512" on x86-64, "neon" on ARM64. The library holds its networks once per set and chooses,
 * at the first call of this function or the first model loaded, the best this CPU executes, or the
 * one the environment variable GLOVEPOSE_ISA names (for tests and bug reports). NULL, with the
 * message in glovepose_last_error(), when GLOVEPOSE_ISA names no set or one this CPU does not
 * execute (models then fail to load with the same message). */
GLOVEPOSE_C_API const char* glovepose_isa(void) GLOVEPOSE_C_NOEXCEPT;
/** @brief When row `row` of a readout cycle that ends at `cycle_end` (seconds) was read, for a glove
 * that reads `rows` rows per cycle at `cycle_rate` cycles per second: each row completes at the end
 * of its slot of 1 / (rows * cycle_rate) s, the last one at `cycle_end`. For timestamping rows
 * (glovepose_estimator_push_row) when the firmware stamps only whole cycles. NaN when row is outside
 * 0..rows-1, rows < 1, or cycle_rate is not a positive finite number. */
GLOVEPOSE_C_API double glovepose_row_time(double cycle_end, int32_t row, int32_t rows, double cycle_rate) GLOVEPOSE_C_NOEXCEPT;
/** @brief The message of the last error on the calling thread ("" if none yet). Valid until the
 * next failing call on this thread; copy it to keep it. */
GLOVEPOSE_C_API const char* glovepose_last_error(void) GLOVEPOSE_C_NOEXCEPT;
/** @brief A short, stable name of a result code, e.g. "solved", "file not found" (static string). */
GLOVEPOSE_C_API const char* glovepose_result_name(glovepose_result result) GLOVEPOSE_C_NOEXCEPT;
/** @brief Stable snake_case name of angle `dof` (0..24), e.g. "index_base_flexion"; NULL when out of range. */
GLOVEPOSE_C_API const char* glovepose_dof_name(int32_t dof) GLOVEPOSE_C_NOEXCEPT;
/** @brief Stable name of joint `joint` (0..20), e.g. "middle_tip"; NULL when out of range. */
GLOVEPOSE_C_API const char* glovepose_joint_name(int32_t joint) GLOVEPOSE_C_NOEXCEPT;
/** @brief Parent of joint `joint` in the list (-1 for the palm); -2 when out of range. */
GLOVEPOSE_C_API int32_t glovepose_joint_parent(int32_t joint) GLOVEPOSE_C_NOEXCEPT;
/** @brief Name of OpenXR joint 0..25, e.g. "index_metacarpal" (NULL out of range). */
GLOVEPOSE_C_API const char* glovepose_xr_joint_name(int32_t joint) GLOVEPOSE_C_NOEXCEPT;
/** @brief Parent of OpenXR joint 0..25 (-1 for the wrist, -2 out of range). */
GLOVEPOSE_C_API int32_t glovepose_xr_joint_parent(int32_t joint) GLOVEPOSE_C_NOEXCEPT;

/* ---- model --------------------------------------------------------------------------------- */

/**
 * @brief Loads a model file (weights_format.md) into *out_model.
 * @param model_path path of the .safetensors model file.
 * @param weight_storage GLOVEPOSE_WEIGHTS_F32, _F16, _BF16, _FIXED16 or _REALTIME.
 * @param glove_description_path a glove description JSON file, or NULL for the model's own glove.
 * @param out_model receives the handle (NULL on failure). Free it with glovepose_model_free().
 * @return GLOVEPOSE_OK, or GLOVEPOSE_ERROR_FILE_NOT_FOUND / _INVALID_FILE / _INVALID_ARGUMENT /
 * _OUT_OF_MEMORY with a message naming the file.
 */
GLOVEPOSE_C_API glovepose_result glovepose_model_load(const char* model_path, int32_t weight_storage, const char* glove_description_path,
                                                      glovepose_model** out_model) GLOVEPOSE_C_NOEXCEPT;
/** @brief Releases the caller's reference. Estimators created from the model keep it alive until
 * they are freed. NULL is ignored. */
GLOVEPOSE_C_API void glovepose_model_free(glovepose_model* model) GLOVEPOSE_C_NOEXCEPT;
/** @brief Number of sensor cells of the model's glove (44 for the paper's); -1 for an invalid handle. */
GLOVEPOSE_C_API int32_t glovepose_model_cell_count(const glovepose_model* model) GLOVEPOSE_C_NOEXCEPT;
/** @brief Number of measurement rows of the glove's wiring (180 for the paper's); 0 when the model
 * knows no wiring (then only glovepose_estimator_push_cells works); -1 for an invalid handle. */
GLOVEPOSE_C_API int32_t glovepose_model_row_count(const glovepose_model* model) GLOVEPOSE_C_NOEXCEPT;
/** @brief The glove's id, e.g. "glauser2019-44" (owned by the model); NULL for an invalid handle. */
GLOVEPOSE_C_API const char* glovepose_model_glove_id(const glovepose_model* model) GLOVEPOSE_C_NOEXCEPT;
/** @brief Name of cell `cell` (owned by the model); NULL for an invalid handle or index. */
GLOVEPOSE_C_API const char* glovepose_model_cell_name(const glovepose_model* model, int32_t cell) GLOVEPOSE_C_NOEXCEPT;
/** @brief 1 when the model records its training-set range (glovepose_calibration_use_training
 * works), 0 when not, -1 for an invalid handle. */
GLOVEPOSE_C_API int32_t glovepose_model_has_training_range(const glovepose_model* model) GLOVEPOSE_C_NOEXCEPT;
/** @brief 1 when the model carries a range map (calibration without a calibration step:
 * glovepose_calibration_use_continuous works and new estimators start with it), 0 when not, -1
 * for an invalid handle. */
GLOVEPOSE_C_API int32_t glovepose_model_has_range_map(const glovepose_model* model) GLOVEPOSE_C_NOEXCEPT;
/** @brief 1 when the model carries its own measured errors (the per-DoF confidence then comes from
 * them: glovepose_estimator_get_confidence), 0 when not (the confidence is then 1 for a trusted
 * pose, 0 otherwise), -1 for an invalid handle. */
GLOVEPOSE_C_API int32_t glovepose_model_has_pose_error(const glovepose_model* model) GLOVEPOSE_C_NOEXCEPT;
/** @brief Steps of the model's guided calibration sequence (docs/calibration.md): 0 when the model
 * carries no pose-guided calibration (its calibration is min-max only), -1 for an invalid handle. */
GLOVEPOSE_C_API int32_t glovepose_model_calibration_step_count(const glovepose_model* model) GLOVEPOSE_C_NOEXCEPT;
/** @brief Copies step `step` (0-based) of the model's guided calibration sequence into *out
 * (struct_size set by glovepose_calibration_step_init). @return GLOVEPOSE_OK, _INVALID_HANDLE,
 * _INVALID_ARGUMENT (out NULL, no sequence, step out of range) or _STRUCT_SIZE. */
GLOVEPOSE_C_API glovepose_result glovepose_model_get_calibration_step(const glovepose_model* model, int32_t step,
                                                                      glovepose_calibration_step* out) GLOVEPOSE_C_NOEXCEPT;

/* ---- estimator ----------------------------------------------------------------------------- */

/** @brief Fills *config with the defaults (the paper's settings) and its struct_size.
 * @return GLOVEPOSE_OK, or GLOVEPOSE_ERROR_INVALID_ARGUMENT for NULL. */
GLOVEPOSE_C_API glovepose_result glovepose_estimator_config_default(glovepose_estimator_config* config) GLOVEPOSE_C_NOEXCEPT;
/**
 * @brief Creates an estimator for one glove stream over a shared model.
 * @param model the model (the estimator keeps it alive).
 * @param config settings, or NULL for the defaults.
 * @param out_estimator receives the handle (NULL on failure). Free it with glovepose_estimator_free().
 * @return GLOVEPOSE_OK, or _INVALID_HANDLE / _STRUCT_SIZE / _INVALID_ARGUMENT (bad settings, named
 * in the message) / _OUT_OF_MEMORY.
 */
GLOVEPOSE_C_API glovepose_result glovepose_estimator_create(const glovepose_model* model, const glovepose_estimator_config* config,
                                                            glovepose_estimator** out_estimator) GLOVEPOSE_C_NOEXCEPT;
/** @brief Frees an estimator. NULL is ignored. */
/** @brief Fills *options with the defaults (a right hand) and sets struct_size. */
GLOVEPOSE_C_API glovepose_result glovepose_hand_options_default(glovepose_hand_options* options) GLOVEPOSE_C_NOEXCEPT;
/** @brief glovepose_estimator_create for a given hand: `options` NULL means the defaults (right hand,
 * glovepose_estimator_create's behaviour). A left glove is the right glove's sensor sheet turned
 * over, so the same model serves it and the joints come out mirrored. */
GLOVEPOSE_C_API glovepose_result glovepose_estimator_create_for_hand(const glovepose_model* model, const glovepose_estimator_config* config,
                                                                     const glovepose_hand_options* options,
                                                                     glovepose_estimator** out_estimator) GLOVEPOSE_C_NOEXCEPT;
GLOVEPOSE_C_API void glovepose_estimator_free(glovepose_estimator* estimator) GLOVEPOSE_C_NOEXCEPT;

/**
 * @brief One reading of measurement row `row` (0 .. row_count-1) at `timestamp` (s, increasing).
 * @return GLOVEPOSE_SOLVED when it completed a frame and a new pose is available; GLOVEPOSE_OK or
 * GLOVEPOSE_NOT_READY when accepted without a new pose; GLOVEPOSE_UNCALIBRATED when a frame was
 * solved without a calibration range; a rejection status (3..7); _INVALID_HANDLE.
 */
GLOVEPOSE_C_API glovepose_result glovepose_estimator_push_row(glovepose_estimator* estimator, int32_t row, double value,
                                                              double timestamp) GLOVEPOSE_C_NOEXCEPT;
/** @brief A whole frame of `count` (= row_count) compound measurements at `timestamp`, solved at
 * once; bad rows are skipped and counted. Returns as glovepose_estimator_push_row. */
GLOVEPOSE_C_API glovepose_result glovepose_estimator_push_measurements(glovepose_estimator* estimator, const double* values, int32_t count,
                                                                       double timestamp) GLOVEPOSE_C_NOEXCEPT;
/** @brief A frame of `count` (= cell_count) already solved cell capacitances at `timestamp`;
 * `oldest_age` is the age of its oldest reading (0 if unknown). Returns as glovepose_estimator_push_row. */
GLOVEPOSE_C_API glovepose_result glovepose_estimator_push_cells(glovepose_estimator* estimator, const double* cells, int32_t count,
                                                                double timestamp, double oldest_age) GLOVEPOSE_C_NOEXCEPT;
/** @brief Copies the latest pose into *out (out->valid is 0 before the first pose).
 * @return GLOVEPOSE_OK, _INVALID_HANDLE, _INVALID_ARGUMENT (NULL out) or _STRUCT_SIZE. */
GLOVEPOSE_C_API glovepose_result glovepose_estimator_get_pose(const glovepose_estimator* estimator,
                                                              glovepose_pose* out) GLOVEPOSE_C_NOEXCEPT;
/** @brief The latest pose's per-DoF confidence into out[0..count) (glovepose_dof_name() order), 0..1:
 * the probability that the angle is within 10 degrees of the truth, from the model's own errors
 * measured on new people under the calibration in use, the DoF's speed and the cells stood in for
 * (include/glovepose/model/pose_error.hpp); 0 for every DoF of a pose with a fault flag; zeros
 * before the first pose. `count` must be GLOVEPOSE_DOF_COUNT. Per-frame: never allocates.
 * @return GLOVEPOSE_OK, _INVALID_HANDLE, _INVALID_ARGUMENT (NULL out) or GLOVEPOSE_SIZE_MISMATCH. */
GLOVEPOSE_C_API glovepose_result glovepose_estimator_get_confidence(const glovepose_estimator* estimator, double* out,
                                                                    int32_t count) GLOVEPOSE_C_NOEXCEPT;
/** @brief Copies the latest joint list into out[0..count-1]; `count` must be GLOVEPOSE_JOINT_COUNT.
 * @return GLOVEPOSE_OK, _INVALID_HANDLE, _INVALID_ARGUMENT (NULL out), GLOVEPOSE_SIZE_MISMATCH
 * (wrong count) or _DISABLED (joint_transforms was off in the config). */
GLOVEPOSE_C_API glovepose_result glovepose_estimator_get_joints(const glovepose_estimator* estimator, glovepose_joint* out,
                                                                int32_t count) GLOVEPOSE_C_NOEXCEPT;
/** @brief Copies the latest solved cell capacitances (pF, the network's input before calibration)
 * into out[0..count-1]; `count` must be the model's cell count.
 * @return GLOVEPOSE_OK, _INVALID_HANDLE, _INVALID_ARGUMENT (NULL out) or GLOVEPOSE_SIZE_MISMATCH. */
/** @brief The pose at `time` (the stream's clock): interpolated between recent poses, or
 * extrapolated along their slope for at most max_prediction seconds. GLOVEPOSE_NOT_READY before
 * the first pose, GLOVEPOSE_NON_FINITE for a non-finite time. Per-frame: never allocates. */
GLOVEPOSE_C_API glovepose_result glovepose_estimator_get_pose_at(const glovepose_estimator* estimator, double time,
                                                                 glovepose_predicted_pose* out) GLOVEPOSE_C_NOEXCEPT;
/** @brief The 26 OpenXR joints at `time` with velocities (from the pose at that time).
 * GLOVEPOSE_NOT_READY (out->active = 0) before the first pose. Per-frame: never allocates. */
GLOVEPOSE_C_API glovepose_result glovepose_estimator_get_xr_joints(const glovepose_estimator* estimator, double time,
                                                                   glovepose_xr_hand* out) GLOVEPOSE_C_NOEXCEPT;
/** @brief The latest frame's cells before calibration into out[0..count): the solved capacitances,
 * each input the glove description conditions (demean_seconds) less its rolling mean, as training
 * saw them; zeros before the first frame. count must be the model's cell count. Per-frame: never
 * allocates.
 * @return GLOVEPOSE_OK, _INVALID_HANDLE, _INVALID_ARGUMENT (NULL out) or GLOVEPOSE_SIZE_MISMATCH. */
GLOVEPOSE_C_API glovepose_result glovepose_estimator_get_cells(const glovepose_estimator* estimator, double* out,
                                                               int32_t count) GLOVEPOSE_C_NOEXCEPT;
/** @brief The pinch and aim state of the latest pose (XR_FB_hand_tracking_aim; see
 * glovepose_xr_aim_state) into *out, whose type must be GLOVEPOSE_XR_TYPE_HAND_TRACKING_AIM_STATE_FB
 * (glovepose_xr_aim_state_init). GLOVEPOSE_NOT_READY before the first pose (out->status 0, strengths
 * 0, the aim pose filled). Per-frame: never allocates.
 * @return GLOVEPOSE_OK, GLOVEPOSE_NOT_READY, _INVALID_HANDLE, _INVALID_ARGUMENT (NULL out) or
 * _STRUCT_SIZE (another type). */
GLOVEPOSE_C_API glovepose_result glovepose_estimator_get_xr_aim(const glovepose_estimator* estimator,
                                                                glovepose_xr_aim_state* out) GLOVEPOSE_C_NOEXCEPT;
/** @brief Forgets the stream (readings, filter, timestamps), e.g. after the glove was unplugged;
 * keeps the calibration and the last pose. @return GLOVEPOSE_OK or _INVALID_HANDLE. */
GLOVEPOSE_C_API glovepose_result glovepose_estimator_reset(glovepose_estimator* estimator) GLOVEPOSE_C_NOEXCEPT;

/* ---- the latest hand, for other threads ------------------------------------------------------ */

/** @brief Creates an empty snapshot (set-up: allocates). Free it with glovepose_latest_free after
 * every thread has stopped using it. @return GLOVEPOSE_OK or _INVALID_ARGUMENT (NULL out). */
GLOVEPOSE_C_API glovepose_result glovepose_latest_create(glovepose_latest** out_latest) GLOVEPOSE_C_NOEXCEPT;
/** @brief Frees a snapshot (NULL is ignored). */
GLOVEPOSE_C_API void glovepose_latest_free(glovepose_latest* latest) GLOVEPOSE_C_NOEXCEPT;
/** @brief Writer, on the estimator's thread (one writer per snapshot): makes the estimator's current
 * pose, joint list and pinch and aim state (glovepose_latest_get_xr_aim) the newest. Per-frame: wait-free, allocation-free; call it after a
 * push that returned GLOVEPOSE_SOLVED. @return GLOVEPOSE_OK or _INVALID_HANDLE. */
GLOVEPOSE_C_API glovepose_result glovepose_latest_publish(glovepose_latest* latest,
                                                          const glovepose_estimator* estimator) GLOVEPOSE_C_NOEXCEPT;
/** @brief Reader, any thread, any number of them: copies the newest published pose into *pose and
 * its joint list into joints[0..joint_count-1] (either may be NULL; joint_count must then be 0, else
 * GLOVEPOSE_JOINT_COUNT; without joint transforms in the estimator, rest values), and its number
 * (1 for the first publish; 0: nothing published yet, outputs untouched) into *number if not NULL.
 * Never blocks the writer, never returns a torn pose, allocation-free.
 * @return GLOVEPOSE_OK, _INVALID_HANDLE, _STRUCT_SIZE (pose->struct_size) or GLOVEPOSE_SIZE_MISMATCH. */
GLOVEPOSE_C_API glovepose_result glovepose_latest_read(const glovepose_latest* latest, glovepose_pose* pose, glovepose_joint* joints,
                                                       int32_t joint_count, uint64_t* number) GLOVEPOSE_C_NOEXCEPT;

/* ---- calibration --------------------------------------------------------------------------- */

/** @brief Starts (or restarts) an on-the-fly calibration: solved frames now also feed the per-cell
 * range. Poses keep coming from the previous range, if any, flagged GLOVEPOSE_POSE_CALIBRATING.
 * @return GLOVEPOSE_OK or _INVALID_HANDLE. */
GLOVEPOSE_C_API glovepose_result glovepose_calibration_start(glovepose_estimator* estimator) GLOVEPOSE_C_NOEXCEPT;
/** @brief How far the calibration has come, and the range in use.
 * @return GLOVEPOSE_OK, _INVALID_HANDLE, _INVALID_ARGUMENT (NULL out) or _STRUCT_SIZE. */
GLOVEPOSE_C_API glovepose_result glovepose_calibration_get_progress(const glovepose_estimator* estimator,
                                                                    glovepose_calibration_progress* out) GLOVEPOSE_C_NOEXCEPT;
/** @brief The guided step under way during a calibration: *step is its index (see
 * glovepose_model_get_calibration_step), -1 before the first frame, after the last step, when no
 * calibration is collecting or the model has no sequence; *sequence_seconds is the stream time
 * since the sequence's first frame (0 before it). Either pointer may be NULL. Never allocates.
 * @return GLOVEPOSE_OK or _INVALID_HANDLE. */
GLOVEPOSE_C_API glovepose_result glovepose_calibration_get_step(const glovepose_estimator* estimator, int32_t* step,
                                                                double* sequence_seconds) GLOVEPOSE_C_NOEXCEPT;
/** @brief Ends the calibration and uses its range (set-up: allocates).
 * @return GLOVEPOSE_OK, or _CALIBRATION_STATE (none running, or fewer frames than the median window
 * so far: it keeps collecting), _INVALID_HANDLE, _OUT_OF_MEMORY. */
GLOVEPOSE_C_API glovepose_result glovepose_calibration_finish(glovepose_estimator* estimator) GLOVEPOSE_C_NOEXCEPT;
/** @brief Stops collecting and keeps the previous range. @return GLOVEPOSE_OK or _INVALID_HANDLE. */
GLOVEPOSE_C_API glovepose_result glovepose_calibration_cancel(glovepose_estimator* estimator) GLOVEPOSE_C_NOEXCEPT;
/** @brief Uses a range file written by glovepose_calibration_save() for the same glove.
 * @return GLOVEPOSE_OK, _FILE_NOT_FOUND, _INVALID_FILE (names the line), _INVALID_ARGUMENT, _INVALID_HANDLE. */
GLOVEPOSE_C_API glovepose_result glovepose_calibration_load(glovepose_estimator* estimator, const char* path) GLOVEPOSE_C_NOEXCEPT;
/** @brief Saves the range in use as a text file (exact round trip).
 * @return GLOVEPOSE_OK, _CALIBRATION_STATE (no range yet), _IO, _INVALID_ARGUMENT, _INVALID_HANDLE. */
GLOVEPOSE_C_API glovepose_result glovepose_calibration_save(const glovepose_estimator* estimator, const char* path) GLOVEPOSE_C_NOEXCEPT;
/** @brief Uses the model's training-set range (the paper's "without calibration").
 * @return GLOVEPOSE_OK, _CALIBRATION_STATE (the model records none), _INVALID_HANDLE. */
GLOVEPOSE_C_API glovepose_result glovepose_calibration_use_training(glovepose_estimator* estimator) GLOVEPOSE_C_NOEXCEPT;
/** @brief Calibrates from the wearer's free motion from now on: the model's prior range at once,
 * refined as the wearer moves (GLOVEPOSE_CALIBRATION_CONTINUOUS).
 * @return GLOVEPOSE_OK, _CALIBRATION_STATE (the model carries no range map), _INVALID_HANDLE. */
GLOVEPOSE_C_API glovepose_result glovepose_calibration_use_continuous(glovepose_estimator* estimator) GLOVEPOSE_C_NOEXCEPT;
/** @brief Forgets the calibration in use: no pose (GLOVEPOSE_UNCALIBRATED) until a calibration
 * finishes or a range is set or loaded (GLOVEPOSE_CALIBRATION_NONE), for an application that wants
 * poses only after its own calibration step. @return GLOVEPOSE_OK, _INVALID_HANDLE. */
GLOVEPOSE_C_API glovepose_result glovepose_calibration_clear(glovepose_estimator* estimator) GLOVEPOSE_C_NOEXCEPT;
/** @brief Uses the range min[i] .. max[i] of each of the `count` (= cell_count) cells.
 * @return GLOVEPOSE_OK, GLOVEPOSE_SIZE_MISMATCH, _INVALID_ARGUMENT (NULL array, non-finite or
 * min > max, named in the message), _INVALID_HANDLE. */
GLOVEPOSE_C_API glovepose_result glovepose_calibration_set_range(glovepose_estimator* estimator, const double* min, const double* max,
                                                                 int32_t count) GLOVEPOSE_C_NOEXCEPT;
/** @brief Copies the range in use into min/max[0..count-1] (count = cell_count).
 * @return GLOVEPOSE_OK, GLOVEPOSE_UNCALIBRATED (no range yet), GLOVEPOSE_SIZE_MISMATCH,
 * _INVALID_ARGUMENT (NULL array), _INVALID_HANDLE. */
GLOVEPOSE_C_API glovepose_result glovepose_calibration_get_range(const glovepose_estimator* estimator, double* min, double* max,
                                                                 int32_t count) GLOVEPOSE_C_NOEXCEPT;

/** @brief A reader thread's OpenXR joints at `time`, predicted from the newest published hand with
 * the hand model, side and prediction bound of `estimator` (only its immutable parts are read, so
 * any thread may call this while the estimator's own thread streams). GLOVEPOSE_NOT_READY
 * (out->active = 0) before the first published pose. Never allocates; never blocks the writer. */
GLOVEPOSE_C_API glovepose_result glovepose_latest_get_xr_joints(const glovepose_latest* latest, const glovepose_estimator* estimator,
                                                                double time, glovepose_xr_hand* out) GLOVEPOSE_C_NOEXCEPT;
/** @brief A reader thread's pinch and aim state: the one glovepose_latest_publish published with
 * the newest pose (the pinch flags' hysteresis is the estimator's), into *out as
 * glovepose_estimator_get_xr_aim, and that pose's sequence (0: nothing published yet) into
 * *sequence if not NULL. GLOVEPOSE_NOT_READY before the first published pose. Never allocates;
 * never blocks the writer. */
GLOVEPOSE_C_API glovepose_result glovepose_latest_get_xr_aim(const glovepose_latest* latest, glovepose_xr_aim_state* out,
                                                             uint64_t* sequence) GLOVEPOSE_C_NOEXCEPT;

/* ---- struct helpers ------------------------------------------------------------------------ */

/** @brief Zeroes *pose and sets its struct_size (call once before glovepose_estimator_get_pose). */
GLOVEPOSE_C_API void glovepose_pose_init(glovepose_pose* pose) GLOVEPOSE_C_NOEXCEPT;
/** @brief Zeroes *progress and sets its struct_size. */
GLOVEPOSE_C_API void glovepose_calibration_progress_init(glovepose_calibration_progress* progress) GLOVEPOSE_C_NOEXCEPT;
/** @brief Zeroes *step and sets its struct_size. */
GLOVEPOSE_C_API void glovepose_calibration_step_init(glovepose_calibration_step* step) GLOVEPOSE_C_NOEXCEPT;
/** @brief Zeroes *hand and sets its struct_size. */
GLOVEPOSE_C_API void glovepose_xr_hand_init(glovepose_xr_hand* hand) GLOVEPOSE_C_NOEXCEPT;
/** @brief Zeroes *pose and sets its struct_size. */
GLOVEPOSE_C_API void glovepose_predicted_pose_init(glovepose_predicted_pose* pose) GLOVEPOSE_C_NOEXCEPT;
/** @brief Zeroes *state and sets its type to GLOVEPOSE_XR_TYPE_HAND_TRACKING_AIM_STATE_FB (next NULL). */
GLOVEPOSE_C_API void glovepose_xr_aim_state_init(glovepose_xr_aim_state* state) GLOVEPOSE_C_NOEXCEPT;

#ifdef __cplusplus
} /* extern "C" */
#endif

#endif /* GLOVEPOSE_C_H */
