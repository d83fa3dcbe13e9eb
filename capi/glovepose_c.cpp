// The C ABI over glovepose::GlovePoseEstimator (glovepose_c.h). Every entry point catches every
// exception; set-up calls report through the thread-local last-error buffer, per-frame calls only
// copy (no allocation, no string building: errors there copy a literal into the buffer).
#define GLOVEPOSE_C_BUILDING
#include "glovepose_c.h"

#include "last_error.hpp"

// Loading and the per-frame calls only: no train/ or sim/ header (offline evaluation is
// glovepose_eval's; the capi_training_isolation test checks the includes and the symbols).
#include <glovepose/calibration/free_motion.hpp>  // PoseModel::range_map()
#include <glovepose/estimator.hpp>
#include <glovepose/hand/contact.hpp>
#include <glovepose/hand/xr_hand.hpp>
#include <glovepose/io/dataset.hpp>  // io::RowClock (glovepose_row_time)
#include <glovepose/model/pose_error.hpp>  // PoseModel::pose_error()
#include <glovepose/model/pose_network.hpp>
#include <glovepose/pose_model_options.hpp>
#include <glovepose/pose_prediction.hpp>
#include <glovepose/sensor/calibration.hpp>
#include <glovepose/sensor/solver.hpp>

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstring>
#include <memory>
#include <new>
#include <string>
#include <utility>

// Handles carry a tag so that a model passed where an estimator is expected (both are plain
// pointers in C# and ctypes), or a freed handle, is usually refused instead of misread.
namespace {
constexpr std::uint32_t kModelTag = 0x4d4f444cu;      // "MODL"
constexpr std::uint32_t kEstimatorTag = 0x45535449u;  // "ESTI"
constexpr std::uint32_t kLatestTag = 0x4c415453u;     // "LATS"
}  // namespace

struct glovepose_model {
  std::uint32_t tag = kModelTag;
  std::shared_ptr<const glovepose::PoseModel> model;
};

struct glovepose_estimator {
  glovepose_estimator(std::shared_ptr<const glovepose::PoseModel> model, glovepose::EstimatorConfig config)
      : estimator(std::move(model), std::move(config)) {}
  std::uint32_t tag = kEstimatorTag;
  glovepose::GlovePoseEstimator estimator;
};

struct glovepose_latest {
  std::uint32_t tag = kLatestTag;
  glovepose::LatestHand latest;
  glovepose::hand::LatestAim aim;  // published with `latest`, from the same pose
};

namespace {

using glovepose::Status;

// The per-frame statuses cross the ABI with the numbers of glovepose::Status.
static_assert(GLOVEPOSE_OK == static_cast<int>(Status::Ok), "status numbers");
static_assert(GLOVEPOSE_SOLVED == static_cast<int>(Status::Solved), "status numbers");
static_assert(GLOVEPOSE_NOT_READY == static_cast<int>(Status::NotReady), "status numbers");
static_assert(GLOVEPOSE_NON_FINITE == static_cast<int>(Status::NonFinite), "status numbers");
static_assert(GLOVEPOSE_NEGATIVE == static_cast<int>(Status::Negative), "status numbers");
static_assert(GLOVEPOSE_UNKNOWN_INDEX == static_cast<int>(Status::UnknownIndex), "status numbers");
static_assert(GLOVEPOSE_TIMESTAMP_BACKWARDS == static_cast<int>(Status::TimestampBackwards), "status numbers");
static_assert(GLOVEPOSE_SIZE_MISMATCH == static_cast<int>(Status::SizeMismatch), "status numbers");
static_assert(GLOVEPOSE_UNCALIBRATED == static_cast<int>(Status::Uncalibrated), "status numbers");
static_assert(GLOVEPOSE_DOF_COUNT == glovepose::hand::kDofCount, "DoF count");
static_assert(GLOVEPOSE_POSE_STALE_READINGS == glovepose::kPoseStaleReadings, "pose flags");
static_assert(GLOVEPOSE_POSE_RECOVERING == glovepose::kPoseRecovering, "pose flags");
static_assert(GLOVEPOSE_POSE_STUCK_ROWS == glovepose::kPoseStuckRows, "pose flags");
static_assert(GLOVEPOSE_POSE_DISCONNECTED_ROWS == glovepose::kPoseDisconnectedRows, "pose flags");
static_assert(GLOVEPOSE_POSE_OUTLIER_ROWS == glovepose::kPoseOutlierRows, "pose flags");
static_assert(GLOVEPOSE_POSE_MASKED_CELLS == glovepose::kPoseMaskedCells, "pose flags");
static_assert(GLOVEPOSE_POSE_GLOVE_OFF == glovepose::kPoseGloveOff, "pose flags");
static_assert(GLOVEPOSE_POSE_FAULT_FLAGS == glovepose::kPoseFaultFlags, "pose flags");
static_assert(GLOVEPOSE_JOINT_COUNT == glovepose::hand::kJointCount, "joint count");
static_assert(GLOVEPOSE_POSE_READINGS_REJECTED == glovepose::kPoseReadingsRejected, "pose flags");
static_assert(GLOVEPOSE_POSE_INPUT_CLAMPED == glovepose::kPoseInputClamped, "pose flags");
static_assert(GLOVEPOSE_POSE_TRAINING_CALIBRATION == glovepose::kPoseTrainingCalibration, "pose flags");
static_assert(GLOVEPOSE_POSE_CALIBRATING == glovepose::kPoseCalibrating, "pose flags");
static_assert(GLOVEPOSE_CALIBRATION_NONE == static_cast<int>(glovepose::CalibrationSource::None) &&
                  GLOVEPOSE_CALIBRATION_ON_THE_FLY == static_cast<int>(glovepose::CalibrationSource::OnTheFly) &&
                  GLOVEPOSE_CALIBRATION_USER == static_cast<int>(glovepose::CalibrationSource::User) &&
                  GLOVEPOSE_CALIBRATION_TRAINING == static_cast<int>(glovepose::CalibrationSource::Training) &&
                  GLOVEPOSE_CALIBRATION_CONTINUOUS == static_cast<int>(glovepose::CalibrationSource::Continuous),
              "calibration sources");
// The documented ABI-1 sizes: no implicit padding, the same layout in C, C# and ctypes.
static_assert(sizeof(glovepose_estimator_config) == 80, "ABI 1 layout");
static_assert(sizeof(glovepose_hand_options) == 24 && offsetof(glovepose_hand_options, prediction_window) == 8, "ABI 1 layout");
// OpenXR's layout (tests/test_openxr_joints.cpp checks hand::XrJointLocation against openxr.h).
static_assert(sizeof(glovepose_xr_joint_location) == sizeof(glovepose::hand::XrJointLocation), "OpenXR layout");
static_assert(offsetof(glovepose_xr_joint_location, orientation) == offsetof(glovepose::hand::XrJointLocation, pose), "OpenXR layout");
static_assert(offsetof(glovepose_xr_joint_location, radius) == offsetof(glovepose::hand::XrJointLocation, radius), "OpenXR layout");
static_assert(sizeof(glovepose_xr_joint_velocity) == sizeof(glovepose::hand::XrJointVelocity), "OpenXR layout");
static_assert(offsetof(glovepose_xr_joint_velocity, angular_velocity) == offsetof(glovepose::hand::XrJointVelocity, angular_velocity),
              "OpenXR layout");
static_assert(sizeof(glovepose_xr_hand) == 1912 && offsetof(glovepose_xr_hand, locations) == 40, "ABI 1 layout");
static_assert(sizeof(glovepose_predicted_pose) == 440 && offsetof(glovepose_predicted_pose, time) == 408, "ABI 1 layout");
static_assert(GLOVEPOSE_XR_JOINT_COUNT == glovepose::hand::kXrJointCount, "OpenXR joint count");
static_assert(GLOVEPOSE_XR_POSITION_TRACKED == glovepose::hand::kXrPositionTracked &&
                  GLOVEPOSE_XR_ANGULAR_VELOCITY_VALID == glovepose::hand::kXrAngularVelocityValid,
              "OpenXR flags");
static_assert(GLOVEPOSE_HAND_LEFT == static_cast<int>(glovepose::hand::Handedness::Left), "handedness");
static_assert(offsetof(glovepose_estimator_config, calibration_sample_period) == 16, "ABI 1 layout");
static_assert(offsetof(glovepose_estimator_config, smoothing_frequency) == 48, "ABI 1 layout");
static_assert(sizeof(glovepose_pose) == 448, "ABI 1 layout");
static_assert(offsetof(glovepose_pose, timestamp) == 408, "ABI 1 layout");
static_assert(offsetof(glovepose_pose, sequence) == 432, "ABI 1 layout");
static_assert(sizeof(glovepose_joint) == 28, "ABI 1 layout");
static_assert(sizeof(glovepose_calibration_progress) == 32, "ABI 1 layout");
static_assert(offsetof(glovepose_calibration_progress, frames) == 8, "ABI 1 layout");
static_assert(sizeof(glovepose_calibration_step) == 1184, "ABI 1 layout");
static_assert(offsetof(glovepose_calibration_step, start_seconds) == 112, "ABI 1 layout");
static_assert(offsetof(glovepose_calibration_step, instruction) == 160, "ABI 1 layout");

using glovepose::capi::fail;
using glovepose::capi::fail_from_exception;
using glovepose::capi::failf;

glovepose::LatestHand* latest_of(const glovepose_latest* handle) noexcept {
  return handle != nullptr && handle->tag == kLatestTag ? &const_cast<glovepose_latest*>(handle)->latest : nullptr;
}

void copy_pose(const glovepose::Pose& p, glovepose_pose& out) noexcept {
  std::memcpy(out.angles, p.angles.data(), sizeof out.angles);
  std::memcpy(out.raw_angles, p.raw_angles.data(), sizeof out.raw_angles);
  out.flags = p.flags;
  out.timestamp = p.timestamp;
  out.oldest_age = p.oldest_age;
  out.compute_seconds = p.compute_seconds;
  out.sequence = p.sequence;
  out.rejected = p.rejected;
  out.valid = p.valid ? 1 : 0;
}

void copy_joints(const glovepose::hand::JointList& joints, glovepose_joint* out) noexcept {
  for (std::size_t j = 0; j < glovepose::hand::kJointCount; ++j) {
    std::memcpy(out[j].position, joints[j].position.data(), sizeof out[j].position);
    std::memcpy(out[j].rotation, joints[j].rotation.data(), sizeof out[j].rotation);
  }
}

const glovepose::PoseModel* model_of(const glovepose_model* handle) noexcept {
  return handle != nullptr && handle->tag == kModelTag ? handle->model.get() : nullptr;
}

glovepose::GlovePoseEstimator* estimator_of(const glovepose_estimator* handle) noexcept {
  return handle != nullptr && handle->tag == kEstimatorTag ? &const_cast<glovepose_estimator*>(handle)->estimator : nullptr;
}

// Copies `text` into a C buffer of `capacity` bytes, NUL-terminated; a text too long is cut before
// the first UTF-8 character that does not fit whole.
void copy_text(const std::string& text, char* out, std::size_t capacity) noexcept {
  std::size_t n = std::min(text.size(), capacity - 1);
  if (n < text.size())
    while (n > 0 && (static_cast<unsigned char>(text[n]) & 0xC0u) == 0x80u) --n;  // text[n] continues a character
  std::memcpy(out, text.data(), n);
  out[n] = '\0';
}

glovepose_result invalid_model() noexcept {
  return fail(GLOVEPOSE_ERROR_INVALID_HANDLE, "invalid model handle: null, freed, or not a glovepose_model");
}
glovepose_result invalid_estimator() noexcept {
  return fail(GLOVEPOSE_ERROR_INVALID_HANDLE, "invalid estimator handle: null, freed, or not a glovepose_estimator");
}

glovepose_result to_result(Status status) noexcept { return static_cast<glovepose_result>(status); }

glovepose::EstimatorConfig to_config(const glovepose_estimator_config& c) {
  glovepose::EstimatorConfig config;
  config.readout.mean_window = c.readout_mean_window;
  config.readout.solve_every = c.readout_solve_every;
  config.calibration_median_window = c.calibration_median_window;
  config.calibration_sample_period = c.calibration_sample_period;
  config.calibration.min_relative_range = c.calibration_min_relative_range;
  config.calibration.clamp_limit = c.calibration_clamp_limit;
  if (c.smoothing != 0)
    config.smoothing =
        glovepose::filter::OneEuroConfig{c.smoothing_frequency, c.smoothing_min_cutoff, c.smoothing_beta, c.smoothing_d_cutoff};
  config.joint_transforms = c.joint_transforms != 0;
  return config;
}

void apply(const glovepose_hand_options& o, glovepose::EstimatorConfig& config) {
  if (o.handedness != GLOVEPOSE_HAND_RIGHT && o.handedness != GLOVEPOSE_HAND_LEFT)
    throw glovepose::Error("glovepose_estimator_create_for_hand: handedness " + std::to_string(o.handedness) +
                           ", expected GLOVEPOSE_HAND_RIGHT (0) or GLOVEPOSE_HAND_LEFT (1)");
  config.handedness = static_cast<glovepose::hand::Handedness>(o.handedness);
  config.prediction_window = o.prediction_window;
  config.max_prediction = o.max_prediction;
}

void copy_xr_hand(const glovepose::hand::XrHandJoints& in, glovepose_xr_hand& out) noexcept {
  out.active = in.active ? 1 : 0;
  out.predicted = in.predicted ? 1 : 0;
  out.clamped = in.clamped ? 1 : 0;
  out.handedness = static_cast<int32_t>(in.side);
  out.data_source = static_cast<int32_t>(in.data_source);
  out.time = in.time;
  out.horizon = in.horizon;
  std::memcpy(out.locations, in.locations.data(), sizeof out.locations);
  std::memcpy(out.velocities, in.velocities.data(), sizeof out.velocities);
}

// The aim state as XrHandTrackingAimStateFB carries it; type and next stay the caller's.
void copy_xr_aim(const glovepose::hand::XrHandAim& in, glovepose_xr_aim_state& out) noexcept {
  static_assert(sizeof out.aim_orientation == sizeof in.aim_pose.orientation && sizeof out.aim_position == sizeof in.aim_pose.position,
                "XrPosef's parts");
  out.status = in.status;
  std::memcpy(out.aim_orientation, &in.aim_pose.orientation, sizeof out.aim_orientation);
  std::memcpy(out.aim_position, &in.aim_pose.position, sizeof out.aim_position);
  out.pinch_strength_index = in.pinch_strength[0];
  out.pinch_strength_middle = in.pinch_strength[1];
  out.pinch_strength_ring = in.pinch_strength[2];
  out.pinch_strength_little = in.pinch_strength[3];
}

glovepose_result check_xr_aim(const glovepose_xr_aim_state* out, const char* function) noexcept {
  if (out == nullptr) return failf(GLOVEPOSE_ERROR_INVALID_ARGUMENT, "%s: out is NULL", function);
  if (out->type != GLOVEPOSE_XR_TYPE_HAND_TRACKING_AIM_STATE_FB)
    return failf(GLOVEPOSE_ERROR_STRUCT_SIZE,
                 "%s: out->type is %d, expected GLOVEPOSE_XR_TYPE_HAND_TRACKING_AIM_STATE_FB (1000111001; call glovepose_xr_aim_state_init "
                 "first)",
                 function, static_cast<int>(out->type));
  return GLOVEPOSE_OK;
}

glovepose_result check_xr_hand(glovepose_xr_hand* out, const char* function) noexcept {
  if (out == nullptr) return failf(GLOVEPOSE_ERROR_INVALID_ARGUMENT, "%s: out is NULL", function);
  if (out->struct_size != sizeof(glovepose_xr_hand))
    return failf(GLOVEPOSE_ERROR_STRUCT_SIZE, "%s: out->struct_size is not sizeof(glovepose_xr_hand) (call glovepose_xr_hand_init first)",
                 function);
  return GLOVEPOSE_OK;
}

}  // namespace

extern "C" {

const char* glovepose_version(void) noexcept { return glovepose::kVersion; }

int32_t glovepose_abi_version(void) noexcept { return GLOVEPOSE_C_ABI_VERSION; }

const char* glovepose_isa(void) noexcept {
  try {
    return glovepose::nn::isa_word(glovepose::model::process_isa());
  } catch (...) {
    (void)fail_from_exception(nullptr, GLOVEPOSE_ERROR_INVALID_ARGUMENT);
    return nullptr;
  }
}

double glovepose_row_time(double cycle_end, int32_t row, int32_t rows, double cycle_rate) noexcept {
  if (rows < 1 || row < 0 || row >= rows || !(cycle_rate > 0.0) || !std::isfinite(cycle_rate)) return std::nan("");
  return glovepose::io::RowClock{static_cast<std::size_t>(rows), cycle_rate}.time(cycle_end, static_cast<std::size_t>(row));
}

const char* glovepose_last_error(void) noexcept { return glovepose::capi::last_error_text; }

const char* glovepose_result_name(glovepose_result result) noexcept {
  if (result >= GLOVEPOSE_OK && result <= GLOVEPOSE_UNCALIBRATED) return glovepose::to_string(static_cast<Status>(result));
  switch (result) {
    case GLOVEPOSE_ERROR_INVALID_ARGUMENT:
      return "invalid argument";
    case GLOVEPOSE_ERROR_INVALID_HANDLE:
      return "invalid handle";
    case GLOVEPOSE_ERROR_STRUCT_SIZE:
      return "unknown struct size";
    case GLOVEPOSE_ERROR_FILE_NOT_FOUND:
      return "file not found";
    case GLOVEPOSE_ERROR_INVALID_FILE:
      return "invalid file";
    case GLOVEPOSE_ERROR_IO:
      return "i/o error";
    case GLOVEPOSE_ERROR_CALIBRATION_STATE:
      return "calibration state";
    case GLOVEPOSE_ERROR_DISABLED:
      return "disabled";
    case GLOVEPOSE_ERROR_OUT_OF_MEMORY:
      return "out of memory";
    case GLOVEPOSE_ERROR_INTERNAL:
      return "internal error";
    default:
      return "unknown result";
  }
}

const char* glovepose_dof_name(int32_t dof) noexcept {
  if (dof < 0 || dof >= GLOVEPOSE_DOF_COUNT) return nullptr;
  return glovepose::hand::kDofs[static_cast<std::size_t>(dof)].name;
}

const char* glovepose_joint_name(int32_t joint) noexcept {
  if (joint < 0 || joint >= GLOVEPOSE_JOINT_COUNT) return nullptr;
  return glovepose::hand::kJointNames[static_cast<std::size_t>(joint)];
}

int32_t glovepose_joint_parent(int32_t joint) noexcept {
  if (joint < 0 || joint >= GLOVEPOSE_JOINT_COUNT) return -2;
  return glovepose::hand::kJointParent[static_cast<std::size_t>(joint)];
}

const char* glovepose_xr_joint_name(int32_t joint) noexcept {
  if (joint < 0 || joint >= GLOVEPOSE_XR_JOINT_COUNT) return nullptr;
  return glovepose::hand::kXrJointNames[static_cast<std::size_t>(joint)];
}

int32_t glovepose_xr_joint_parent(int32_t joint) noexcept {
  if (joint < 0 || joint >= GLOVEPOSE_XR_JOINT_COUNT) return -2;
  return glovepose::hand::kXrJointParent[static_cast<std::size_t>(joint)];
}

// ---- model -------------------------------------------------------------------------------------

glovepose_result glovepose_model_load(const char* model_path, int32_t weight_storage, const char* glove_description_path,
                                      glovepose_model** out_model) noexcept {
  if (out_model == nullptr) return fail(GLOVEPOSE_ERROR_INVALID_ARGUMENT, "glovepose_model_load: out_model is NULL");
  *out_model = nullptr;
  if (model_path == nullptr) return fail(GLOVEPOSE_ERROR_INVALID_ARGUMENT, "glovepose_model_load: model_path is NULL");
  if (weight_storage < GLOVEPOSE_WEIGHTS_F32 || weight_storage > GLOVEPOSE_WEIGHTS_REALTIME)
    return failf(GLOVEPOSE_ERROR_INVALID_ARGUMENT,
                 "glovepose_model_load: weight_storage %d, expected GLOVEPOSE_WEIGHTS_F32 (0), GLOVEPOSE_WEIGHTS_F16 (1), "
                 "GLOVEPOSE_WEIGHTS_BF16 (2), GLOVEPOSE_WEIGHTS_FIXED16 (3) or GLOVEPOSE_WEIGHTS_REALTIME (4)",
                 static_cast<int>(weight_storage));
  glovepose::PoseModelOptions options;
  try {
    // The C values are the enumerators' order (checked where WeightStorage is defined).
    options.storage = weight_storage == GLOVEPOSE_WEIGHTS_REALTIME ? glovepose::nn::realtime_storage(glovepose::model::process_isa())
                                                                    : static_cast<glovepose::nn::WeightStorage>(weight_storage);
  } catch (...) {
    return fail_from_exception(nullptr, GLOVEPOSE_ERROR_INVALID_ARGUMENT);
  }
  if (glove_description_path != nullptr) {
    try {
      options.glove = glovepose::grid::GloveDescription::read(glove_description_path);
    } catch (...) {
      return fail_from_exception(glove_description_path, GLOVEPOSE_ERROR_INVALID_FILE);
    }
  }
  try {
    auto handle = std::make_unique<glovepose_model>();
    handle->model = glovepose::PoseModel::load(model_path, std::move(options));
    *out_model = handle.release();
    return GLOVEPOSE_OK;
  } catch (...) {
    return fail_from_exception(model_path, GLOVEPOSE_ERROR_INVALID_FILE);
  }
}

void glovepose_model_free(glovepose_model* model) noexcept {
  if (model_of(model) == nullptr) return;
  model->tag = 0;  // a second free or a later use is refused (while the memory is not reused)
  delete model;
}

int32_t glovepose_model_cell_count(const glovepose_model* model) noexcept {
  const glovepose::PoseModel* m = model_of(model);
  if (m == nullptr) {
    invalid_model();
    return -1;
  }
  return m->cell_count();
}

int32_t glovepose_model_row_count(const glovepose_model* model) noexcept {
  const glovepose::PoseModel* m = model_of(model);
  if (m == nullptr) {
    invalid_model();
    return -1;
  }
  return m->solver() ? static_cast<int32_t>(m->solver()->layout().row_count()) : 0;
}

const char* glovepose_model_glove_id(const glovepose_model* model) noexcept {
  const glovepose::PoseModel* m = model_of(model);
  if (m == nullptr) {
    invalid_model();
    return nullptr;
  }
  return m->glove().id().c_str();
}

const char* glovepose_model_cell_name(const glovepose_model* model, int32_t cell) noexcept {
  const glovepose::PoseModel* m = model_of(model);
  if (m == nullptr) {
    invalid_model();
    return nullptr;
  }
  if (cell < 0 || cell >= m->cell_count()) {
    failf(GLOVEPOSE_ERROR_INVALID_ARGUMENT, "glovepose_model_cell_name: cell %d, expected 0..%d", static_cast<int>(cell),
          m->cell_count() - 1);
    return nullptr;
  }
  return m->glove().cell_names()[static_cast<std::size_t>(cell)].c_str();
}

int32_t glovepose_model_has_training_range(const glovepose_model* model) noexcept {
  const glovepose::PoseModel* m = model_of(model);
  if (m == nullptr) {
    invalid_model();
    return -1;
  }
  return m->training_range() ? 1 : 0;
}

int32_t glovepose_model_has_range_map(const glovepose_model* model) noexcept {
  const glovepose::PoseModel* m = model_of(model);
  if (m == nullptr) {
    invalid_model();
    return -1;
  }
  return m->range_map() ? 1 : 0;
}

int32_t glovepose_model_has_pose_error(const glovepose_model* model) noexcept {
  const glovepose::PoseModel* m = model_of(model);
  if (m == nullptr) {
    invalid_model();
    return -1;
  }
  return m->pose_error() ? 1 : 0;
}

int32_t glovepose_model_calibration_step_count(const glovepose_model* model) noexcept {
  const glovepose::PoseModel* m = model_of(model);
  if (m == nullptr) {
    invalid_model();
    return -1;
  }
  return m->pose_offset() ? static_cast<int32_t>(m->pose_offset()->sequence().steps().size()) : 0;
}

glovepose_result glovepose_model_get_calibration_step(const glovepose_model* model, int32_t step,
                                                      glovepose_calibration_step* out) noexcept {
  const glovepose::PoseModel* m = model_of(model);
  if (m == nullptr) return invalid_model();
  if (out == nullptr) return fail(GLOVEPOSE_ERROR_INVALID_ARGUMENT, "glovepose_model_get_calibration_step: out is NULL");
  if (out->struct_size != sizeof(glovepose_calibration_step))
    return fail(GLOVEPOSE_ERROR_STRUCT_SIZE,
                "glovepose_model_get_calibration_step: out->struct_size is not "
                "sizeof(glovepose_calibration_step) (call glovepose_calibration_step_init first)");
  if (!m->pose_offset())
    return fail(GLOVEPOSE_ERROR_INVALID_ARGUMENT, "glovepose_model_get_calibration_step: the model has no guided calibration sequence");
  const auto& steps = m->pose_offset()->sequence().steps();
  if (step < 0 || static_cast<std::size_t>(step) >= steps.size())
    return failf(GLOVEPOSE_ERROR_INVALID_ARGUMENT, "glovepose_model_get_calibration_step: step %d, expected 0..%d", static_cast<int>(step),
                 static_cast<int>(steps.size()) - 1);
  out->step = step;
  out->step_count = static_cast<int32_t>(steps.size());
  out->start_seconds = 0.0;
  for (int32_t k = 0; k < step; ++k) out->start_seconds += steps[static_cast<std::size_t>(k)].seconds;
  const glovepose::calibration::Step& s = steps[static_cast<std::size_t>(step)];
  out->seconds = s.seconds;
  for (std::size_t d = 0; d < glovepose::hand::kDofCount; ++d) out->pose[d] = static_cast<float>(s.pose[d]);
  copy_text(s.name, out->name, sizeof out->name);
  copy_text(s.instruction, out->instruction, sizeof out->instruction);
  return GLOVEPOSE_OK;
}

// ---- estimator ---------------------------------------------------------------------------------

glovepose_result glovepose_estimator_config_default(glovepose_estimator_config* config) noexcept {
  if (config == nullptr) return fail(GLOVEPOSE_ERROR_INVALID_ARGUMENT, "glovepose_estimator_config_default: config is NULL");
  const glovepose::EstimatorConfig defaults;
  const glovepose::filter::OneEuroConfig one_euro;
  std::memset(config, 0, sizeof *config);
  config->struct_size = sizeof *config;
  config->readout_mean_window = defaults.readout.mean_window;
  config->readout_solve_every = defaults.readout.solve_every;
  config->calibration_median_window = defaults.calibration_median_window;
  config->calibration_sample_period = defaults.calibration_sample_period;
  config->calibration_min_relative_range = defaults.calibration.min_relative_range;
  config->calibration_clamp_limit = defaults.calibration.clamp_limit;
  config->smoothing = defaults.smoothing ? 1 : 0;
  config->joint_transforms = defaults.joint_transforms ? 1 : 0;
  config->smoothing_frequency = one_euro.frequency;
  config->smoothing_min_cutoff = one_euro.min_cutoff;
  config->smoothing_beta = one_euro.beta;
  config->smoothing_d_cutoff = one_euro.d_cutoff;
  return GLOVEPOSE_OK;
}

glovepose_result glovepose_hand_options_default(glovepose_hand_options* options) noexcept {
  if (options == nullptr) return fail(GLOVEPOSE_ERROR_INVALID_ARGUMENT, "glovepose_hand_options_default: options is NULL");
  const glovepose::EstimatorConfig defaults;
  std::memset(options, 0, sizeof *options);
  options->struct_size = sizeof *options;
  options->handedness = static_cast<int32_t>(defaults.handedness);
  options->prediction_window = defaults.prediction_window;
  options->max_prediction = defaults.max_prediction;
  return GLOVEPOSE_OK;
}

glovepose_result glovepose_estimator_create(const glovepose_model* model, const glovepose_estimator_config* config,
                                            glovepose_estimator** out_estimator) noexcept {
  return glovepose_estimator_create_for_hand(model, config, nullptr, out_estimator);
}

glovepose_result glovepose_estimator_create_for_hand(const glovepose_model* model, const glovepose_estimator_config* config,
                                                     const glovepose_hand_options* options, glovepose_estimator** out_estimator) noexcept {
  if (out_estimator == nullptr) return fail(GLOVEPOSE_ERROR_INVALID_ARGUMENT, "glovepose_estimator_create: out_estimator is NULL");
  *out_estimator = nullptr;
  if (model_of(model) == nullptr) return invalid_model();
  glovepose_estimator_config settings;
  if (config == nullptr) {
    (void)glovepose_estimator_config_default(&settings);
  } else {
    if (config->struct_size != sizeof(glovepose_estimator_config))
      return failf(GLOVEPOSE_ERROR_STRUCT_SIZE, "glovepose_estimator_create: config struct_size %u, expected %u (ABI %d)",
                   static_cast<unsigned>(config->struct_size), static_cast<unsigned>(sizeof(glovepose_estimator_config)),
                   GLOVEPOSE_C_ABI_VERSION);
    settings = *config;
  }
  if (options != nullptr && options->struct_size != sizeof(glovepose_hand_options))
    return failf(GLOVEPOSE_ERROR_STRUCT_SIZE, "glovepose_estimator_create_for_hand: options struct_size %u, expected %u (ABI %d)",
                 static_cast<unsigned>(options->struct_size), static_cast<unsigned>(sizeof(glovepose_hand_options)),
                 GLOVEPOSE_C_ABI_VERSION);
  try {
    glovepose::EstimatorConfig estimator_config = to_config(settings);
    if (options != nullptr) apply(*options, estimator_config);
    *out_estimator = new glovepose_estimator(model->model, std::move(estimator_config));
    return GLOVEPOSE_OK;
  } catch (...) {
    // Every glovepose::Error here is about the settings (the model was checked above).
    return fail_from_exception(nullptr, GLOVEPOSE_ERROR_INVALID_ARGUMENT);
  }
}

void glovepose_estimator_free(glovepose_estimator* estimator) noexcept {
  if (estimator_of(estimator) == nullptr) return;
  estimator->tag = 0;
  delete estimator;
}

glovepose_result glovepose_estimator_push_row(glovepose_estimator* estimator, int32_t row, double value, double timestamp) noexcept {
  glovepose::GlovePoseEstimator* e = estimator_of(estimator);
  if (e == nullptr) return invalid_estimator();
  return to_result(e->push_row(row, value, timestamp));
}

glovepose_result glovepose_estimator_push_measurements(glovepose_estimator* estimator, const double* values, int32_t count,
                                                       double timestamp) noexcept {
  glovepose::GlovePoseEstimator* e = estimator_of(estimator);
  if (e == nullptr) return invalid_estimator();
  return to_result(e->push_measurements(values, count, timestamp));
}

glovepose_result glovepose_estimator_push_cells(glovepose_estimator* estimator, const double* cells, int32_t count, double timestamp,
                                                double oldest_age) noexcept {
  glovepose::GlovePoseEstimator* e = estimator_of(estimator);
  if (e == nullptr) return invalid_estimator();
  return to_result(e->push_cells(cells, count, timestamp, oldest_age));
}

glovepose_result glovepose_estimator_get_pose(const glovepose_estimator* estimator, glovepose_pose* out) noexcept {
  const glovepose::GlovePoseEstimator* e = estimator_of(estimator);
  if (e == nullptr) return invalid_estimator();
  if (out == nullptr) return fail(GLOVEPOSE_ERROR_INVALID_ARGUMENT, "glovepose_estimator_get_pose: out is NULL");
  if (out->struct_size != sizeof(glovepose_pose))
    return fail(GLOVEPOSE_ERROR_STRUCT_SIZE,
                "glovepose_estimator_get_pose: out->struct_size is not sizeof(glovepose_pose) "
                "(call glovepose_pose_init first)");
  copy_pose(e->pose(), *out);
  return GLOVEPOSE_OK;
}

glovepose_result glovepose_estimator_get_joints(const glovepose_estimator* estimator, glovepose_joint* out, int32_t count) noexcept {
  const glovepose::GlovePoseEstimator* e = estimator_of(estimator);
  if (e == nullptr) return invalid_estimator();
  if (out == nullptr) return fail(GLOVEPOSE_ERROR_INVALID_ARGUMENT, "glovepose_estimator_get_joints: out is NULL");
  if (count != GLOVEPOSE_JOINT_COUNT)
    return fail(GLOVEPOSE_SIZE_MISMATCH, "glovepose_estimator_get_joints: count is not GLOVEPOSE_JOINT_COUNT (21)");
  if (!e->config().joint_transforms)
    return fail(GLOVEPOSE_ERROR_DISABLED, "glovepose_estimator_get_joints: the estimator was created with joint_transforms = 0");
  copy_joints(e->joints(), out);
  return GLOVEPOSE_OK;
}

glovepose_result glovepose_estimator_get_pose_at(const glovepose_estimator* estimator, double time,
                                                 glovepose_predicted_pose* out) noexcept {
  const glovepose::GlovePoseEstimator* e = estimator_of(estimator);
  if (e == nullptr) return invalid_estimator();
  if (out == nullptr) return fail(GLOVEPOSE_ERROR_INVALID_ARGUMENT, "glovepose_estimator_get_pose_at: out is NULL");
  if (out->struct_size != sizeof(glovepose_predicted_pose))
    return fail(GLOVEPOSE_ERROR_STRUCT_SIZE,
                "glovepose_estimator_get_pose_at: out->struct_size is not sizeof(glovepose_predicted_pose) "
                "(call glovepose_predicted_pose_init first)");
  glovepose::PredictedPose pose;
  const Status status = e->pose_at(time, pose);
  if (status != Status::Ok) return to_result(status);
  out->flags = pose.flags;
  std::memcpy(out->angles, pose.angles.data(), sizeof out->angles);
  std::memcpy(out->rate, pose.rate.data(), sizeof out->rate);
  out->time = pose.time;
  out->horizon = pose.horizon;
  out->predicted = pose.predicted ? 1 : 0;
  out->clamped = pose.clamped ? 1 : 0;
  out->has_rate = pose.has_rate ? 1 : 0;
  out->trusted = pose.trusted ? 1 : 0;
  return GLOVEPOSE_OK;
}

glovepose_result glovepose_estimator_get_xr_joints(const glovepose_estimator* estimator, double time, glovepose_xr_hand* out) noexcept {
  const glovepose::GlovePoseEstimator* e = estimator_of(estimator);
  if (e == nullptr) return invalid_estimator();
  if (const glovepose_result bad = check_xr_hand(out, "glovepose_estimator_get_xr_joints"); bad != GLOVEPOSE_OK) return bad;
  glovepose::hand::XrHandJoints joints;
  const Status status = e->joints_at(time, joints);
  if (status != Status::Ok) {
    out->active = 0;
    return to_result(status);
  }
  copy_xr_hand(joints, *out);
  return GLOVEPOSE_OK;
}

glovepose_result glovepose_estimator_get_cells(const glovepose_estimator* estimator, double* out, int32_t count) noexcept {
  const glovepose::GlovePoseEstimator* e = estimator_of(estimator);
  if (e == nullptr) return invalid_estimator();
  if (out == nullptr) return fail(GLOVEPOSE_ERROR_INVALID_ARGUMENT, "glovepose_estimator_get_cells: out is NULL");
  if (static_cast<std::size_t>(count) != e->cells().size())
    return fail(GLOVEPOSE_SIZE_MISMATCH, "glovepose_estimator_get_cells: count is not the model's cell count");
  std::memcpy(out, e->cells().data(), sizeof(double) * static_cast<std::size_t>(count));
  return GLOVEPOSE_OK;
}

glovepose_result glovepose_estimator_get_confidence(const glovepose_estimator* estimator, double* out, int32_t count) noexcept {
  const glovepose::GlovePoseEstimator* e = estimator_of(estimator);
  if (e == nullptr) return invalid_estimator();
  if (out == nullptr) return fail(GLOVEPOSE_ERROR_INVALID_ARGUMENT, "glovepose_estimator_get_confidence: out is NULL");
  if (count != GLOVEPOSE_DOF_COUNT)
    return fail(GLOVEPOSE_SIZE_MISMATCH, "glovepose_estimator_get_confidence: count is not GLOVEPOSE_DOF_COUNT (25)");
  std::memcpy(out, e->pose().confidence.data(), sizeof(double) * static_cast<std::size_t>(count));
  return GLOVEPOSE_OK;
}

glovepose_result glovepose_estimator_get_xr_aim(const glovepose_estimator* estimator, glovepose_xr_aim_state* out) noexcept {
  const glovepose::GlovePoseEstimator* e = estimator_of(estimator);
  if (e == nullptr) return invalid_estimator();
  if (const glovepose_result bad = check_xr_aim(out, "glovepose_estimator_get_xr_aim"); bad != GLOVEPOSE_OK) return bad;
  copy_xr_aim(e->aim(), *out);
  return e->aim().active ? GLOVEPOSE_OK : GLOVEPOSE_NOT_READY;
}

glovepose_result glovepose_estimator_reset(glovepose_estimator* estimator) noexcept {
  glovepose::GlovePoseEstimator* e = estimator_of(estimator);
  if (e == nullptr) return invalid_estimator();
  e->reset();
  return GLOVEPOSE_OK;
}

// ---- the latest hand ---------------------------------------------------------------------------

glovepose_result glovepose_latest_create(glovepose_latest** out_latest) noexcept {
  if (out_latest == nullptr) return fail(GLOVEPOSE_ERROR_INVALID_ARGUMENT, "glovepose_latest_create: out_latest is NULL");
  *out_latest = new (std::nothrow) glovepose_latest;
  if (*out_latest == nullptr) return fail(GLOVEPOSE_ERROR_OUT_OF_MEMORY, "glovepose_latest_create: out of memory");
  return GLOVEPOSE_OK;
}

void glovepose_latest_free(glovepose_latest* latest) noexcept {
  if (latest_of(latest) == nullptr) return;
  latest->tag = 0;
  delete latest;
}

glovepose_result glovepose_latest_publish(glovepose_latest* latest, const glovepose_estimator* estimator) noexcept {
  glovepose::LatestHand* l = latest_of(latest);
  if (l == nullptr) return fail(GLOVEPOSE_ERROR_INVALID_HANDLE, "glovepose_latest_publish: not a snapshot from glovepose_latest_create");
  const glovepose::GlovePoseEstimator* e = estimator_of(estimator);
  if (e == nullptr) return invalid_estimator();
  l->publish(e->state());
  latest->aim.publish(e->aim());
  return GLOVEPOSE_OK;
}

glovepose_result glovepose_latest_read(const glovepose_latest* latest, glovepose_pose* pose, glovepose_joint* joints, int32_t joint_count,
                                       uint64_t* number) noexcept {
  const glovepose::LatestHand* l = latest_of(latest);
  if (l == nullptr) return fail(GLOVEPOSE_ERROR_INVALID_HANDLE, "glovepose_latest_read: not a snapshot from glovepose_latest_create");
  if (pose != nullptr && pose->struct_size != sizeof(glovepose_pose))
    return fail(GLOVEPOSE_ERROR_STRUCT_SIZE,
                "glovepose_latest_read: pose->struct_size is not sizeof(glovepose_pose) "
                "(call glovepose_pose_init first)");
  if (joint_count != (joints == nullptr ? 0 : GLOVEPOSE_JOINT_COUNT))
    return fail(GLOVEPOSE_SIZE_MISMATCH, "glovepose_latest_read: joint_count must be GLOVEPOSE_JOINT_COUNT (21) with joints, 0 without");
  glovepose::HandState state;
  const std::uint64_t n = l->read(state);
  if (number != nullptr) *number = n;
  if (n == 0) return GLOVEPOSE_OK;
  if (pose != nullptr) copy_pose(state.pose, *pose);
  if (joints != nullptr) copy_joints(state.joints, joints);
  return GLOVEPOSE_OK;
}

glovepose_result glovepose_latest_get_xr_joints(const glovepose_latest* latest, const glovepose_estimator* estimator, double time,
                                                glovepose_xr_hand* out) noexcept {
  const glovepose::LatestHand* l = latest_of(latest);
  if (l == nullptr)
    return fail(GLOVEPOSE_ERROR_INVALID_HANDLE, "glovepose_latest_get_xr_joints: not a snapshot from glovepose_latest_create");
  const glovepose::GlovePoseEstimator* e = estimator_of(estimator);
  if (e == nullptr) return invalid_estimator();
  if (const glovepose_result bad = check_xr_hand(out, "glovepose_latest_get_xr_joints"); bad != GLOVEPOSE_OK) return bad;
  glovepose::HandState state;
  glovepose::PredictedPose pose;
  const Status status =
      l->read(state) == 0 ? Status::NotReady : glovepose::predict(state, e->locator(), time, e->config().max_prediction, pose);
  if (status != Status::Ok) {
    out->active = 0;
    return to_result(status);
  }
  glovepose::hand::XrHandJoints joints;
  glovepose::locate(pose, e->locator(), joints);
  copy_xr_hand(joints, *out);
  return GLOVEPOSE_OK;
}

glovepose_result glovepose_latest_get_xr_aim(const glovepose_latest* latest, glovepose_xr_aim_state* out, uint64_t* sequence) noexcept {
  if (latest_of(latest) == nullptr)
    return fail(GLOVEPOSE_ERROR_INVALID_HANDLE, "glovepose_latest_get_xr_aim: not a snapshot from glovepose_latest_create");
  if (const glovepose_result bad = check_xr_aim(out, "glovepose_latest_get_xr_aim"); bad != GLOVEPOSE_OK) return bad;
  glovepose::hand::XrHandAim aim;
  if (latest->aim.read(aim) == 0) {
    out->status = 0;
    out->pinch_strength_index = out->pinch_strength_middle = out->pinch_strength_ring = out->pinch_strength_little = 0.0f;
    if (sequence != nullptr) *sequence = 0;
    return GLOVEPOSE_NOT_READY;
  }
  copy_xr_aim(aim, *out);
  if (sequence != nullptr) *sequence = aim.sequence;
  return aim.active ? GLOVEPOSE_OK : GLOVEPOSE_NOT_READY;
}

// ---- calibration -------------------------------------------------------------------------------

glovepose_result glovepose_calibration_start(glovepose_estimator* estimator) noexcept {
  glovepose::GlovePoseEstimator* e = estimator_of(estimator);
  if (e == nullptr) return invalid_estimator();
  e->start_calibration();
  return GLOVEPOSE_OK;
}

glovepose_result glovepose_calibration_get_progress(const glovepose_estimator* estimator, glovepose_calibration_progress* out) noexcept {
  const glovepose::GlovePoseEstimator* e = estimator_of(estimator);
  if (e == nullptr) return invalid_estimator();
  if (out == nullptr) return fail(GLOVEPOSE_ERROR_INVALID_ARGUMENT, "glovepose_calibration_get_progress: out is NULL");
  if (out->struct_size != sizeof(glovepose_calibration_progress))
    return fail(GLOVEPOSE_ERROR_STRUCT_SIZE,
                "glovepose_calibration_get_progress: out->struct_size is not "
                "sizeof(glovepose_calibration_progress) (call glovepose_calibration_progress_init first)");
  const glovepose::CalibrationProgress p = e->calibration_progress();
  out->collecting = p.collecting ? 1 : 0;
  out->frames = p.frames;
  out->frames_needed = p.frames_needed;
  out->ready = p.ready ? 1 : 0;
  out->source = static_cast<int32_t>(e->calibration_source());
  out->flat_cells = e->calibration() ? static_cast<int32_t>(e->calibration()->flat_sensors().size()) : 0;
  return GLOVEPOSE_OK;
}

glovepose_result glovepose_calibration_get_step(const glovepose_estimator* estimator, int32_t* step, double* sequence_seconds) noexcept {
  const glovepose::GlovePoseEstimator* e = estimator_of(estimator);
  if (e == nullptr) return invalid_estimator();
  const glovepose::CalibrationProgress p = e->calibration_progress();
  if (step != nullptr) *step = p.step;
  if (sequence_seconds != nullptr) *sequence_seconds = p.sequence_seconds;
  return GLOVEPOSE_OK;
}

glovepose_result glovepose_calibration_finish(glovepose_estimator* estimator) noexcept {
  glovepose::GlovePoseEstimator* e = estimator_of(estimator);
  if (e == nullptr) return invalid_estimator();
  try {
    (void)e->finish_calibration();
    return GLOVEPOSE_OK;
  } catch (...) {
    return fail_from_exception(nullptr, GLOVEPOSE_ERROR_CALIBRATION_STATE);
  }
}

glovepose_result glovepose_calibration_cancel(glovepose_estimator* estimator) noexcept {
  glovepose::GlovePoseEstimator* e = estimator_of(estimator);
  if (e == nullptr) return invalid_estimator();
  e->cancel_calibration();
  return GLOVEPOSE_OK;
}

glovepose_result glovepose_calibration_load(glovepose_estimator* estimator, const char* path) noexcept {
  glovepose::GlovePoseEstimator* e = estimator_of(estimator);
  if (e == nullptr) return invalid_estimator();
  if (path == nullptr) return fail(GLOVEPOSE_ERROR_INVALID_ARGUMENT, "glovepose_calibration_load: path is NULL");
  try {
    e->load_calibration(path);
    return GLOVEPOSE_OK;
  } catch (...) {
    return fail_from_exception(path, GLOVEPOSE_ERROR_INVALID_FILE);
  }
}

glovepose_result glovepose_calibration_save(const glovepose_estimator* estimator, const char* path) noexcept {
  const glovepose::GlovePoseEstimator* e = estimator_of(estimator);
  if (e == nullptr) return invalid_estimator();
  if (path == nullptr) return fail(GLOVEPOSE_ERROR_INVALID_ARGUMENT, "glovepose_calibration_save: path is NULL");
  if (!e->calibration())
    return fail(GLOVEPOSE_ERROR_CALIBRATION_STATE, "glovepose_calibration_save: no calibration range set, expected one to save");
  try {
    e->save_calibration(path);
    return GLOVEPOSE_OK;
  } catch (...) {
    return fail_from_exception(nullptr, GLOVEPOSE_ERROR_IO);
  }
}

glovepose_result glovepose_calibration_use_training(glovepose_estimator* estimator) noexcept {
  glovepose::GlovePoseEstimator* e = estimator_of(estimator);
  if (e == nullptr) return invalid_estimator();
  try {
    e->use_training_calibration();
    return GLOVEPOSE_OK;
  } catch (...) {
    return fail_from_exception(nullptr, GLOVEPOSE_ERROR_CALIBRATION_STATE);
  }
}

glovepose_result glovepose_calibration_clear(glovepose_estimator* estimator) noexcept {
  glovepose::GlovePoseEstimator* e = estimator_of(estimator);
  if (e == nullptr) return invalid_estimator();
  e->clear_calibration();
  return GLOVEPOSE_OK;
}

glovepose_result glovepose_calibration_use_continuous(glovepose_estimator* estimator) noexcept {
  glovepose::GlovePoseEstimator* e = estimator_of(estimator);
  if (e == nullptr) return invalid_estimator();
  try {
    e->use_continuous_calibration();
    return GLOVEPOSE_OK;
  } catch (...) {
    return fail_from_exception(nullptr, GLOVEPOSE_ERROR_CALIBRATION_STATE);
  }
}

glovepose_result glovepose_calibration_set_range(glovepose_estimator* estimator, const double* min, const double* max,
                                                 int32_t count) noexcept {
  glovepose::GlovePoseEstimator* e = estimator_of(estimator);
  if (e == nullptr) return invalid_estimator();
  if (min == nullptr || max == nullptr)
    return fail(GLOVEPOSE_ERROR_INVALID_ARGUMENT, "glovepose_calibration_set_range: min or max is NULL");
  const int cells = e->model().cell_count();
  if (count != cells)
    return failf(GLOVEPOSE_SIZE_MISMATCH, "glovepose_calibration_set_range: count %d, expected %d (the model's cells)",
                 static_cast<int>(count), cells);
  try {
    const glovepose::sensor::CalibrationRange range(Eigen::Map<const Eigen::VectorXd>(min, count),
                                                    Eigen::Map<const Eigen::VectorXd>(max, count), e->model().glove().cell_names(),
                                                    e->config().calibration);
    e->set_calibration(range);
    return GLOVEPOSE_OK;
  } catch (...) {
    return fail_from_exception(nullptr, GLOVEPOSE_ERROR_INVALID_ARGUMENT);
  }
}

glovepose_result glovepose_calibration_get_range(const glovepose_estimator* estimator, double* min, double* max, int32_t count) noexcept {
  const glovepose::GlovePoseEstimator* e = estimator_of(estimator);
  if (e == nullptr) return invalid_estimator();
  if (min == nullptr || max == nullptr)
    return fail(GLOVEPOSE_ERROR_INVALID_ARGUMENT, "glovepose_calibration_get_range: min or max is NULL");
  if (count != e->model().cell_count())
    return fail(GLOVEPOSE_SIZE_MISMATCH, "glovepose_calibration_get_range: count is not the model's cell count");
  if (!e->calibration()) return GLOVEPOSE_UNCALIBRATED;
  std::memcpy(min, e->calibration()->min().data(), sizeof(double) * static_cast<std::size_t>(count));
  std::memcpy(max, e->calibration()->max().data(), sizeof(double) * static_cast<std::size_t>(count));
  return GLOVEPOSE_OK;
}

// ---- struct helpers ----------------------------------------------------------------------------

void glovepose_pose_init(glovepose_pose* pose) noexcept {
  if (pose == nullptr) return;
  std::memset(pose, 0, sizeof *pose);
  pose->struct_size = sizeof *pose;
}

void glovepose_calibration_progress_init(glovepose_calibration_progress* progress) noexcept {
  if (progress == nullptr) return;
  std::memset(progress, 0, sizeof *progress);
  progress->struct_size = sizeof *progress;
}

void glovepose_calibration_step_init(glovepose_calibration_step* step) noexcept {
  if (step == nullptr) return;
  std::memset(step, 0, sizeof *step);
  step->struct_size = sizeof *step;
}

void glovepose_xr_hand_init(glovepose_xr_hand* hand) noexcept {
  if (hand == nullptr) return;
  std::memset(hand, 0, sizeof *hand);
  hand->struct_size = sizeof *hand;
}

void glovepose_predicted_pose_init(glovepose_predicted_pose* pose) noexcept {
  if (pose == nullptr) return;
  std::memset(pose, 0, sizeof *pose);
  pose->struct_size = sizeof *pose;
}

void glovepose_xr_aim_state_init(glovepose_xr_aim_state* state) noexcept {
  if (state == nullptr) return;
  std::memset(static_cast<void*>(state), 0, sizeof *state);
  state->type = GLOVEPOSE_XR_TYPE_HAND_TRACKING_AIM_STATE_FB;
  state->next = nullptr;
}

}  // extern "C"
