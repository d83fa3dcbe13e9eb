/* The C side of the C# package's test (bindings/csharp/Tests~/PackageTest.cs): what the C compiler
 * says about the ABI's structs and constants, and a session streamed through the C ABI from C,
 * written to a file the C# test replays and compares with, bit for bit.
 *
 * Usage: capi_csharp_reference MODEL MALFORMED_FILE OUT RANGE_FILE   (RANGE_FILE: the calibration it saves)
 * Lines of OUT (doubles and floats as the hex of their bits, so nothing is lost in decimal):
 *   size STRUCT BYTES / offset STRUCT FIELD BYTES   sizeof and offsetof of every struct and field
 *   const GROUP NAME VALUE                          a header constant, under the C# enum it maps to
 *   error CODE MESSAGE                              glovepose_model_load of MALFORMED_FILE
 *   start / finish CODE                             calibration start and finish, in stream order
 *   push ROW VALUE TIMESTAMP CODE                   one glovepose_estimator_push_row and its result
 *   pose ... / joints ... / xr ... / aim ...        after each solved push (formats in the writers below)
 *   calibration_step CODE STEP SECONDS             the guided step under way, mid-calibration and after
 *   latest_pose ... / latest_joints ... / latest_xr ... / latest_aim ...   a reader's view at the end
 *   pose_at / cells / progress / range / save / model / step + instruction    the other reads (write_rest)
 * Exit code 0 when every call answered as expected. */
#include "glovepose_c.h"

#include <math.h>
#include <stddef.h>
#include <stdio.h>
#include <string.h>

static FILE* out;

static void put_double(double v) {
  unsigned long long bits;
  memcpy(&bits, &v, sizeof bits);
  fprintf(out, " %016llx", bits);
}

static void put_float(float v) {
  unsigned int bits;
  memcpy(&bits, &v, sizeof bits);
  fprintf(out, " %08x", bits);
}

static void put_floats(const float* v, int n) {
  int i;
  for (i = 0; i < n; ++i) put_float(v[i]);
}

#define SIZE(type) fprintf(out, "size %s %u\n", #type, (unsigned)sizeof(type))
#define OFFSET(type, field) fprintf(out, "offset %s %s %u\n", #type, #field, (unsigned)offsetof(type, field))
#define CONST(group, name, macro) fprintf(out, "const %s %s %lld\n", group, name, (long long)(macro))

static void write_layout(void) {
  SIZE(glovepose_estimator_config);
  OFFSET(glovepose_estimator_config, struct_size);
  OFFSET(glovepose_estimator_config, readout_mean_window);
  OFFSET(glovepose_estimator_config, readout_solve_every);
  OFFSET(glovepose_estimator_config, calibration_median_window);
  OFFSET(glovepose_estimator_config, calibration_sample_period);
  OFFSET(glovepose_estimator_config, calibration_min_relative_range);
  OFFSET(glovepose_estimator_config, calibration_clamp_limit);
  OFFSET(glovepose_estimator_config, smoothing);
  OFFSET(glovepose_estimator_config, joint_transforms);
  OFFSET(glovepose_estimator_config, smoothing_frequency);
  OFFSET(glovepose_estimator_config, smoothing_min_cutoff);
  OFFSET(glovepose_estimator_config, smoothing_beta);
  OFFSET(glovepose_estimator_config, smoothing_d_cutoff);
  SIZE(glovepose_hand_options);
  OFFSET(glovepose_hand_options, struct_size);
  OFFSET(glovepose_hand_options, handedness);
  OFFSET(glovepose_hand_options, prediction_window);
  OFFSET(glovepose_hand_options, max_prediction);
  SIZE(glovepose_pose);
  OFFSET(glovepose_pose, struct_size);
  OFFSET(glovepose_pose, flags);
  OFFSET(glovepose_pose, angles);
  OFFSET(glovepose_pose, raw_angles);
  OFFSET(glovepose_pose, timestamp);
  OFFSET(glovepose_pose, oldest_age);
  OFFSET(glovepose_pose, compute_seconds);
  OFFSET(glovepose_pose, sequence);
  OFFSET(glovepose_pose, rejected);
  OFFSET(glovepose_pose, valid);
  SIZE(glovepose_joint);
  OFFSET(glovepose_joint, position);
  OFFSET(glovepose_joint, rotation);
  SIZE(glovepose_xr_joint_location);
  OFFSET(glovepose_xr_joint_location, location_flags);
  OFFSET(glovepose_xr_joint_location, orientation);
  OFFSET(glovepose_xr_joint_location, position);
  OFFSET(glovepose_xr_joint_location, radius);
  SIZE(glovepose_xr_joint_velocity);
  OFFSET(glovepose_xr_joint_velocity, velocity_flags);
  OFFSET(glovepose_xr_joint_velocity, linear_velocity);
  OFFSET(glovepose_xr_joint_velocity, angular_velocity);
  SIZE(glovepose_xr_hand);
  OFFSET(glovepose_xr_hand, struct_size);
  OFFSET(glovepose_xr_hand, active);
  OFFSET(glovepose_xr_hand, predicted);
  OFFSET(glovepose_xr_hand, clamped);
  OFFSET(glovepose_xr_hand, handedness);
  OFFSET(glovepose_xr_hand, data_source);
  OFFSET(glovepose_xr_hand, time);
  OFFSET(glovepose_xr_hand, horizon);
  OFFSET(glovepose_xr_hand, locations);
  OFFSET(glovepose_xr_hand, velocities);
  SIZE(glovepose_xr_aim_state);
  OFFSET(glovepose_xr_aim_state, type);
  OFFSET(glovepose_xr_aim_state, next);
  OFFSET(glovepose_xr_aim_state, status);
  OFFSET(glovepose_xr_aim_state, aim_orientation);
  OFFSET(glovepose_xr_aim_state, aim_position);
  OFFSET(glovepose_xr_aim_state, pinch_strength_index);
  OFFSET(glovepose_xr_aim_state, pinch_strength_middle);
  OFFSET(glovepose_xr_aim_state, pinch_strength_ring);
  OFFSET(glovepose_xr_aim_state, pinch_strength_little);
  SIZE(glovepose_predicted_pose);
  OFFSET(glovepose_predicted_pose, struct_size);
  OFFSET(glovepose_predicted_pose, flags);
  OFFSET(glovepose_predicted_pose, angles);
  OFFSET(glovepose_predicted_pose, rate);
  OFFSET(glovepose_predicted_pose, time);
  OFFSET(glovepose_predicted_pose, horizon);
  OFFSET(glovepose_predicted_pose, predicted);
  OFFSET(glovepose_predicted_pose, clamped);
  OFFSET(glovepose_predicted_pose, has_rate);
  OFFSET(glovepose_predicted_pose, trusted);
  SIZE(glovepose_calibration_progress);
  OFFSET(glovepose_calibration_progress, struct_size);
  OFFSET(glovepose_calibration_progress, collecting);
  OFFSET(glovepose_calibration_progress, frames);
  OFFSET(glovepose_calibration_progress, frames_needed);
  OFFSET(glovepose_calibration_progress, ready);
  OFFSET(glovepose_calibration_progress, source);
  OFFSET(glovepose_calibration_progress, flat_cells);
  SIZE(glovepose_calibration_step);
  OFFSET(glovepose_calibration_step, struct_size);
  OFFSET(glovepose_calibration_step, step);
  OFFSET(glovepose_calibration_step, step_count);
  OFFSET(glovepose_calibration_step, pose);
  OFFSET(glovepose_calibration_step, start_seconds);
  OFFSET(glovepose_calibration_step, seconds);
  OFFSET(glovepose_calibration_step, name);
  OFFSET(glovepose_calibration_step, instruction);
}

static void write_constants(void) {
  CONST("Status", "Ok", GLOVEPOSE_OK);
  CONST("Status", "Solved", GLOVEPOSE_SOLVED);
  CONST("Status", "NotReady", GLOVEPOSE_NOT_READY);
  CONST("Status", "NonFinite", GLOVEPOSE_NON_FINITE);
  CONST("Status", "Negative", GLOVEPOSE_NEGATIVE);
  CONST("Status", "UnknownIndex", GLOVEPOSE_UNKNOWN_INDEX);
  CONST("Status", "TimestampBackwards", GLOVEPOSE_TIMESTAMP_BACKWARDS);
  CONST("Status", "SizeMismatch", GLOVEPOSE_SIZE_MISMATCH);
  CONST("Status", "Uncalibrated", GLOVEPOSE_UNCALIBRATED);
  CONST("Status", "ErrorInvalidArgument", GLOVEPOSE_ERROR_INVALID_ARGUMENT);
  CONST("Status", "ErrorInvalidHandle", GLOVEPOSE_ERROR_INVALID_HANDLE);
  CONST("Status", "ErrorStructSize", GLOVEPOSE_ERROR_STRUCT_SIZE);
  CONST("Status", "ErrorFileNotFound", GLOVEPOSE_ERROR_FILE_NOT_FOUND);
  CONST("Status", "ErrorInvalidFile", GLOVEPOSE_ERROR_INVALID_FILE);
  CONST("Status", "ErrorIo", GLOVEPOSE_ERROR_IO);
  CONST("Status", "ErrorCalibrationState", GLOVEPOSE_ERROR_CALIBRATION_STATE);
  CONST("Status", "ErrorDisabled", GLOVEPOSE_ERROR_DISABLED);
  CONST("Status", "ErrorOutOfMemory", GLOVEPOSE_ERROR_OUT_OF_MEMORY);
  CONST("Status", "ErrorInternal", GLOVEPOSE_ERROR_INTERNAL);
  CONST("WeightStorage", "F32", GLOVEPOSE_WEIGHTS_F32);
  CONST("WeightStorage", "F16", GLOVEPOSE_WEIGHTS_F16);
  CONST("WeightStorage", "Bf16", GLOVEPOSE_WEIGHTS_BF16);
  CONST("WeightStorage", "Fixed16", GLOVEPOSE_WEIGHTS_FIXED16);
  CONST("WeightStorage", "Realtime", GLOVEPOSE_WEIGHTS_REALTIME);
  CONST("Hand", "Right", GLOVEPOSE_HAND_RIGHT);
  CONST("Hand", "Left", GLOVEPOSE_HAND_LEFT);
  CONST("CalibrationSource", "None", GLOVEPOSE_CALIBRATION_NONE);
  CONST("CalibrationSource", "OnTheFly", GLOVEPOSE_CALIBRATION_ON_THE_FLY);
  CONST("CalibrationSource", "User", GLOVEPOSE_CALIBRATION_USER);
  CONST("CalibrationSource", "Training", GLOVEPOSE_CALIBRATION_TRAINING);
  CONST("CalibrationSource", "Continuous", GLOVEPOSE_CALIBRATION_CONTINUOUS);
  CONST("PoseFlags", "ReadingsRejected", GLOVEPOSE_POSE_READINGS_REJECTED);
  CONST("PoseFlags", "InputClamped", GLOVEPOSE_POSE_INPUT_CLAMPED);
  CONST("PoseFlags", "TrainingCalibration", GLOVEPOSE_POSE_TRAINING_CALIBRATION);
  CONST("PoseFlags", "Calibrating", GLOVEPOSE_POSE_CALIBRATING);
  CONST("PoseFlags", "StaleReadings", GLOVEPOSE_POSE_STALE_READINGS);
  CONST("PoseFlags", "Recovering", GLOVEPOSE_POSE_RECOVERING);
  CONST("PoseFlags", "StuckRows", GLOVEPOSE_POSE_STUCK_ROWS);
  CONST("PoseFlags", "DisconnectedRows", GLOVEPOSE_POSE_DISCONNECTED_ROWS);
  CONST("PoseFlags", "OutlierRows", GLOVEPOSE_POSE_OUTLIER_ROWS);
  CONST("PoseFlags", "MaskedCells", GLOVEPOSE_POSE_MASKED_CELLS);
  CONST("PoseFlags", "GloveOff", GLOVEPOSE_POSE_GLOVE_OFF);
  CONST("PoseFlags", "FaultFlags", GLOVEPOSE_POSE_FAULT_FLAGS);
  CONST("XrLocationFlags", "OrientationValid", GLOVEPOSE_XR_ORIENTATION_VALID);
  CONST("XrLocationFlags", "PositionValid", GLOVEPOSE_XR_POSITION_VALID);
  CONST("XrLocationFlags", "OrientationTracked", GLOVEPOSE_XR_ORIENTATION_TRACKED);
  CONST("XrLocationFlags", "PositionTracked", GLOVEPOSE_XR_POSITION_TRACKED);
  CONST("XrVelocityFlags", "LinearVelocityValid", GLOVEPOSE_XR_LINEAR_VELOCITY_VALID);
  CONST("XrVelocityFlags", "AngularVelocityValid", GLOVEPOSE_XR_ANGULAR_VELOCITY_VALID);
  CONST("XrAimFlags", "Computed", GLOVEPOSE_XR_AIM_COMPUTED);
  CONST("XrAimFlags", "Valid", GLOVEPOSE_XR_AIM_VALID);
  CONST("XrAimFlags", "IndexPinching", GLOVEPOSE_XR_AIM_INDEX_PINCHING);
  CONST("XrAimFlags", "MiddlePinching", GLOVEPOSE_XR_AIM_MIDDLE_PINCHING);
  CONST("XrAimFlags", "RingPinching", GLOVEPOSE_XR_AIM_RING_PINCHING);
  CONST("XrAimFlags", "LittlePinching", GLOVEPOSE_XR_AIM_LITTLE_PINCHING);
  CONST("XrAimFlags", "SystemGesture", GLOVEPOSE_XR_AIM_SYSTEM_GESTURE);
  CONST("XrAimFlags", "DominantHand", GLOVEPOSE_XR_AIM_DOMINANT_HAND);
  CONST("XrAimFlags", "MenuPressed", GLOVEPOSE_XR_AIM_MENU_PRESSED);
  CONST("Counts", "AbiVersion", GLOVEPOSE_C_ABI_VERSION);
  CONST("Counts", "Dof", GLOVEPOSE_DOF_COUNT);
  CONST("Counts", "Joints", GLOVEPOSE_JOINT_COUNT);
  CONST("Counts", "XrJoints", GLOVEPOSE_XR_JOINT_COUNT);
  CONST("Counts", "XrTypeHandTrackingAimStateFB", GLOVEPOSE_XR_TYPE_HAND_TRACKING_AIM_STATE_FB);
}

static void write_pose(const char* tag, const glovepose_pose* p) {
  int d;
  fprintf(out, "%s %llu %u %u %d", tag, (unsigned long long)p->sequence, (unsigned)p->flags, (unsigned)p->rejected, (int)p->valid);
  put_double(p->timestamp);
  put_double(p->oldest_age);
  for (d = 0; d < GLOVEPOSE_DOF_COUNT; ++d) put_double(p->angles[d]);
  for (d = 0; d < GLOVEPOSE_DOF_COUNT; ++d) put_double(p->raw_angles[d]);
  fprintf(out, "\n");
}

static void write_joints(const char* tag, const glovepose_joint* joints) {
  int j;
  fprintf(out, "%s", tag);
  for (j = 0; j < GLOVEPOSE_JOINT_COUNT; ++j) {
    put_floats(joints[j].position, 3);
    put_floats(joints[j].rotation, 4);
  }
  fprintf(out, "\n");
}

static void write_xr(const char* tag, double time, glovepose_result result, const glovepose_xr_hand* h) {
  int j;
  fprintf(out, "%s", tag);
  put_double(time);
  fprintf(out, " %d %d %d %d %d", (int)result, (int)h->active, (int)h->predicted, (int)h->clamped, (int)h->handedness);
  put_double(h->time);
  put_double(h->horizon);
  for (j = 0; j < GLOVEPOSE_XR_JOINT_COUNT; ++j) {
    fprintf(out, " %llu", (unsigned long long)h->locations[j].location_flags);
    put_floats(h->locations[j].orientation, 4);
    put_floats(h->locations[j].position, 3);
    put_float(h->locations[j].radius);
  }
  for (j = 0; j < GLOVEPOSE_XR_JOINT_COUNT; ++j) {
    fprintf(out, " %llu", (unsigned long long)h->velocities[j].velocity_flags);
    put_floats(h->velocities[j].linear_velocity, 3);
    put_floats(h->velocities[j].angular_velocity, 3);
  }
  fprintf(out, "\n");
}

static void write_aim(const char* tag, glovepose_result result, const glovepose_xr_aim_state* a) {
  fprintf(out, "%s %d %llu", tag, (int)result, (unsigned long long)a->status);
  put_floats(a->aim_orientation, 4);
  put_floats(a->aim_position, 3);
  put_float(a->pinch_strength_index);
  put_float(a->pinch_strength_middle);
  put_float(a->pinch_strength_ring);
  put_float(a->pinch_strength_little);
  fprintf(out, "\n");
}

static void write_doubles(const double* v, int n) {
  int i;
  for (i = 0; i < n; ++i) put_double(v[i]);
}

/* The reads not written per pose, after the session: each line holds the call's result and output. */
static void write_rest(const glovepose_model* model, const glovepose_estimator* estimator, double time, const char* range_path) {
  glovepose_predicted_pose at;
  glovepose_calibration_progress progress;
  glovepose_calibration_step step;
  double cells[44], lo[44], hi[44];
  glovepose_result result;
  int k;
  glovepose_predicted_pose_init(&at);
  result = glovepose_estimator_get_pose_at(estimator, time, &at);
  fprintf(out, "pose_at");
  put_double(time);
  fprintf(out, " %d %u %d %d %d %d", (int)result, (unsigned)at.flags, (int)at.predicted, (int)at.clamped, (int)at.has_rate, (int)at.trusted);
  put_double(at.time);
  put_double(at.horizon);
  write_doubles(at.angles, GLOVEPOSE_DOF_COUNT);
  write_doubles(at.rate, GLOVEPOSE_DOF_COUNT);
  fprintf(out, "\ncells %d", (int)glovepose_estimator_get_cells(estimator, cells, 44));
  write_doubles(cells, 44);
  glovepose_calibration_progress_init(&progress);
  result = glovepose_calibration_get_progress(estimator, &progress);
  fprintf(out, "\nprogress %d %d %lld %d %d %d %d\n", (int)result, (int)progress.collecting, (long long)progress.frames,
          (int)progress.frames_needed, (int)progress.ready, (int)progress.source, (int)progress.flat_cells);
  fprintf(out, "range %d", (int)glovepose_calibration_get_range(estimator, lo, hi, 44));
  write_doubles(lo, 44);
  write_doubles(hi, 44);
  fprintf(out, "\nsave %d\n", (int)glovepose_calibration_save(estimator, range_path));
  fprintf(out, "model %d %d %d %d %s %s %s\n", (int)glovepose_model_cell_count(model), (int)glovepose_model_row_count(model),
          (int)glovepose_model_has_training_range(model), (int)glovepose_model_calibration_step_count(model),
          glovepose_model_glove_id(model), glovepose_model_cell_name(model, 0), glovepose_model_cell_name(model, 43));
  for (k = 0; k < glovepose_model_calibration_step_count(model); ++k) {
    glovepose_calibration_step_init(&step);
    result = glovepose_model_get_calibration_step(model, k, &step);
    fprintf(out, "step %d %d %d %d", k, (int)result, (int)step.step, (int)step.step_count);
    put_floats(step.pose, GLOVEPOSE_DOF_COUNT);
    put_double(step.start_seconds);
    put_double(step.seconds);
    fprintf(out, " %s\ninstruction %s\n", step.name, step.instruction);
  }
}

/* The session's settings; PackageTest.cs sets the same three fields on the defaults. */
static void session_config(glovepose_estimator_config* config) {
  glovepose_estimator_config_default(config);
  config->readout_solve_every = 60; /* three poses per 180-row cycle */
  config->smoothing = 1;
  config->joint_transforms = 1;
}

/* Synthetic readout rows: each row breathes at its own rate around its own level (pF). */
static double row_value(int row, double t) { return 40.0 + 0.05 * row + 6.0 * sin(2.0 * 3.14159265358979 * (0.4 + 0.01 * row) * t + row); }

int main(int argc, char** argv) {
  glovepose_model* model = NULL;
  glovepose_estimator* estimator = NULL;
  glovepose_latest* latest = NULL;
  glovepose_estimator_config config;
  glovepose_pose pose;
  glovepose_joint joints[GLOVEPOSE_JOINT_COUNT];
  glovepose_xr_hand hand;
  glovepose_xr_aim_state aim;
  glovepose_result result;
  uint64_t number = 0, sequence = 0;
  const int calibration_frames = 30, frames = 60, rows = 180;
  int f, r, poses = 0;
  double last_timestamp = 0.0;
  if (argc != 5) {
    fprintf(stderr, "usage: %s MODEL MALFORMED_FILE OUT RANGE_FILE\n", argv[0]);
    return 2;
  }
  out = fopen(argv[3], "w");
  if (out == NULL) {
    fprintf(stderr, "cannot write %s\n", argv[3]);
    return 2;
  }
  write_layout();
  write_constants();

  result = glovepose_model_load(argv[2], GLOVEPOSE_WEIGHTS_F32, NULL, &model);
  fprintf(out, "error %d %s\n", (int)result, glovepose_last_error());
  if (result != GLOVEPOSE_ERROR_INVALID_FILE || model != NULL) {
    fprintf(stderr, "loading %s gave %d, expected GLOVEPOSE_ERROR_INVALID_FILE\n", argv[2], (int)result);
    return 1;
  }
  if (glovepose_model_load(argv[1], GLOVEPOSE_WEIGHTS_F32, NULL, &model) != GLOVEPOSE_OK || glovepose_model_row_count(model) != rows) {
    fprintf(stderr, "%s\n", glovepose_last_error());
    return 1;
  }
  session_config(&config);
  if (glovepose_estimator_create(model, &config, &estimator) != GLOVEPOSE_OK || glovepose_latest_create(&latest) != GLOVEPOSE_OK) {
    fprintf(stderr, "%s\n", glovepose_last_error());
    return 1;
  }
  glovepose_pose_init(&pose);
  glovepose_xr_hand_init(&hand);
  glovepose_xr_aim_state_init(&aim);

  fprintf(out, "start %d\n", (int)glovepose_calibration_start(estimator));
  for (f = 0; f < frames; ++f) {
    if (f == calibration_frames) fprintf(out, "finish %d\n", (int)glovepose_calibration_finish(estimator));
    if (f == calibration_frames / 2 || f == calibration_frames + 1) { /* the guided step under way, and none after finishing */
      int32_t step = -9;
      double seconds = -9.0;
      result = glovepose_calibration_get_step(estimator, &step, &seconds);
      fprintf(out, "calibration_step %d %d", (int)result, (int)step);
      put_double(seconds);
      fprintf(out, "\n");
    }
    for (r = 0; r < rows; ++r) {
      const double t = glovepose_row_time((f + 1) / 60.0, r, rows, 60.0);
      const double value = row_value(r, t);
      result = glovepose_estimator_push_row(estimator, r, value, t);
      fprintf(out, "push %d", r);
      put_double(value);
      put_double(t);
      fprintf(out, " %d\n", (int)result);
      if (result != GLOVEPOSE_SOLVED) continue;
      ++poses;
      last_timestamp = t;
      glovepose_estimator_get_pose(estimator, &pose);
      write_pose("pose", &pose);
      glovepose_estimator_get_joints(estimator, joints, GLOVEPOSE_JOINT_COUNT);
      write_joints("joints", joints);
      result = glovepose_estimator_get_xr_joints(estimator, t + 0.01, &hand);
      write_xr("xr", t + 0.01, result, &hand);
      result = glovepose_estimator_get_xr_aim(estimator, &aim);
      write_aim("aim", result, &aim);
      glovepose_latest_publish(latest, estimator);
    }
  }
  /* A reader's view of the last published hand. */
  glovepose_pose_init(&pose);
  result = glovepose_latest_read(latest, &pose, joints, GLOVEPOSE_JOINT_COUNT, &number);
  fprintf(out, "latest_read %d %llu\n", (int)result, (unsigned long long)number);
  write_pose("latest_pose", &pose);
  write_joints("latest_joints", joints);
  result = glovepose_latest_get_xr_joints(latest, estimator, last_timestamp + 0.02, &hand);
  write_xr("latest_xr", last_timestamp + 0.02, result, &hand);
  result = glovepose_latest_get_xr_aim(latest, &aim, &sequence);
  fprintf(out, "latest_sequence %llu\n", (unsigned long long)sequence);
  write_aim("latest_aim", result, &aim);
  write_rest(model, estimator, last_timestamp + 0.03, argv[4]);
  fprintf(out, "end %d\n", poses);
  glovepose_latest_free(latest);
  glovepose_estimator_free(estimator);
  glovepose_model_free(model);
  if (fclose(out) != 0 || poses < 30) {
    fprintf(stderr, "%d poses (expected at least 30), or %s not written\n", poses, argv[3]);
    return 1;
  }
  return 0;
}
