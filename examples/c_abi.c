/* The C ABI from C: load a model, create an estimator, calibrate on the fly while showing the
 * model's guided calibration steps (instruction and target pose of the step under way), print a
 * few poses.
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
  glovepose_calibration_step step;
  int32_t step_count, step_now = -1, step_shown = -1, calibration_frames = 120;
  double sequence_seconds = 0.0;
  glovepose_pose pose;
  glovepose_joint joints[GLOVEPOSE_JOINT_COUNT];
  double cells[CELLS];
  glovepose_result result;
  int frame, first_frame, printed = 0;

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
  config.smoothing = 1; /* 1-euro smoothing of the angles */
  config.smoothing_beta = 0.5;
  config.joint_transforms = 1; /* also the 21-joint list an engine drives a skeleton with */
  result = glovepose_estimator_create(model, &config, &estimator);
  if (result != GLOVEPOSE_OK) return fail("create the estimator", result);

  /* The model's guided calibration sequence, if it carries one: the calibration lasts as long. */
  glovepose_calibration_step_init(&step);
  step_count = glovepose_model_calibration_step_count(model);
  if (step_count > 0 && glovepose_model_get_calibration_step(model, step_count - 1, &step) == GLOVEPOSE_OK)
    calibration_frames = (int)((step.start_seconds + step.seconds) * 60.0) + 1;
  printf("calibration: %d guided steps, %d frames\n", (int)step_count, calibration_frames);

  /* Calibrate on the fly. An app shows the step under way: its instruction and the pose to copy
   * (this synthetic glove does not follow them, so the estimator will apply min-max). */
  glovepose_calibration_start(estimator);
  for (frame = 0; frame < calibration_frames; ++frame) {
    read_glove(frame / 60.0, cells);
    (void)glovepose_estimator_push_cells(estimator, cells, CELLS, frame / 60.0, 0.0); /* no range yet: no pose */
    glovepose_calibration_get_step(estimator, &step_now, &sequence_seconds);
    if (step_now < 0 || step_now == step_shown) continue;
    step_shown = step_now;
    if (glovepose_model_get_calibration_step(model, step_now, &step) != GLOVEPOSE_OK) continue;
    printf("  %5.2f s  step %d/%d %s (%.1f s): \"%s\"  target %s %.2f rad\n", sequence_seconds, (int)step.step + 1, (int)step.step_count,
           step.name, step.seconds, step.instruction, glovepose_dof_name(5), step.pose[5]);
  }
  glovepose_calibration_progress_init(&progress);
  glovepose_calibration_get_progress(estimator, &progress);
  printf("calibration: %ld frames taken, %d needed\n", (long)progress.frames, (int)progress.frames_needed);
  result = glovepose_calibration_finish(estimator);
  if (result != GLOVEPOSE_OK) return fail("finish the calibration", result);

  /* Track for 2 s; print a pose every half second. */
  glovepose_pose_init(&pose);
  first_frame = calibration_frames;
  for (frame = first_frame; frame < first_frame + 120; ++frame) {
    read_glove(frame / 60.0, cells);
    result = glovepose_estimator_push_cells(estimator, cells, CELLS, frame / 60.0, 0.0);
    if (result != GLOVEPOSE_SOLVED) return fail("push a frame", result);
    if ((frame - first_frame) % 30 != 0) continue;
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
  glovepose_model_free(model); /* (the estimator kept it alive while it lived) */
  return printed == 4 && (step_count == 0 || step_shown == step_count - 1) ? 0 : 1;
}
