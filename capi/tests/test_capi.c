/* Every function of the C ABI from C, with its error paths: bad paths (code + a message naming the
 * file), null and mixed-up handles, wrong struct sizes and counts, the calibration state machine
 * (finish too early, cancel, save/load, set/get range, the training range), poses and joints.
 *
 * Usage: capi_test_c MODEL DIR   (DIR holds the files `capi_cpp_reference write-fixtures` wrote)
 * Prints each failed check and, last, "N passed, N failed"; exit code 0 when none failed. */
#include "glovepose_c.h"

#include <openxr/openxr.h>

#include <math.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static int passed = 0;
static int failed = 0;

#define CHECK(condition)                                            \
  do {                                                              \
    if (condition) {                                                \
      ++passed;                                                     \
    } else {                                                        \
      ++failed;                                                     \
      printf("FAILED %s:%d: %s\n", __FILE__, __LINE__, #condition); \
    }                                                               \
  } while (0)

/* A call's result code, with the last error printed when it differs from the expected one. */
#define CHECK_RESULT(call, expected)                                                                                      \
  do {                                                                                                                    \
    glovepose_result result_ = (call);                                                                                    \
    if (result_ == (expected)) {                                                                                          \
      ++passed;                                                                                                           \
    } else {                                                                                                              \
      ++failed;                                                                                                           \
      printf("FAILED %s:%d: %s returned %d (%s), expected %s; last error: %s\n", __FILE__, __LINE__, #call, (int)result_, \
             glovepose_result_name(result_), #expected, glovepose_last_error());                                          \
    }                                                                                                                     \
  } while (0)

static int contains(const char* text, const char* part) { return text != NULL && strstr(text, part) != NULL; }

static char paths[8][1024];
static const char* path_in(int slot, const char* dir, const char* name) {
  snprintf(paths[slot], sizeof paths[slot], "%s/%s", dir, name);
  return paths[slot];
}

/* A synthetic glove: cell c breathes between 15 and 25 pF + c/10 at its own rate. */
static void synthetic_cells(double t, double* cells, int count) {
  int c;
  for (c = 0; c < count; ++c) cells[c] = 20.0 + 0.1 * c + 5.0 * sin(2.0 * 3.14159265358979 * (0.7 + 0.05 * c) * t + c);
}

/* Pushes `frames` frames of synthetic cells at 60 Hz from `t0`; returns how many gave a pose. */
static int push_synthetic(glovepose_estimator* estimator, double t0, int frames) {
  double cells[44];
  int f, solved = 0;
  for (f = 0; f < frames; ++f) {
    const double t = t0 + f / 60.0;
    synthetic_cells(t, cells, 44);
    if (glovepose_estimator_push_cells(estimator, cells, 44, t, 0.0) == GLOVEPOSE_SOLVED) ++solved;
  }
  return solved;
}

static void test_library(void) {
  CHECK(glovepose_abi_version() == GLOVEPOSE_C_ABI_VERSION);
  /* The row clock: the last row of a cycle at its end, rows one slot of 1 / (rows * rate) apart. */
  CHECK(glovepose_row_time(2.0, 179, 180, 60.0) == 2.0);
  CHECK(fabs(glovepose_row_time(2.0, 0, 180, 60.0) - (2.0 - 179.0 / 10800.0)) < 1e-12);
  CHECK(fabs(glovepose_row_time(2.0, 90, 180, 60.0) - glovepose_row_time(2.0, 89, 180, 60.0) - 1.0 / 10800.0) < 1e-12);
  CHECK(glovepose_row_time(1.0, 0, 1, 50.0) == 1.0);
  CHECK(isnan(glovepose_row_time(2.0, 180, 180, 60.0)) && isnan(glovepose_row_time(2.0, -1, 180, 60.0)));
  CHECK(isnan(glovepose_row_time(2.0, 0, 0, 60.0)) && isnan(glovepose_row_time(2.0, 0, 180, 0.0)));
  CHECK(isnan(glovepose_row_time(2.0, 0, 180, INFINITY)) && isnan(glovepose_row_time(2.0, 0, 180, NAN)));
  CHECK(strcmp(glovepose_version(), GLOVEPOSE_EXPECTED_VERSION) == 0);
  /* The instruction set the networks run: one the library holds; GLOVEPOSE_ISA's when it is set. */
  {
    const char* isa = glovepose_isa();
    const char* asked = getenv("GLOVEPOSE_ISA");
    CHECK(isa != NULL);
    if (isa != NULL) {
      CHECK(strcmp(isa, "sse2") == 0 || strcmp(isa, "avx2") == 0 || strcmp(isa, "avx512") == 0 || strcmp(isa, "neon") == 0);
      if (asked != NULL && asked[0] != '\0') CHECK(strcmp(isa, asked) == 0);
      CHECK(glovepose_isa() == isa); /* one choice per process */
    }
  }
  CHECK(strcmp(glovepose_result_name(GLOVEPOSE_SOLVED), "solved") == 0);
  CHECK(strcmp(glovepose_result_name(GLOVEPOSE_UNCALIBRATED), "uncalibrated") == 0);
  CHECK(strcmp(glovepose_result_name(GLOVEPOSE_ERROR_FILE_NOT_FOUND), "file not found") == 0);
  CHECK(strcmp(glovepose_result_name(GLOVEPOSE_ERROR_INTERNAL), "internal error") == 0);
  CHECK(strcmp(glovepose_result_name(1234), "unknown result") == 0);
  CHECK(strcmp(glovepose_dof_name(0), "thumb_base_abduction") == 0);
  CHECK(strcmp(glovepose_dof_name(1), "thumb_base_flexion") == 0);
  CHECK(glovepose_dof_name(GLOVEPOSE_DOF_COUNT - 1) != NULL);
  CHECK(glovepose_dof_name(GLOVEPOSE_DOF_COUNT) == NULL);
  CHECK(glovepose_dof_name(-1) == NULL);
  CHECK(strcmp(glovepose_joint_name(0), "palm") == 0);
  CHECK(strcmp(glovepose_joint_name(12), "middle_tip") == 0);
  CHECK(glovepose_joint_name(GLOVEPOSE_JOINT_COUNT) == NULL);
  CHECK(glovepose_joint_parent(0) == -1);
  CHECK(glovepose_joint_parent(4) == 3);
  CHECK(glovepose_joint_parent(5) == 0);
  CHECK(glovepose_joint_parent(21) == -2);
  CHECK(glovepose_joint_parent(-1) == -2);
  /* The documented ABI-1 sizes (C# and ctypes mirror them). */
  CHECK(sizeof(glovepose_estimator_config) == 80);
  CHECK(sizeof(glovepose_hand_options) == 24);
  CHECK(sizeof(glovepose_xr_joint_location) == 40);
  CHECK(sizeof(glovepose_xr_joint_velocity) == 32);
  CHECK(sizeof(glovepose_xr_hand) == 1912);
  CHECK(sizeof(glovepose_predicted_pose) == 440);
  CHECK(strcmp(glovepose_xr_joint_name(0), "palm") == 0);
  CHECK(strcmp(glovepose_xr_joint_name(6), "index_metacarpal") == 0);
  CHECK(strcmp(glovepose_xr_joint_name(25), "little_tip") == 0);
  CHECK(glovepose_xr_joint_name(GLOVEPOSE_XR_JOINT_COUNT) == NULL);
  CHECK(glovepose_xr_joint_parent(1) == -1);
  CHECK(glovepose_xr_joint_parent(0) == 1);
  CHECK(glovepose_xr_joint_parent(7) == 6);
  CHECK(glovepose_xr_joint_parent(26) == -2);
  CHECK(sizeof(glovepose_pose) == 448);
  CHECK(sizeof(glovepose_joint) == 28);
  CHECK(sizeof(glovepose_calibration_progress) == 32);
  CHECK(sizeof(glovepose_calibration_step) == 1184);
}

static void test_model_errors(const char* model_path, const char* dir) {
  glovepose_model* model = (glovepose_model*)&passed; /* must be overwritten with NULL on failure */
  const char* missing = "/nonexistent/glovepose/model.safetensors";
  CHECK_RESULT(glovepose_model_load(missing, GLOVEPOSE_WEIGHTS_F32, NULL, &model), GLOVEPOSE_ERROR_FILE_NOT_FOUND);
  CHECK(model == NULL);
  CHECK(contains(glovepose_last_error(), missing));
  /* A readable file that is not a model: its contents are refused, and the message names it. */
  CHECK_RESULT(glovepose_model_load(path_in(0, dir, "glauser2019-44.json"), GLOVEPOSE_WEIGHTS_F32, NULL, &model),
               GLOVEPOSE_ERROR_INVALID_FILE);
  CHECK(contains(glovepose_last_error(), "glauser2019-44.json"));
  CHECK_RESULT(glovepose_model_load(model_path, GLOVEPOSE_WEIGHTS_F32, NULL, NULL), GLOVEPOSE_ERROR_INVALID_ARGUMENT);
  CHECK_RESULT(glovepose_model_load(NULL, GLOVEPOSE_WEIGHTS_F32, NULL, &model), GLOVEPOSE_ERROR_INVALID_ARGUMENT);
  CHECK_RESULT(glovepose_model_load(model_path, 7, NULL, &model), GLOVEPOSE_ERROR_INVALID_ARGUMENT);
  CHECK(contains(glovepose_last_error(), "weight_storage 7"));
  /* The glove description file: missing, and of another glove than the model's. */
  CHECK_RESULT(glovepose_model_load(model_path, GLOVEPOSE_WEIGHTS_F32, path_in(1, dir, "no-such-glove.json"), &model),
               GLOVEPOSE_ERROR_FILE_NOT_FOUND);
  CHECK(contains(glovepose_last_error(), "no-such-glove.json"));
  CHECK_RESULT(glovepose_model_load(model_path, GLOVEPOSE_WEIGHTS_F32, path_in(2, dir, "another-glove.json"), &model),
               GLOVEPOSE_ERROR_INVALID_FILE);
  CHECK(contains(glovepose_last_error(), "another-glove"));
  CHECK(model == NULL);
  /* Queries on a null handle. */
  CHECK(glovepose_model_cell_count(NULL) == -1);
  CHECK(contains(glovepose_last_error(), "invalid model handle"));
  CHECK(glovepose_model_row_count(NULL) == -1);
  CHECK(glovepose_model_glove_id(NULL) == NULL);
  CHECK(glovepose_model_cell_name(NULL, 0) == NULL);
  CHECK(glovepose_model_has_training_range(NULL) == -1);
  CHECK(glovepose_model_has_range_map(NULL) == -1);
  CHECK(glovepose_model_has_pose_error(NULL) == -1);
  glovepose_model_free(NULL); /* ignored */
}

/* The pose with 16-bit weights is the pose of F32 weights up to rounding: the largest angle
 * difference (degrees) on the synthetic input, which must be nonzero (the storage is really in use). */
static double angle_difference_degrees(glovepose_model* exact, glovepose_model* rounded) {
  glovepose_estimator* a = NULL;
  glovepose_estimator* b = NULL;
  glovepose_pose pa, pb;
  double worst = 0.0, lo[44], hi[44];
  int c, d;
  CHECK_RESULT(glovepose_estimator_create(exact, NULL, &a), GLOVEPOSE_OK);
  CHECK_RESULT(glovepose_estimator_create(rounded, NULL, &b), GLOVEPOSE_OK);
  for (c = 0; c < 44; ++c) {
    lo[c] = 15.0 + 0.1 * c;
    hi[c] = 25.0 + 0.1 * c;
  }
  CHECK_RESULT(glovepose_calibration_set_range(a, lo, hi, 44), GLOVEPOSE_OK);
  CHECK_RESULT(glovepose_calibration_set_range(b, lo, hi, 44), GLOVEPOSE_OK);
  CHECK(push_synthetic(a, 0.0, 10) == 10);
  CHECK(push_synthetic(b, 0.0, 10) == 10);
  glovepose_pose_init(&pa);
  glovepose_pose_init(&pb);
  CHECK_RESULT(glovepose_estimator_get_pose(a, &pa), GLOVEPOSE_OK);
  CHECK_RESULT(glovepose_estimator_get_pose(b, &pb), GLOVEPOSE_OK);
  for (d = 0; d < GLOVEPOSE_DOF_COUNT; ++d) worst = fmax(worst, fabs(pa.angles[d] - pb.angles[d]));
  glovepose_estimator_free(a);
  glovepose_estimator_free(b);
  return worst * 180.0 / 3.14159265358979;
}

static void test_model(glovepose_model* model, const char* model_path, const char* dir) {
  glovepose_model* f16 = NULL;
  glovepose_model* bf16 = NULL;
  glovepose_model* fixed16 = NULL;
  glovepose_model* with_glove = NULL;
  glovepose_model* with_training = NULL;
  CHECK(glovepose_model_cell_count(model) == 44);
  CHECK(glovepose_model_row_count(model) == 180);
  CHECK(strcmp(glovepose_model_glove_id(model), "glauser2019-44") == 0);
  CHECK(strcmp(glovepose_model_cell_name(model, 0), "cell_0") == 0);
  CHECK(strcmp(glovepose_model_cell_name(model, 43), "cell_43") == 0);
  CHECK(glovepose_model_cell_name(model, 44) == NULL);
  CHECK(contains(glovepose_last_error(), "cell 44, expected 0..43"));
  CHECK(glovepose_model_cell_name(model, -1) == NULL);
  CHECK(glovepose_model_has_training_range(model) == 0);

  CHECK_RESULT(glovepose_model_load(model_path, GLOVEPOSE_WEIGHTS_F16, NULL, &f16), GLOVEPOSE_OK);
  CHECK(glovepose_model_cell_count(f16) == 44);
  CHECK_RESULT(glovepose_model_load(model_path, GLOVEPOSE_WEIGHTS_BF16, NULL, &bf16), GLOVEPOSE_OK);
  CHECK_RESULT(glovepose_model_load(model_path, GLOVEPOSE_WEIGHTS_FIXED16, NULL, &fixed16), GLOVEPOSE_OK);
  CHECK_RESULT(glovepose_model_load(model_path, GLOVEPOSE_WEIGHTS_F32, path_in(3, dir, "glauser2019-44.json"), &with_glove), GLOVEPOSE_OK);
  CHECK(strcmp(glovepose_model_glove_id(with_glove), "glauser2019-44") == 0);
  CHECK_RESULT(glovepose_model_load(path_in(4, dir, "training_range.safetensors"), GLOVEPOSE_WEIGHTS_F32, NULL, &with_training),
               GLOVEPOSE_OK);
  CHECK(glovepose_model_has_training_range(with_training) == 1);
  CHECK(glovepose_model_has_range_map(with_training) == 0);

  /* 16-bit weights: the pose of F32 up to rounding. The shipped FCN's file holds binary16 weights
   * and an FCN has no batch norm to fold, so F16 keeps them exactly; Fixed16 rounds each weight to
   * 2^-16 of its channel's largest (this synthetic input: 0.0012 degree, bound 0.05); BF16 keeps 8
   * significant bits (0.082 degree here), so only its order of magnitude is checked. */
  {
    glovepose_estimator* a = NULL;
    double f16_degrees, bf16_degrees, fixed16_degrees;
    CHECK_RESULT(glovepose_estimator_create(model, NULL, &a), GLOVEPOSE_OK);
    CHECK_RESULT(glovepose_calibration_use_training(a), GLOVEPOSE_ERROR_CALIBRATION_STATE);
    CHECK(contains(glovepose_last_error(), "no training-set range"));
    glovepose_estimator_free(a);
    CHECK_RESULT(glovepose_estimator_create(with_training, NULL, &a), GLOVEPOSE_OK);
    CHECK_RESULT(glovepose_calibration_use_continuous(a), GLOVEPOSE_ERROR_CALIBRATION_STATE);
    CHECK(contains(glovepose_last_error(), "no range map"));
    glovepose_estimator_free(a);
    f16_degrees = angle_difference_degrees(model, f16);
    bf16_degrees = angle_difference_degrees(model, bf16);
    fixed16_degrees = angle_difference_degrees(model, fixed16);
    printf("16-bit vs F32 weights: largest angle difference %.3g degrees (F16), %.3g degrees (BF16), %.3g degrees (Fixed16)\n", f16_degrees,
           bf16_degrees, fixed16_degrees);
    CHECK(fixed16_degrees > 0.0);
    CHECK(fixed16_degrees < 0.05);
    /* The real-time choice is one of the storages within 0.1 degree of F32. */
    {
      glovepose_model* realtime = NULL;
      CHECK_RESULT(glovepose_model_load(model_path, GLOVEPOSE_WEIGHTS_REALTIME, NULL, &realtime), GLOVEPOSE_OK);
      CHECK(angle_difference_degrees(model, realtime) < 0.1);
      glovepose_model_free(realtime);
    }
    CHECK(f16_degrees == 0.0);
    CHECK(bf16_degrees > fixed16_degrees);
    CHECK(bf16_degrees < 1.0);
  }

  /* The training range: the pose is flagged as such. */
  {
    glovepose_estimator* e = NULL;
    glovepose_pose pose;
    glovepose_calibration_progress progress;
    CHECK_RESULT(glovepose_estimator_create(with_training, NULL, &e), GLOVEPOSE_OK);
    CHECK_RESULT(glovepose_calibration_use_training(e), GLOVEPOSE_OK);
    glovepose_calibration_progress_init(&progress);
    CHECK_RESULT(glovepose_calibration_get_progress(e, &progress), GLOVEPOSE_OK);
    CHECK(progress.source == GLOVEPOSE_CALIBRATION_TRAINING);
    CHECK(push_synthetic(e, 0.0, 1) == 1);
    glovepose_pose_init(&pose);
    CHECK_RESULT(glovepose_estimator_get_pose(e, &pose), GLOVEPOSE_OK);
    CHECK((pose.flags & GLOVEPOSE_POSE_TRAINING_CALIBRATION) != 0);
    glovepose_estimator_free(e);
  }
  glovepose_model_free(f16);
  glovepose_model_free(bf16);
  glovepose_model_free(fixed16);
  glovepose_model_free(with_glove);
  glovepose_model_free(with_training);
}

static void test_create(glovepose_model* model) {
  glovepose_estimator_config config;
  glovepose_estimator* e = (glovepose_estimator*)&passed;
  CHECK_RESULT(glovepose_estimator_config_default(NULL), GLOVEPOSE_ERROR_INVALID_ARGUMENT);
  CHECK_RESULT(glovepose_estimator_config_default(&config), GLOVEPOSE_OK);
  CHECK(config.struct_size == sizeof config);
  CHECK(config.readout_mean_window == 1); /* glovepose::realtime_readout(); the paper's is 5 */
  CHECK(config.readout_solve_every == 16);
  CHECK(config.calibration_median_window == 0);         /* the glove's: 20 frames for the built-in glove */
  CHECK(config.calibration_min_relative_range == -1.0); /* the glove's: 0.01 */
  CHECK(fabs(config.calibration_sample_period - 1.0 / 60.0) < 1e-15);
  CHECK(config.smoothing == 0);
  CHECK(config.joint_transforms == 0);
  CHECK(config.smoothing_frequency == 60.0);

  CHECK_RESULT(glovepose_estimator_create(model, &config, NULL), GLOVEPOSE_ERROR_INVALID_ARGUMENT);
  CHECK_RESULT(glovepose_estimator_create(NULL, &config, &e), GLOVEPOSE_ERROR_INVALID_HANDLE);
  CHECK(e == NULL);
  CHECK(contains(glovepose_last_error(), "invalid model handle"));
  config.struct_size = 72;
  CHECK_RESULT(glovepose_estimator_create(model, &config, &e), GLOVEPOSE_ERROR_STRUCT_SIZE);
  CHECK(contains(glovepose_last_error(), "struct_size 72, expected 80"));
  config.struct_size = sizeof config;
  config.readout_mean_window = 0;
  CHECK_RESULT(glovepose_estimator_create(model, &config, &e), GLOVEPOSE_ERROR_INVALID_ARGUMENT);
  CHECK(strlen(glovepose_last_error()) > 0);
  config.readout_mean_window = 5;
  config.calibration_sample_period = -1.0;
  CHECK_RESULT(glovepose_estimator_create(model, &config, &e), GLOVEPOSE_ERROR_INVALID_ARGUMENT);
  CHECK(contains(glovepose_last_error(), "calibration_sample_period"));
  config.calibration_sample_period = 1.0 / 60.0;
  config.smoothing = 1;
  config.smoothing_min_cutoff = 0.0;
  CHECK_RESULT(glovepose_estimator_create(model, &config, &e), GLOVEPOSE_ERROR_INVALID_ARGUMENT);
  config.smoothing_min_cutoff = 1.0;
  config.calibration_median_window = -1;
  CHECK_RESULT(glovepose_estimator_create(model, &config, &e), GLOVEPOSE_ERROR_INVALID_ARGUMENT);
  CHECK(contains(glovepose_last_error(), "median window"));
  config.calibration_median_window = 0;
  CHECK_RESULT(glovepose_estimator_create(model, &config, &e), GLOVEPOSE_OK);
  CHECK(e != NULL);
  /* A model handle is not an estimator handle (both are plain pointers in C# and Python). */
  CHECK_RESULT(glovepose_estimator_reset((glovepose_estimator*)model), GLOVEPOSE_ERROR_INVALID_HANDLE);
  {
    glovepose_estimator* not_created = NULL;
    CHECK_RESULT(glovepose_estimator_create((const glovepose_model*)e, &config, &not_created), GLOVEPOSE_ERROR_INVALID_HANDLE);
    CHECK(not_created == NULL);
  }
  glovepose_estimator_free(e);
  glovepose_estimator_free(NULL); /* ignored */
}

static void test_null_estimator(void) {
  double values[180] = {0};
  glovepose_pose pose;
  glovepose_joint joints[GLOVEPOSE_JOINT_COUNT];
  glovepose_calibration_progress progress;
  glovepose_pose_init(&pose);
  glovepose_calibration_progress_init(&progress);
  CHECK_RESULT(glovepose_estimator_push_row(NULL, 0, 1.0, 0.0), GLOVEPOSE_ERROR_INVALID_HANDLE);
  CHECK(contains(glovepose_last_error(), "invalid estimator handle"));
  CHECK_RESULT(glovepose_estimator_push_measurements(NULL, values, 180, 0.0), GLOVEPOSE_ERROR_INVALID_HANDLE);
  CHECK_RESULT(glovepose_estimator_push_cells(NULL, values, 44, 0.0, 0.0), GLOVEPOSE_ERROR_INVALID_HANDLE);
  CHECK_RESULT(glovepose_estimator_get_pose(NULL, &pose), GLOVEPOSE_ERROR_INVALID_HANDLE);
  CHECK_RESULT(glovepose_estimator_get_joints(NULL, joints, GLOVEPOSE_JOINT_COUNT), GLOVEPOSE_ERROR_INVALID_HANDLE);
  CHECK_RESULT(glovepose_estimator_get_cells(NULL, values, 44), GLOVEPOSE_ERROR_INVALID_HANDLE);
  CHECK_RESULT(glovepose_estimator_reset(NULL), GLOVEPOSE_ERROR_INVALID_HANDLE);
  CHECK_RESULT(glovepose_calibration_start(NULL), GLOVEPOSE_ERROR_INVALID_HANDLE);
  CHECK_RESULT(glovepose_calibration_get_progress(NULL, &progress), GLOVEPOSE_ERROR_INVALID_HANDLE);
  CHECK_RESULT(glovepose_calibration_finish(NULL), GLOVEPOSE_ERROR_INVALID_HANDLE);
  CHECK_RESULT(glovepose_calibration_cancel(NULL), GLOVEPOSE_ERROR_INVALID_HANDLE);
  CHECK_RESULT(glovepose_calibration_load(NULL, "x"), GLOVEPOSE_ERROR_INVALID_HANDLE);
  CHECK_RESULT(glovepose_calibration_save(NULL, "x"), GLOVEPOSE_ERROR_INVALID_HANDLE);
  CHECK_RESULT(glovepose_calibration_use_training(NULL), GLOVEPOSE_ERROR_INVALID_HANDLE);
  CHECK_RESULT(glovepose_calibration_use_continuous(NULL), GLOVEPOSE_ERROR_INVALID_HANDLE);
  CHECK_RESULT(glovepose_calibration_clear(NULL), GLOVEPOSE_ERROR_INVALID_HANDLE);
  CHECK_RESULT(glovepose_calibration_set_range(NULL, values, values, 44), GLOVEPOSE_ERROR_INVALID_HANDLE);
  CHECK_RESULT(glovepose_calibration_get_range(NULL, values, values, 44), GLOVEPOSE_ERROR_INVALID_HANDLE);
  glovepose_pose_init(NULL);                 /* ignored */
  glovepose_calibration_progress_init(NULL); /* ignored */
}

/* Rows: the statuses of bad readings, and the calibration state machine on a row stream. */
static void test_rows_and_calibration(glovepose_model* model, const char* dir) {
  glovepose_estimator* e = NULL;
  glovepose_estimator* other = NULL;
  glovepose_estimator_config config;
  glovepose_calibration_progress progress;
  glovepose_pose pose;
  double frame[180], lo[44], hi[44], lo2[44], hi2[44], cells[44], confidence[GLOVEPOSE_DOF_COUNT];
  int f, r, solved = 0, uncalibrated = 0, refused = 0;
  double t = 0.0;
  glovepose_estimator_config_default(&config);
  config.readout_solve_every = 180; /* one solve per cycle: one pose per frame */
  CHECK_RESULT(glovepose_estimator_create(model, &config, &e), GLOVEPOSE_OK);
  glovepose_calibration_progress_init(&progress);
  glovepose_pose_init(&pose);
  /* The shipped model carries a range map: a new estimator calibrates from the wearer's motion,
   * its prior range in use at once; cleared, it waits for a calibration. */
  CHECK(glovepose_model_has_range_map(model) == 1);
  CHECK(glovepose_model_has_pose_error(model) == 1); /* its own errors: the confidence */
  CHECK_RESULT(glovepose_calibration_get_progress(e, &progress), GLOVEPOSE_OK);
  CHECK(progress.source == GLOVEPOSE_CALIBRATION_CONTINUOUS);
  CHECK_RESULT(glovepose_calibration_get_range(e, lo, hi, 44), GLOVEPOSE_OK);
  CHECK(lo[0] < hi[0]);
  CHECK_RESULT(glovepose_calibration_clear(e), GLOVEPOSE_OK);
  CHECK_RESULT(glovepose_calibration_get_progress(e, &progress), GLOVEPOSE_OK);
  CHECK(progress.source == GLOVEPOSE_CALIBRATION_NONE);
  CHECK_RESULT(glovepose_calibration_use_continuous(e), GLOVEPOSE_OK);
  CHECK_RESULT(glovepose_calibration_get_progress(e, &progress), GLOVEPOSE_OK);
  CHECK(progress.source == GLOVEPOSE_CALIBRATION_CONTINUOUS);
  CHECK_RESULT(glovepose_calibration_clear(e), GLOVEPOSE_OK);

  CHECK_RESULT(glovepose_estimator_push_row(e, -1, 30.0, 0.0), GLOVEPOSE_UNKNOWN_INDEX);
  CHECK_RESULT(glovepose_estimator_push_row(e, 180, 30.0, 0.0), GLOVEPOSE_UNKNOWN_INDEX);
  CHECK_RESULT(glovepose_estimator_push_row(e, 0, NAN, 0.0), GLOVEPOSE_NON_FINITE);
  CHECK_RESULT(glovepose_estimator_push_row(e, 0, -1.0, 0.0), GLOVEPOSE_NEGATIVE);
  CHECK_RESULT(glovepose_estimator_push_row(e, 0, 30.0, 5.0), GLOVEPOSE_NOT_READY); /* accepted; the ring is not full */
  CHECK_RESULT(glovepose_estimator_push_row(e, 0, 30.0, 4.0), GLOVEPOSE_TIMESTAMP_BACKWARDS);
  CHECK_RESULT(glovepose_estimator_reset(e), GLOVEPOSE_OK);
  CHECK_RESULT(glovepose_estimator_push_row(e, 0, 30.0, 4.0), GLOVEPOSE_NOT_READY); /* reset forgot the clock */
  CHECK_RESULT(glovepose_estimator_reset(e), GLOVEPOSE_OK);
  CHECK_RESULT(glovepose_estimator_push_measurements(e, frame, 179, 0.0), GLOVEPOSE_SIZE_MISMATCH);
  CHECK_RESULT(glovepose_estimator_push_measurements(e, NULL, 180, 0.0), GLOVEPOSE_SIZE_MISMATCH);

  CHECK_RESULT(glovepose_calibration_finish(e), GLOVEPOSE_ERROR_CALIBRATION_STATE);
  CHECK(contains(glovepose_last_error(), "start_calibration"));
  CHECK_RESULT(glovepose_calibration_save(e, path_in(5, dir, "none.calibration")), GLOVEPOSE_ERROR_CALIBRATION_STATE);
  CHECK_RESULT(glovepose_calibration_get_range(e, lo, hi, 44), GLOVEPOSE_UNCALIBRATED);

  /* A row stream of a synthetic glove: each row reads a sum of breathing cells. Frames before a
   * calibration solve but give no pose. */
  for (f = 0; f < 60; ++f) {
    if (f == 10) CHECK_RESULT(glovepose_calibration_start(e), GLOVEPOSE_OK);
    if (f == 20) {
      CHECK_RESULT(glovepose_calibration_get_progress(e, &progress), GLOVEPOSE_OK);
      CHECK(progress.collecting == 1);
      CHECK(progress.frames == 10);
      CHECK(progress.frames_needed == 20);
      CHECK(progress.ready == 0);
      CHECK(progress.source == GLOVEPOSE_CALIBRATION_NONE);
      CHECK_RESULT(glovepose_calibration_finish(e), GLOVEPOSE_ERROR_CALIBRATION_STATE);
      CHECK(contains(glovepose_last_error(), "expected at least 20"));
      CHECK_RESULT(glovepose_calibration_get_progress(e, &progress), GLOVEPOSE_OK);
      CHECK(progress.collecting == 1); /* it keeps collecting */
    }
    if (f == 40) {
      CHECK_RESULT(glovepose_calibration_get_progress(e, &progress), GLOVEPOSE_OK);
      CHECK(progress.ready == 1);
      CHECK_RESULT(glovepose_calibration_finish(e), GLOVEPOSE_OK);
      CHECK_RESULT(glovepose_calibration_get_progress(e, &progress), GLOVEPOSE_OK);
      CHECK(progress.collecting == 0);
      CHECK(progress.source == GLOVEPOSE_CALIBRATION_ON_THE_FLY);
      CHECK(progress.flat_cells >= 0 && progress.flat_cells < 44);
    }
    t = f / 60.0;
    synthetic_cells(t, cells, 44);
    for (r = 0; r < 180; ++r) {
      /* Row r sums two cells (a stand-in wiring; the solve finds some cells from any rows). */
      const glovepose_result result =
          glovepose_estimator_push_row(e, r, cells[r % 44] + cells[(r / 15) % 44], glovepose_row_time(t, r, 180, 60.0));
      if (result == GLOVEPOSE_SOLVED) ++solved;
      if (result == GLOVEPOSE_UNCALIBRATED) ++uncalibrated;
      if (result != GLOVEPOSE_SOLVED && result != GLOVEPOSE_UNCALIBRATED && result != GLOVEPOSE_OK && result != GLOVEPOSE_NOT_READY)
        ++refused;
    }
  }
  CHECK(refused == 0);
  CHECK(uncalibrated == 40);
  CHECK(solved == 20);
  CHECK_RESULT(glovepose_estimator_get_pose(e, &pose), GLOVEPOSE_OK);
  CHECK(pose.valid == 1);
  CHECK(pose.sequence == 20);
  CHECK(fabs(pose.timestamp - t) < 1e-12);
  CHECK(pose.oldest_age > 0.0);
  CHECK(pose.compute_seconds > 0.0);
  for (f = 0; f < GLOVEPOSE_DOF_COUNT; ++f) CHECK(isfinite(pose.angles[f]) && pose.angles[f] == pose.raw_angles[f]);
  CHECK_RESULT(glovepose_estimator_get_cells(e, cells, 44), GLOVEPOSE_OK);
  CHECK(isfinite(cells[0]) && isfinite(cells[43]));
  CHECK_RESULT(glovepose_estimator_get_cells(e, cells, 43), GLOVEPOSE_SIZE_MISMATCH);
  CHECK_RESULT(glovepose_estimator_get_cells(e, NULL, 44), GLOVEPOSE_ERROR_INVALID_ARGUMENT);
  /* The confidence: per DoF in [0, 1]; this pose is trusted unless the readout saw a fault. */
  CHECK_RESULT(glovepose_estimator_get_confidence(e, confidence, GLOVEPOSE_DOF_COUNT), GLOVEPOSE_OK);
  for (f = 0; f < GLOVEPOSE_DOF_COUNT; ++f)
    CHECK(confidence[f] >= 0.0 && confidence[f] <= 1.0 && ((pose.flags & GLOVEPOSE_POSE_FAULT_FLAGS) != 0 ? confidence[f] == 0.0 : confidence[f] > 0.0));
  CHECK_RESULT(glovepose_estimator_get_confidence(e, confidence, 24), GLOVEPOSE_SIZE_MISMATCH);
  CHECK_RESULT(glovepose_estimator_get_confidence(e, NULL, 25), GLOVEPOSE_ERROR_INVALID_ARGUMENT);
  CHECK_RESULT(glovepose_estimator_get_confidence(NULL, confidence, 25), GLOVEPOSE_ERROR_INVALID_HANDLE);

  /* A whole C_m frame solves at once. */
  for (r = 0; r < 180; ++r) frame[r] = 30.0 + 0.01 * r;
  CHECK_RESULT(glovepose_estimator_push_measurements(e, frame, 180, t + 1.0 / 60.0), GLOVEPOSE_SOLVED);

  /* Wrong struct sizes and null outputs. */
  pose.struct_size = 0;
  CHECK_RESULT(glovepose_estimator_get_pose(e, &pose), GLOVEPOSE_ERROR_STRUCT_SIZE);
  CHECK(contains(glovepose_last_error(), "glovepose_pose_init"));
  CHECK_RESULT(glovepose_estimator_get_pose(e, NULL), GLOVEPOSE_ERROR_INVALID_ARGUMENT);
  progress.struct_size = 16;
  CHECK_RESULT(glovepose_calibration_get_progress(e, &progress), GLOVEPOSE_ERROR_STRUCT_SIZE);
  CHECK_RESULT(glovepose_calibration_get_progress(e, NULL), GLOVEPOSE_ERROR_INVALID_ARGUMENT);
  glovepose_calibration_progress_init(&progress);

  /* A new calibration keeps the old range until it finishes: poses are flagged meanwhile; cancel
   * keeps the old range. */
  CHECK_RESULT(glovepose_calibration_get_range(e, lo, hi, 44), GLOVEPOSE_OK);
  CHECK_RESULT(glovepose_calibration_start(e), GLOVEPOSE_OK);
  CHECK(push_synthetic(e, 10.0, 3) == 3);
  glovepose_pose_init(&pose);
  CHECK_RESULT(glovepose_estimator_get_pose(e, &pose), GLOVEPOSE_OK);
  CHECK((pose.flags & GLOVEPOSE_POSE_CALIBRATING) != 0);
  CHECK_RESULT(glovepose_calibration_cancel(e), GLOVEPOSE_OK);
  CHECK_RESULT(glovepose_calibration_get_progress(e, &progress), GLOVEPOSE_OK);
  CHECK(progress.collecting == 0);
  CHECK(progress.source == GLOVEPOSE_CALIBRATION_ON_THE_FLY);
  CHECK(push_synthetic(e, 11.0, 1) == 1);
  CHECK_RESULT(glovepose_estimator_get_pose(e, &pose), GLOVEPOSE_OK);
  CHECK((pose.flags & GLOVEPOSE_POSE_CALIBRATING) == 0);
  CHECK_RESULT(glovepose_calibration_get_range(e, lo2, hi2, 44), GLOVEPOSE_OK);
  CHECK(memcmp(lo, lo2, sizeof lo) == 0 && memcmp(hi, hi2, sizeof hi) == 0);
  CHECK_RESULT(glovepose_calibration_get_range(e, lo2, hi2, 45), GLOVEPOSE_SIZE_MISMATCH);
  CHECK_RESULT(glovepose_calibration_get_range(e, NULL, hi2, 44), GLOVEPOSE_ERROR_INVALID_ARGUMENT);

  /* Save and load: the same range, exactly; files that are missing, malformed or unwritable. */
  CHECK_RESULT(glovepose_calibration_save(e, path_in(5, dir, "user.calibration")), GLOVEPOSE_OK);
  CHECK_RESULT(glovepose_calibration_save(e, "/nonexistent/glovepose/user.calibration"), GLOVEPOSE_ERROR_IO);
  CHECK(contains(glovepose_last_error(), "/nonexistent/glovepose/user.calibration"));
  CHECK_RESULT(glovepose_calibration_save(e, NULL), GLOVEPOSE_ERROR_INVALID_ARGUMENT);
  CHECK_RESULT(glovepose_estimator_create(model, NULL, &other), GLOVEPOSE_OK);
  CHECK_RESULT(glovepose_calibration_load(other, path_in(5, dir, "user.calibration")), GLOVEPOSE_OK);
  CHECK_RESULT(glovepose_calibration_get_range(other, lo2, hi2, 44), GLOVEPOSE_OK);
  CHECK(memcmp(lo, lo2, sizeof lo) == 0 && memcmp(hi, hi2, sizeof hi) == 0);
  CHECK_RESULT(glovepose_calibration_get_progress(other, &progress), GLOVEPOSE_OK);
  CHECK(progress.source == GLOVEPOSE_CALIBRATION_USER);
  CHECK_RESULT(glovepose_calibration_load(other, path_in(6, dir, "missing.calibration")), GLOVEPOSE_ERROR_FILE_NOT_FOUND);
  CHECK(contains(glovepose_last_error(), "missing.calibration"));
  CHECK_RESULT(glovepose_calibration_load(other, path_in(6, dir, "glauser2019-44.json")), GLOVEPOSE_ERROR_INVALID_FILE);
  CHECK(contains(glovepose_last_error(), "glauser2019-44.json"));
  CHECK_RESULT(glovepose_calibration_load(other, NULL), GLOVEPOSE_ERROR_INVALID_ARGUMENT);

  /* Set a range: counts, order, and a range the library refuses. */
  CHECK_RESULT(glovepose_calibration_set_range(other, lo, hi, 43), GLOVEPOSE_SIZE_MISMATCH);
  CHECK_RESULT(glovepose_calibration_set_range(other, NULL, hi, 44), GLOVEPOSE_ERROR_INVALID_ARGUMENT);
  CHECK_RESULT(glovepose_calibration_set_range(other, hi, lo, 44), GLOVEPOSE_ERROR_INVALID_ARGUMENT);
  CHECK(contains(glovepose_last_error(), "above max"));
  lo2[3] = NAN;
  CHECK_RESULT(glovepose_calibration_set_range(other, lo2, hi, 44), GLOVEPOSE_ERROR_INVALID_ARGUMENT);
  CHECK(contains(glovepose_last_error(), "cell_3"));
  CHECK_RESULT(glovepose_calibration_set_range(other, lo, hi, 44), GLOVEPOSE_OK);

  /* Cells: sizes, non-finite values, timestamps. */
  synthetic_cells(20.0, cells, 44);
  CHECK_RESULT(glovepose_estimator_push_cells(other, cells, 43, 20.0, 0.0), GLOVEPOSE_SIZE_MISMATCH);
  CHECK_RESULT(glovepose_estimator_push_cells(other, NULL, 44, 20.0, 0.0), GLOVEPOSE_SIZE_MISMATCH);
  CHECK_RESULT(glovepose_estimator_push_cells(other, cells, 44, NAN, 0.0), GLOVEPOSE_NON_FINITE);
  CHECK_RESULT(glovepose_estimator_push_cells(other, cells, 44, 20.0, 0.0125), GLOVEPOSE_SOLVED);
  CHECK_RESULT(glovepose_estimator_push_cells(other, cells, 44, 19.0, 0.0), GLOVEPOSE_TIMESTAMP_BACKWARDS);
  glovepose_pose_init(&pose);
  CHECK_RESULT(glovepose_estimator_get_pose(other, &pose), GLOVEPOSE_OK);
  CHECK(pose.oldest_age == 0.0125);
  CHECK(pose.timestamp == 20.0);
  cells[7] = NAN;
  CHECK_RESULT(glovepose_estimator_push_cells(other, cells, 44, 21.0, 0.0), GLOVEPOSE_NON_FINITE);

  glovepose_estimator_free(other);
  glovepose_estimator_free(e);
}

/* Smoothing and joints: the joint list needs joint_transforms; quaternions are unit. */
static void test_joints(glovepose_model* model) {
  glovepose_estimator_config config;
  glovepose_estimator* plain = NULL;
  glovepose_estimator* full = NULL;
  glovepose_joint joints[GLOVEPOSE_JOINT_COUNT];
  glovepose_pose pose;
  double lo[44], hi[44], smoothing_effect = 0.0;
  int c, j, f;
  for (c = 0; c < 44; ++c) {
    lo[c] = 15.0 + 0.1 * c;
    hi[c] = 25.0 + 0.1 * c;
  }
  CHECK_RESULT(glovepose_estimator_create(model, NULL, &plain), GLOVEPOSE_OK);
  CHECK_RESULT(glovepose_estimator_get_joints(plain, joints, GLOVEPOSE_JOINT_COUNT), GLOVEPOSE_ERROR_DISABLED);
  CHECK(contains(glovepose_last_error(), "joint_transforms"));
  glovepose_estimator_config_default(&config);
  config.joint_transforms = 1;
  config.smoothing = 1;
  config.smoothing_beta = 0.5;
  CHECK_RESULT(glovepose_estimator_create(model, &config, &full), GLOVEPOSE_OK);
  CHECK_RESULT(glovepose_calibration_set_range(full, lo, hi, 44), GLOVEPOSE_OK);
  CHECK(push_synthetic(full, 0.0, 30) == 30);
  glovepose_pose_init(&pose);
  CHECK_RESULT(glovepose_estimator_get_pose(full, &pose), GLOVEPOSE_OK);
  for (f = 0; f < GLOVEPOSE_DOF_COUNT; ++f) smoothing_effect = fmax(smoothing_effect, fabs(pose.angles[f] - pose.raw_angles[f]));
  CHECK(smoothing_effect > 1e-4); /* smoothing on: the angles differ from the network's */
  CHECK_RESULT(glovepose_estimator_get_joints(full, joints, GLOVEPOSE_JOINT_COUNT), GLOVEPOSE_OK);
  for (j = 0; j < GLOVEPOSE_JOINT_COUNT; ++j) {
    const double norm = sqrt(joints[j].rotation[0] * joints[j].rotation[0] + joints[j].rotation[1] * joints[j].rotation[1] +
                             joints[j].rotation[2] * joints[j].rotation[2] + joints[j].rotation[3] * joints[j].rotation[3]);
    CHECK(fabs(norm - 1.0) < 1e-5);
  }
  /* A fingertip lies beyond its knuckle, a few centimetres away, in metres. */
  {
    const float dx = joints[12].position[0] - joints[9].position[0], dy = joints[12].position[1] - joints[9].position[1],
                dz = joints[12].position[2] - joints[9].position[2];
    const double length = sqrt(dx * dx + dy * dy + dz * dz);
    CHECK(length > 0.03 && length < 0.15);
  }
  CHECK_RESULT(glovepose_estimator_get_joints(full, joints, 20), GLOVEPOSE_SIZE_MISMATCH);
  CHECK_RESULT(glovepose_estimator_get_joints(full, NULL, GLOVEPOSE_JOINT_COUNT), GLOVEPOSE_ERROR_INVALID_ARGUMENT);
  glovepose_estimator_free(plain);
  glovepose_estimator_free(full);
}

/* The latest hand for other threads (here read on the same thread: the threaded behaviour is the
 * C++ library's, tested under ThreadSanitizer in tests/test_latest.cpp). */
static void test_latest(glovepose_model* model) {
  glovepose_estimator_config config;
  glovepose_estimator* estimator = NULL;
  glovepose_latest* latest = NULL;
  glovepose_pose pose, direct;
  glovepose_joint joints[GLOVEPOSE_JOINT_COUNT], direct_joints[GLOVEPOSE_JOINT_COUNT];
  uint64_t number = 99;
  double lo[44], hi[44];
  int c;
  for (c = 0; c < 44; ++c) {
    lo[c] = 15.0 + 0.1 * c;
    hi[c] = 25.0 + 0.1 * c;
  }
  glovepose_estimator_config_default(&config);
  config.joint_transforms = 1;
  CHECK_RESULT(glovepose_estimator_create(model, &config, &estimator), GLOVEPOSE_OK);
  CHECK_RESULT(glovepose_calibration_set_range(estimator, lo, hi, 44), GLOVEPOSE_OK);
  CHECK_RESULT(glovepose_latest_create(&latest), GLOVEPOSE_OK);
  CHECK_RESULT(glovepose_latest_create(NULL), GLOVEPOSE_ERROR_INVALID_ARGUMENT);
  glovepose_pose_init(&pose);
  pose.timestamp = -5.0;
  CHECK_RESULT(glovepose_latest_read(latest, &pose, joints, GLOVEPOSE_JOINT_COUNT, &number), GLOVEPOSE_OK);
  CHECK(number == 0);
  CHECK(pose.timestamp == -5.0); /* nothing published: untouched */
  CHECK(push_synthetic(estimator, 0.0, 3) == 3);
  CHECK_RESULT(glovepose_latest_publish(latest, estimator), GLOVEPOSE_OK);
  CHECK(push_synthetic(estimator, 0.05, 2) == 2);
  CHECK_RESULT(glovepose_latest_publish(latest, estimator), GLOVEPOSE_OK);
  CHECK_RESULT(glovepose_latest_read(latest, &pose, joints, GLOVEPOSE_JOINT_COUNT, &number), GLOVEPOSE_OK);
  CHECK(number == 2);
  glovepose_pose_init(&direct);
  CHECK_RESULT(glovepose_estimator_get_pose(estimator, &direct), GLOVEPOSE_OK);
  CHECK_RESULT(glovepose_estimator_get_joints(estimator, direct_joints, GLOVEPOSE_JOINT_COUNT), GLOVEPOSE_OK);
  CHECK(pose.sequence == direct.sequence && pose.sequence == 5);
  CHECK(memcmp(pose.angles, direct.angles, sizeof pose.angles) == 0);
  CHECK(memcmp(joints, direct_joints, sizeof joints) == 0);
  CHECK_RESULT(glovepose_latest_read(latest, NULL, NULL, 0, &number), GLOVEPOSE_OK);
  CHECK(number == 2);
  CHECK_RESULT(glovepose_latest_read(latest, &pose, joints, 20, NULL), GLOVEPOSE_SIZE_MISMATCH);
  CHECK_RESULT(glovepose_latest_read(latest, NULL, NULL, GLOVEPOSE_JOINT_COUNT, NULL), GLOVEPOSE_SIZE_MISMATCH);
  pose.struct_size = 3;
  CHECK_RESULT(glovepose_latest_read(latest, &pose, NULL, 0, NULL), GLOVEPOSE_ERROR_STRUCT_SIZE);
  CHECK_RESULT(glovepose_latest_publish(latest, NULL), GLOVEPOSE_ERROR_INVALID_HANDLE);
  CHECK_RESULT(glovepose_latest_publish((glovepose_latest*)estimator, estimator), GLOVEPOSE_ERROR_INVALID_HANDLE);
  CHECK_RESULT(glovepose_latest_read(NULL, NULL, NULL, 0, NULL), GLOVEPOSE_ERROR_INVALID_HANDLE);
  glovepose_latest_free(latest);
  glovepose_latest_free(NULL);
  glovepose_estimator_free(estimator);
}

/* OpenXR joints and poses at a requested time: a left and a right estimator on the same stream give
 * mirrored joints; the latest published hand gives a reader the estimator's own prediction. */
static void test_xr_joints(glovepose_model* model) {
  glovepose_hand_options options;
  glovepose_estimator *right = NULL, *left = NULL, *old = NULL;
  glovepose_latest* latest = NULL;
  glovepose_xr_hand r, l, read;
  glovepose_predicted_pose ahead;
  double lo[44], hi[44], worst = 0.0;
  const double t = 29.0 / 60.0 + 0.02; /* 20 ms after the newest pose of push_synthetic(.., 0.0, 30) */
  int c, j;
  for (c = 0; c < 44; ++c) {
    lo[c] = 15.0 + 0.1 * c;
    hi[c] = 25.0 + 0.1 * c;
  }
  CHECK_RESULT(glovepose_hand_options_default(&options), GLOVEPOSE_OK);
  CHECK(options.struct_size == sizeof options);
  CHECK(options.handedness == GLOVEPOSE_HAND_RIGHT && options.prediction_window > 0.0 && options.max_prediction == 0.05);
  options.handedness = 2;
  CHECK_RESULT(glovepose_estimator_create_for_hand(model, NULL, &options, &right), GLOVEPOSE_ERROR_INVALID_ARGUMENT);
  CHECK(contains(glovepose_last_error(), "handedness 2"));
  options.handedness = GLOVEPOSE_HAND_RIGHT;
  options.struct_size = 16;
  CHECK_RESULT(glovepose_estimator_create_for_hand(model, NULL, &options, &right), GLOVEPOSE_ERROR_STRUCT_SIZE);
  options.struct_size = sizeof options;
  CHECK_RESULT(glovepose_estimator_create(model, NULL, &old), GLOVEPOSE_OK); /* the defaults: a right hand */
  CHECK_RESULT(glovepose_estimator_create_for_hand(model, NULL, &options, &right), GLOVEPOSE_OK);
  options.handedness = GLOVEPOSE_HAND_LEFT;
  CHECK_RESULT(glovepose_estimator_create_for_hand(model, NULL, &options, &left), GLOVEPOSE_OK);
  glovepose_xr_hand_init(&r);
  glovepose_xr_hand_init(&l);
  glovepose_predicted_pose_init(&ahead);
  r.active = 7;
  CHECK_RESULT(glovepose_estimator_get_xr_joints(right, 0.0, &r), GLOVEPOSE_NOT_READY);
  CHECK(r.active == 0);
  CHECK_RESULT(glovepose_estimator_get_pose_at(right, 0.0, &ahead), GLOVEPOSE_NOT_READY);
  CHECK_RESULT(glovepose_calibration_set_range(right, lo, hi, 44), GLOVEPOSE_OK);
  CHECK_RESULT(glovepose_calibration_set_range(left, lo, hi, 44), GLOVEPOSE_OK);
  CHECK_RESULT(glovepose_calibration_set_range(old, lo, hi, 44), GLOVEPOSE_OK);
  CHECK(push_synthetic(right, 0.0, 30) == 30);
  CHECK(push_synthetic(left, 0.0, 30) == 30);
  CHECK(push_synthetic(old, 0.0, 30) == 30);
  CHECK_RESULT(glovepose_estimator_get_pose_at(right, t, &ahead), GLOVEPOSE_OK);
  CHECK(ahead.predicted == 1 && ahead.clamped == 0 && ahead.has_rate == 1);
  CHECK(fabs(ahead.horizon - 0.02) < 1e-12);
  CHECK_RESULT(glovepose_estimator_get_pose_at(right, 100.0, &ahead), GLOVEPOSE_OK);
  CHECK(ahead.clamped == 1 && fabs(ahead.horizon - 0.05) < 1e-12);
  CHECK_RESULT(glovepose_estimator_get_pose_at(right, NAN, &ahead), GLOVEPOSE_NON_FINITE);
  CHECK_RESULT(glovepose_estimator_get_xr_joints(right, t, &r), GLOVEPOSE_OK);
  CHECK_RESULT(glovepose_estimator_get_xr_joints(left, t, &l), GLOVEPOSE_OK);
  CHECK(r.active == 1 && r.predicted == 1 && r.handedness == GLOVEPOSE_HAND_RIGHT && l.handedness == GLOVEPOSE_HAND_LEFT);
  CHECK((r.locations[1].location_flags & (GLOVEPOSE_XR_ORIENTATION_VALID | GLOVEPOSE_XR_POSITION_VALID)) ==
        (GLOVEPOSE_XR_ORIENTATION_VALID | GLOVEPOSE_XR_POSITION_VALID));
  CHECK(r.velocities[10].velocity_flags == (GLOVEPOSE_XR_LINEAR_VELOCITY_VALID | GLOVEPOSE_XR_ANGULAR_VELOCITY_VALID));
  CHECK(r.locations[1].orientation[3] == 1.0f && r.locations[1].position[2] == 0.0f); /* the wrist: identity */
  CHECK(r.locations[15].position[2] < -0.05f);                                        /* the middle tip: fingers along -Z */
  for (j = 0; j < GLOVEPOSE_XR_JOINT_COUNT; ++j) {
    CHECK(r.locations[j].radius > 0.003f && r.locations[j].radius < 0.02f);
    worst = fmax(worst, fabs(l.locations[j].position[0] + r.locations[j].position[0]));
    worst = fmax(worst, fabs(l.locations[j].position[1] - r.locations[j].position[1]));
    worst = fmax(worst, fabs(l.locations[j].orientation[1] + r.locations[j].orientation[1]));
  }
  CHECK(worst < 1e-6); /* the left hand is the right hand mirrored (x -> -x) */
  r.struct_size = 12;
  CHECK_RESULT(glovepose_estimator_get_xr_joints(right, t, &r), GLOVEPOSE_ERROR_STRUCT_SIZE);
  CHECK(contains(glovepose_last_error(), "glovepose_xr_hand_init"));
  CHECK_RESULT(glovepose_estimator_get_xr_joints(right, t, NULL), GLOVEPOSE_ERROR_INVALID_ARGUMENT);
  CHECK_RESULT(glovepose_estimator_get_xr_joints(NULL, t, &l), GLOVEPOSE_ERROR_INVALID_HANDLE);
  /* The same stream through glovepose_estimator_create: the same joints as the right estimator. */
  glovepose_xr_hand_init(&r);
  CHECK_RESULT(glovepose_estimator_get_xr_joints(right, t, &r), GLOVEPOSE_OK);
  CHECK_RESULT(glovepose_estimator_get_xr_joints(old, t, &l), GLOVEPOSE_OK);
  CHECK(memcmp(r.locations, l.locations, sizeof r.locations) == 0);

  /* A reader thread: the published hand, predicted with the estimator's locator. */
  CHECK_RESULT(glovepose_latest_create(&latest), GLOVEPOSE_OK);
  glovepose_xr_hand_init(&read);
  CHECK_RESULT(glovepose_latest_get_xr_joints(latest, right, t, &read), GLOVEPOSE_NOT_READY);
  CHECK(read.active == 0);
  CHECK_RESULT(glovepose_latest_publish(latest, right), GLOVEPOSE_OK);
  CHECK_RESULT(glovepose_latest_get_xr_joints(latest, right, t, &read), GLOVEPOSE_OK);
  CHECK(read.active == 1 && read.predicted == 1);
  CHECK(memcmp(read.locations, r.locations, sizeof r.locations) == 0);
  CHECK(memcmp(read.velocities, r.velocities, sizeof r.velocities) == 0);
  CHECK_RESULT(glovepose_latest_get_xr_joints(NULL, right, t, &read), GLOVEPOSE_ERROR_INVALID_HANDLE);
  CHECK_RESULT(glovepose_latest_get_xr_joints(latest, NULL, t, &read), GLOVEPOSE_ERROR_INVALID_HANDLE);
  glovepose_latest_free(latest);
  glovepose_estimator_free(old);
  glovepose_estimator_free(left);
  glovepose_estimator_free(right);
}

/* XR_FB_hand_tracking_aim: glovepose_xr_aim_state against openxr.h's XrHandTrackingAimStateFB
 * (size, every offset, the flags and the type's value), then the estimator's and a reader's state. */
static void test_xr_aim(glovepose_model* model) {
  glovepose_estimator *right = NULL, *left = NULL;
  glovepose_latest* latest = NULL;
  glovepose_xr_aim_state r, l, read;
  glovepose_hand_options options;
  uint64_t sequence = 7;
  double lo[44], hi[44], norm;
  int c;
  CHECK(sizeof(glovepose_xr_aim_state) == sizeof(XrHandTrackingAimStateFB));
  CHECK(offsetof(glovepose_xr_aim_state, type) == offsetof(XrHandTrackingAimStateFB, type));
  CHECK(offsetof(glovepose_xr_aim_state, next) == offsetof(XrHandTrackingAimStateFB, next));
  CHECK(offsetof(glovepose_xr_aim_state, status) == offsetof(XrHandTrackingAimStateFB, status));
  CHECK(offsetof(glovepose_xr_aim_state, aim_orientation) == offsetof(XrHandTrackingAimStateFB, aimPose) + offsetof(XrPosef, orientation));
  CHECK(offsetof(glovepose_xr_aim_state, aim_position) == offsetof(XrHandTrackingAimStateFB, aimPose) + offsetof(XrPosef, position));
  CHECK(offsetof(glovepose_xr_aim_state, pinch_strength_index) == offsetof(XrHandTrackingAimStateFB, pinchStrengthIndex));
  CHECK(offsetof(glovepose_xr_aim_state, pinch_strength_middle) == offsetof(XrHandTrackingAimStateFB, pinchStrengthMiddle));
  CHECK(offsetof(glovepose_xr_aim_state, pinch_strength_ring) == offsetof(XrHandTrackingAimStateFB, pinchStrengthRing));
  CHECK(offsetof(glovepose_xr_aim_state, pinch_strength_little) == offsetof(XrHandTrackingAimStateFB, pinchStrengthLittle));
  CHECK(sizeof r.type == sizeof(XrStructureType) && sizeof r.status == sizeof(XrHandTrackingAimFlagsFB));
  CHECK(sizeof r.aim_orientation + sizeof r.aim_position == sizeof(XrPosef));
  if (sizeof(void*) == 8) { /* the 64-bit layout the header documents */
    CHECK(sizeof(glovepose_xr_aim_state) == 72);
    CHECK(offsetof(glovepose_xr_aim_state, next) == 8);
    CHECK(offsetof(glovepose_xr_aim_state, status) == 16);
    CHECK(offsetof(glovepose_xr_aim_state, aim_orientation) == 24);
    CHECK(offsetof(glovepose_xr_aim_state, aim_position) == 40);
    CHECK(offsetof(glovepose_xr_aim_state, pinch_strength_index) == 52);
    CHECK(offsetof(glovepose_xr_aim_state, pinch_strength_little) == 64);
  }
  CHECK(GLOVEPOSE_XR_TYPE_HAND_TRACKING_AIM_STATE_FB == XR_TYPE_HAND_TRACKING_AIM_STATE_FB);
  CHECK(GLOVEPOSE_XR_AIM_COMPUTED == XR_HAND_TRACKING_AIM_COMPUTED_BIT_FB);
  CHECK(GLOVEPOSE_XR_AIM_VALID == XR_HAND_TRACKING_AIM_VALID_BIT_FB);
  CHECK(GLOVEPOSE_XR_AIM_INDEX_PINCHING == XR_HAND_TRACKING_AIM_INDEX_PINCHING_BIT_FB);
  CHECK(GLOVEPOSE_XR_AIM_MIDDLE_PINCHING == XR_HAND_TRACKING_AIM_MIDDLE_PINCHING_BIT_FB);
  CHECK(GLOVEPOSE_XR_AIM_RING_PINCHING == XR_HAND_TRACKING_AIM_RING_PINCHING_BIT_FB);
  CHECK(GLOVEPOSE_XR_AIM_LITTLE_PINCHING == XR_HAND_TRACKING_AIM_LITTLE_PINCHING_BIT_FB);
  CHECK(GLOVEPOSE_XR_AIM_SYSTEM_GESTURE == XR_HAND_TRACKING_AIM_SYSTEM_GESTURE_BIT_FB);
  CHECK(GLOVEPOSE_XR_AIM_DOMINANT_HAND == XR_HAND_TRACKING_AIM_DOMINANT_HAND_BIT_FB);
  CHECK(GLOVEPOSE_XR_AIM_MENU_PRESSED == XR_HAND_TRACKING_AIM_MENU_PRESSED_BIT_FB);

  for (c = 0; c < 44; ++c) {
    lo[c] = 15.0 + 0.1 * c;
    hi[c] = 25.0 + 0.1 * c;
  }
  CHECK_RESULT(glovepose_hand_options_default(&options), GLOVEPOSE_OK);
  CHECK_RESULT(glovepose_estimator_create_for_hand(model, NULL, &options, &right), GLOVEPOSE_OK);
  options.handedness = GLOVEPOSE_HAND_LEFT;
  CHECK_RESULT(glovepose_estimator_create_for_hand(model, NULL, &options, &left), GLOVEPOSE_OK);
  glovepose_xr_aim_state_init(&r);
  glovepose_xr_aim_state_init(&l);
  CHECK(r.type == GLOVEPOSE_XR_TYPE_HAND_TRACKING_AIM_STATE_FB && r.next == NULL && r.status == 0);
  CHECK_RESULT(glovepose_estimator_get_xr_aim(right, &r), GLOVEPOSE_NOT_READY);
  CHECK(r.status == 0 && r.pinch_strength_index == 0.0f);
  CHECK(r.aim_orientation[3] != 0.0f); /* the aim pose is the hand's, there before any pose */
  CHECK_RESULT(glovepose_calibration_set_range(right, lo, hi, 44), GLOVEPOSE_OK);
  CHECK_RESULT(glovepose_calibration_set_range(left, lo, hi, 44), GLOVEPOSE_OK);
  CHECK(push_synthetic(right, 0.0, 30) == 30);
  CHECK(push_synthetic(left, 0.0, 30) == 30);
  r.next = &l; /* the caller's chain: left alone */
  CHECK_RESULT(glovepose_estimator_get_xr_aim(right, &r), GLOVEPOSE_OK);
  CHECK_RESULT(glovepose_estimator_get_xr_aim(left, &l), GLOVEPOSE_OK);
  CHECK(r.type == GLOVEPOSE_XR_TYPE_HAND_TRACKING_AIM_STATE_FB && r.next == &l);
  CHECK((r.status & ~(uint64_t)(GLOVEPOSE_XR_AIM_VALID | 0x3Cu)) == 0); /* only VALID and the pinching bits */
  CHECK(r.pinch_strength_index >= 0.0f && r.pinch_strength_index <= 1.0f);
  CHECK(r.pinch_strength_little >= 0.0f && r.pinch_strength_little <= 1.0f);
  norm = sqrt((double)r.aim_orientation[0] * r.aim_orientation[0] + (double)r.aim_orientation[1] * r.aim_orientation[1] +
              (double)r.aim_orientation[2] * r.aim_orientation[2] + (double)r.aim_orientation[3] * r.aim_orientation[3]);
  CHECK(fabs(norm - 1.0) < 1e-6);
  CHECK(r.aim_position[2] < -0.04f);              /* the index knuckle lies towards the fingers (-Z) */
  CHECK(r.aim_position[0] == -l.aim_position[0]); /* the left hand mirrored */
  CHECK(r.aim_position[1] == l.aim_position[1]);
  l.type = 3;
  CHECK_RESULT(glovepose_estimator_get_xr_aim(left, &l), GLOVEPOSE_ERROR_STRUCT_SIZE);
  CHECK(contains(glovepose_last_error(), "glovepose_xr_aim_state_init"));
  CHECK_RESULT(glovepose_estimator_get_xr_aim(right, NULL), GLOVEPOSE_ERROR_INVALID_ARGUMENT);
  CHECK_RESULT(glovepose_estimator_get_xr_aim(NULL, &r), GLOVEPOSE_ERROR_INVALID_HANDLE);

  /* A reader thread: the state published with the newest pose. */
  CHECK_RESULT(glovepose_latest_create(&latest), GLOVEPOSE_OK);
  glovepose_xr_aim_state_init(&read);
  read.pinch_strength_ring = 0.5f;
  CHECK_RESULT(glovepose_latest_get_xr_aim(latest, &read, &sequence), GLOVEPOSE_NOT_READY);
  CHECK(sequence == 0 && read.status == 0 && read.pinch_strength_ring == 0.0f);
  CHECK_RESULT(glovepose_latest_publish(latest, right), GLOVEPOSE_OK);
  CHECK_RESULT(glovepose_latest_get_xr_aim(latest, &read, &sequence), GLOVEPOSE_OK);
  CHECK(sequence == 30);
  CHECK(read.status == r.status && read.pinch_strength_index == r.pinch_strength_index);
  CHECK(memcmp(read.aim_orientation, r.aim_orientation, sizeof r.aim_orientation) == 0);
  CHECK(memcmp(read.aim_position, r.aim_position, sizeof r.aim_position) == 0);
  CHECK_RESULT(glovepose_latest_get_xr_aim(latest, &read, NULL), GLOVEPOSE_OK);
  CHECK_RESULT(glovepose_latest_get_xr_aim(NULL, &read, NULL), GLOVEPOSE_ERROR_INVALID_HANDLE);
  CHECK_RESULT(glovepose_latest_get_xr_aim((const glovepose_latest*)right, &read, NULL), GLOVEPOSE_ERROR_INVALID_HANDLE);
  CHECK_RESULT(glovepose_latest_get_xr_aim(latest, NULL, NULL), GLOVEPOSE_ERROR_INVALID_ARGUMENT);
  glovepose_xr_aim_state_init(NULL);
  glovepose_latest_free(latest);
  glovepose_estimator_free(left);
  glovepose_estimator_free(right);
}

/* The guided calibration sequence the shipped model carries (models/calibration_glauser2019.json):
 * its steps as data, and the step under way while a calibration collects. */
static void test_guided_steps(glovepose_model* model) {
  glovepose_calibration_step step;
  glovepose_estimator* e = NULL;
  double cells[44], seconds = -1.0;
  int32_t under_way = 7, k, d;
  glovepose_calibration_step_init(&step);
  CHECK(step.struct_size == sizeof step);
  CHECK(glovepose_model_calibration_step_count(model) == 10);
  CHECK(glovepose_model_calibration_step_count(NULL) == -1);
  for (k = 0; k < 10; ++k) {
    CHECK_RESULT(glovepose_model_get_calibration_step(model, k, &step), GLOVEPOSE_OK);
    CHECK(step.step == k && step.step_count == 10);
    CHECK(fabs(step.seconds - 3.0) < 1e-12);
    CHECK(fabs(step.start_seconds - 3.0 * k) < 1e-9);
    CHECK(strlen(step.name) > 0 && strlen(step.name) < sizeof step.name);
    CHECK(strlen(step.instruction) > 10 && strlen(step.instruction) < sizeof step.instruction);
  }
  /* Step 0: the hand pressed flat on a table, thumb abducted 5.729578 degrees, every flexion 0. */
  CHECK_RESULT(glovepose_model_get_calibration_step(model, 0, &step), GLOVEPOSE_OK);
  CHECK(strcmp(step.name, "flat_on_table") == 0);
  CHECK(strncmp(step.instruction, "Lay your hand flat on a table", 29) == 0);
  CHECK(fabs(step.pose[0] - 5.729578 * 3.14159265358979 / 180.0) < 1e-6);
  for (d = 0; d < 25; ++d)
    if (strstr(glovepose_dof_name(d), "flexion") != NULL) CHECK(step.pose[d] == 0.0f);
  CHECK_RESULT(glovepose_model_get_calibration_step(model, 10, &step), GLOVEPOSE_ERROR_INVALID_ARGUMENT);
  CHECK(contains(glovepose_last_error(), "step 10, expected 0..9"));
  CHECK_RESULT(glovepose_model_get_calibration_step(model, -1, &step), GLOVEPOSE_ERROR_INVALID_ARGUMENT);
  CHECK_RESULT(glovepose_model_get_calibration_step(model, 0, NULL), GLOVEPOSE_ERROR_INVALID_ARGUMENT);
  CHECK_RESULT(glovepose_model_get_calibration_step(NULL, 0, &step), GLOVEPOSE_ERROR_INVALID_HANDLE);
  step.struct_size = 8;
  CHECK_RESULT(glovepose_model_get_calibration_step(model, 0, &step), GLOVEPOSE_ERROR_STRUCT_SIZE);

  /* The step under way follows the stream's clock from the sequence's first frame. */
  CHECK_RESULT(glovepose_estimator_create(model, NULL, &e), GLOVEPOSE_OK);
  CHECK_RESULT(glovepose_calibration_get_step(e, &under_way, &seconds), GLOVEPOSE_OK);
  CHECK(under_way == -1 && seconds == 0.0); /* not collecting */
  CHECK_RESULT(glovepose_calibration_start(e), GLOVEPOSE_OK);
  for (d = 0; d < 44; ++d) cells[d] = 20.0 + d;
  for (k = 0; k <= 1860; ++k) { /* 31 s at 60 Hz, from t = 100 s */
    const double t = 100.0 + k / 60.0;
    cells[k % 44] += (k % 2 ? 0.5 : -0.5);
    (void)glovepose_estimator_push_cells(e, cells, 44, t, 0.0);
    if (k == 270) { /* 4.5 s in: the second step */
      CHECK_RESULT(glovepose_calibration_get_step(e, &under_way, &seconds), GLOVEPOSE_OK);
      CHECK(under_way == 1);
      CHECK(fabs(seconds - 4.5) < 1e-6);
    }
  }
  CHECK_RESULT(glovepose_calibration_get_step(e, &under_way, NULL), GLOVEPOSE_OK);
  CHECK(under_way == -1); /* past the last step */
  CHECK_RESULT(glovepose_calibration_get_step(NULL, &under_way, &seconds), GLOVEPOSE_ERROR_INVALID_HANDLE);
  glovepose_estimator_free(e);
}

int main(int argc, char** argv) {
  glovepose_model* model = NULL;
  glovepose_estimator* survivor = NULL;
  if (argc != 3) {
    printf("usage: %s MODEL DIR\n", argv[0]);
    return 2;
  }
  CHECK(strcmp(glovepose_last_error(), "") == 0); /* nothing failed yet on this thread */
  test_library();
  test_model_errors(argv[1], argv[2]);
  CHECK_RESULT(glovepose_model_load(argv[1], GLOVEPOSE_WEIGHTS_F32, NULL, &model), GLOVEPOSE_OK);
  if (model == NULL) {
    printf("cannot go on without the model: %s\n%d passed, %d failed\n", glovepose_last_error(), passed, failed + 1);
    return 1;
  }
  test_model(model, argv[1], argv[2]);
  test_create(model);
  test_null_estimator();
  test_rows_and_calibration(model, argv[2]);
  test_joints(model);
  test_guided_steps(model);
  test_latest(model);
  test_xr_joints(model);
  test_xr_aim(model);

  /* Estimators share the model: freeing the caller's model handle leaves them working. */
  CHECK_RESULT(glovepose_estimator_create(model, NULL, &survivor), GLOVEPOSE_OK);
  glovepose_model_free(model);
  {
    double lo[44], hi[44];
    int c;
    for (c = 0; c < 44; ++c) {
      lo[c] = 15.0;
      hi[c] = 25.0;
    }
    CHECK_RESULT(glovepose_calibration_set_range(survivor, lo, hi, 44), GLOVEPOSE_OK);
    CHECK(push_synthetic(survivor, 0.0, 2) == 2);
  }
  glovepose_estimator_free(survivor);

  printf("%d passed, %d failed\n", passed, failed);
  return failed == 0 ? 0 : 1;
}
