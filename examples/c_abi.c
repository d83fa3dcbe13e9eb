/* The C ABI from C: load a model, create an estimator, calibrate on the fly, print a few poses.
 *
 * The glove here is synthetic: a glove whose firmware solves its cells on board and sends 44 cell
 * capacitances (pF) 60 times a second, each cell breathing between its own limits. With a real
 * glove, push its rows (glovepose_estimator_push_row) or frames instead.
 *
 * Build: link against glovepose_c (see capi/README.md). Run: c_abi MODEL.safetensors */
#include <glovepose_c.h>

#include <math.h>
#include <stdio.h>

#define CELLS 44

static void read_glove(double t, double* cells) {
  int c;
  for (c = 0; c < CELLS; ++c) cells[c] = 20.0 + 0.1 * c + 5.0 * sin(2.0 * 3.14159265358979 * (0.5 + 0.03 * c) * t + c);
}

/* Prints what failed and the library's message. */
static int fail(const char* what, glovepose_result result) {
  fprintf(stderr, "%s: %s (%s)\n", what, glovepose_result_name(result), glovepose_last_error());
  return 1;
}

int main(int argc, char** argv) {
  glovepose_model* model = NULL;
  glovepose_estimator* estimator = NULL;
  glovepose_estimator_config config;
  glovepose_calibration_progress progress;
  glovepose_pose pose;
  glovepose_joint joints[GLOVEPOSE_JOINT_COUNT];
  double cells[CELLS];
  glovepose_result result;
  int frame, printed = 0;

  if (argc != 2) {
    fprintf(stderr, "usage: %s MODEL.safetensors\n", argv[0]);
    return 2;
  }
  printf("glovepose %s, C ABI %d\n", glovepose_version(), (int)glovepose_abi_version());

  /* One model per process, shared by every estimator (one per glove). */
  result = glovepose_model_load(argv[1], GLOVEPOSE_WEIGHTS_F32, NULL, &model);
  if (result != GLOVEPOSE_OK) return fail("load the model", result);
  if (glovepose_model_cell_count(model) != CELLS) {
    fprintf(stderr, "this example's glove has %d cells, the model reads %d\n", CELLS, (int)glovepose_model_cell_count(model));
    glovepose_model_free(model);
    return 1;
  }

  glovepose_estimator_config_default(&config);
  config.smoothing = 1;        /* 1-euro smoothing of the angles */
  config.smoothing_beta = 0.5;
  config.joint_transforms = 1; /* also the 21-joint list an engine drives a skeleton with */
  result = glovepose_estimator_create(model, &config, &estimator);
  glovepose_model_free(model); /* the estimator keeps the model alive */
  if (result != GLOVEPOSE_OK) return fail("create the estimator", result);

  /* Calibrate on the fly: the user moves through extreme poses for 2 s. */
  glovepose_calibration_start(estimator);
  for (frame = 0; frame < 120; ++frame) {
    read_glove(frame / 60.0, cells);
    (void)glovepose_estimator_push_cells(estimator, cells, CELLS, frame / 60.0, 0.0); /* no range yet: no pose */
  }
  glovepose_calibration_progress_init(&progress);
  glovepose_calibration_get_progress(estimator, &progress);
  printf("calibration: %ld frames taken, %d needed\n", (long)progress.frames, (int)progress.frames_needed);
  result = glovepose_calibration_finish(estimator);
  if (result != GLOVEPOSE_OK) return fail("finish the calibration", result);

  /* Track for 2 s; print a pose every half second. */
  glovepose_pose_init(&pose);
  for (frame = 120; frame < 240; ++frame) {
    read_glove(frame / 60.0, cells);
    result = glovepose_estimator_push_cells(estimator, cells, CELLS, frame / 60.0, 0.0);
    if (result != GLOVEPOSE_SOLVED) return fail("push a frame", result);
    if (frame % 30 != 0) continue;
    glovepose_estimator_get_pose(estimator, &pose);
    glovepose_estimator_get_joints(estimator, joints, GLOVEPOSE_JOINT_COUNT);
    /* flags: e.g. GLOVEPOSE_POSE_INPUT_CLAMPED (0x2) when the hand goes beyond the calibrated range. */
    printf("t = %.2f s  pose %llu  %s %+.3f  %s %+.3f  %s %+.3f rad  index tip (%.3f, %.3f, %.3f) m  flags 0x%x\n", pose.timestamp,
           (unsigned long long)pose.sequence, glovepose_dof_name(0), pose.angles[0], glovepose_dof_name(5), pose.angles[5],
           glovepose_dof_name(6), pose.angles[6], joints[8].position[0], joints[8].position[1], joints[8].position[2],
           (unsigned)pose.flags);
    ++printed;
  }
  glovepose_estimator_free(estimator);
  return printed == 4 ? 0 : 1;
}
