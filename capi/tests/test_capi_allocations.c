/* The per-frame calls of the C ABI allocate nothing, take no lock and make no system call
 * (GLOVEPOSE_REALTIME's contract), counted where they would leave the library (glibc only;
 * tests/realtime_counters.c interposes the allocators, the locks and the system-call wrappers, so
 * every call made inside libglovepose_c is seen). tests/test_realtime.cpp checks the C++ API.
 *
 * Usage: capi_test_allocations MODEL   Last line "N passed, N failed"; exit code 0 when none failed,
 * 77 when GLOVEPOSE_ISA names an instruction set this CPU does not execute (skipped). */
#define _GNU_SOURCE
#include "glovepose_c.h"
#include "realtime_counters.h"

#include <math.h>
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

static int passed = 0, failed = 0;
static void check(int condition, const char* what) {
  if (condition) {
    ++passed;
  } else {
    ++failed;
    printf("FAILED: %s\n", what);
  }
}

static void synthetic_cells(double t, double* cells) {
  int c;
  for (c = 0; c < 44; ++c) cells[c] = 20.0 + 5.0 * sin(2.0 * 3.14159265358979 * (0.7 + 0.05 * c) * t + c);
}

int main(int argc, char** argv) {
  glovepose_model* model = NULL;
  glovepose_estimator* estimator = NULL;
  glovepose_estimator_config config;
  glovepose_pose pose;
  glovepose_joint joints[GLOVEPOSE_JOINT_COUNT];
  glovepose_calibration_progress progress;
  glovepose_latest* latest = NULL;
  glovepose_xr_hand hand;
  glovepose_xr_aim_state aim;
  glovepose_predicted_pose ahead;
  uint64_t number = 0;
  int32_t step = 0;
  double sequence_seconds = 0.0;
  double cells[44], frame[180];
  unsigned long before, during, locks_before, locks_during, calls_before, calls_during;
  const char* isa;
  int f, r, solved = 0;
  if (argc != 2) {
    printf("usage: %s MODEL\n", argv[0]);
    return 2;
  }
  isa = glovepose_isa();
  if (isa == NULL) {
    printf("skipped: %s\n", glovepose_last_error());
    return 77;
  }
  printf("networks: %s\n", isa);
  /* Set-up allocates; the counter must see it (else the interposition does not work here). */
  before = realtime_allocations();
  if (glovepose_model_load(argv[1], GLOVEPOSE_WEIGHTS_F32, NULL, &model) != GLOVEPOSE_OK) {
    printf("cannot load %s: %s\n", argv[1], glovepose_last_error());
    return 1;
  }
  check(realtime_allocations() - before > 10, "loading the model is seen allocating (the counter works)");
  glovepose_estimator_config_default(&config);
  config.smoothing = 1;
  config.joint_transforms = 1;
  check(glovepose_estimator_create(model, &config, &estimator) == GLOVEPOSE_OK, "create");
  glovepose_pose_init(&pose);
  glovepose_calibration_progress_init(&progress);
  glovepose_xr_hand_init(&hand);
  glovepose_predicted_pose_init(&ahead);
  glovepose_xr_aim_state_init(&aim);
  /* Calibrate from rows of a synthetic glove (set-up: finish allocates the range). */
  glovepose_calibration_start(estimator);
  for (f = 0; f < 40; ++f) {
    synthetic_cells(f / 60.0, cells);
    for (r = 0; r < 180; ++r) glovepose_estimator_push_row(estimator, r, cells[r % 44] + cells[(r / 15) % 44], f / 60.0 + r / 10800.0);
  }
  check(glovepose_calibration_finish(estimator) == GLOVEPOSE_OK, "finish the calibration");
  check(glovepose_latest_create(&latest) == GLOVEPOSE_OK, "create the latest-hand snapshot");
  /* The lock and system-call counters must see calls too: a mutex, a write. */
  {
    pthread_mutex_t probe = PTHREAD_MUTEX_INITIALIZER;
    locks_before = realtime_locks();
    calls_before = realtime_system_calls();
    pthread_mutex_lock(&probe);
    pthread_mutex_unlock(&probe);
    fflush(stdout);
    (void)!write(1, "", 0);
    check(realtime_locks() - locks_before == 1 && realtime_system_calls() - calls_before >= 1, "a lock and a system call are counted (the counters work)");
  }

  fflush(stdout);
  before = realtime_allocations();
  locks_before = realtime_locks();
  calls_before = realtime_system_calls();
  glovepose_calibration_start(estimator); /* while a calibration collects, and after */
  for (f = 40; f < 100; ++f) { /* 10,800 rows and 780 other per-frame calls */
    if (f == 60) glovepose_calibration_cancel(estimator);
    synthetic_cells(f / 60.0, cells);
    for (r = 0; r < 180; ++r)
      if (glovepose_estimator_push_row(estimator, r, cells[r % 44] + cells[(r / 15) % 44], f / 60.0 + r / 10800.0) == GLOVEPOSE_SOLVED)
        ++solved;
    glovepose_estimator_get_pose(estimator, &pose);
    glovepose_estimator_get_joints(estimator, joints, GLOVEPOSE_JOINT_COUNT);
    glovepose_estimator_get_cells(estimator, cells, 44);
    glovepose_calibration_get_progress(estimator, &progress);
    glovepose_calibration_get_step(estimator, &step, &sequence_seconds);
    glovepose_latest_publish(latest, estimator);
    glovepose_latest_read(latest, &pose, joints, GLOVEPOSE_JOINT_COUNT, &number);
    glovepose_estimator_get_pose_at(estimator, f / 60.0 + 0.02, &ahead);
    glovepose_estimator_get_xr_joints(estimator, f / 60.0 + 0.02, &hand);
    glovepose_estimator_get_xr_joints(estimator, f / 60.0 - 0.01, &hand);
    glovepose_latest_get_xr_joints(latest, estimator, f / 60.0 + 0.02, &hand);
    glovepose_estimator_get_xr_aim(estimator, &aim);
    glovepose_latest_get_xr_aim(latest, &aim, &number);
  }
  for (r = 0; r < 180; ++r) frame[r] = 30.0 + 0.01 * r;
  glovepose_estimator_push_measurements(estimator, frame, 180, 2.0);
  synthetic_cells(2.1, cells);
  glovepose_estimator_push_cells(estimator, cells, 44, 2.1, 0.0);
  /* Rejections and per-frame errors (they write the last-error buffer) allocate nothing either. */
  glovepose_estimator_push_row(estimator, 3, NAN, 3.0);
  glovepose_estimator_push_row(NULL, 3, 1.0, 3.0);
  glovepose_estimator_get_joints(estimator, joints, 3);
  pose.struct_size = 1;
  glovepose_estimator_get_pose(estimator, &pose);
  glovepose_estimator_reset(estimator);
  during = realtime_allocations() - before;
  locks_during = realtime_locks() - locks_before;
  calls_during = realtime_system_calls() - calls_before;
  printf("per-frame calls: %d poses, %lu heap allocations, %lu locks, %lu system calls\n", solved, during, locks_during, calls_during);
  check(solved > 400, "poses were computed (11.25 per 180-row cycle)");
  check(during == 0, "no heap allocation in the per-frame calls");
  check(locks_during == 0, "no lock in the per-frame calls");
  check(calls_during == 0, "no system call in the per-frame calls");

  check(number > 0, "the snapshot was read");
  check(hand.active == 1, "OpenXR joints were located");
  glovepose_latest_free(latest);
  glovepose_estimator_free(estimator);
  glovepose_model_free(model);
  printf("%d passed, %d failed\n", passed, failed);
  return failed == 0 ? 0 : 1;
}
