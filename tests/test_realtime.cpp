// The per-frame calls of the C++ API allocate nothing, take no lock and make no system call
// (GLOVEPOSE_REALTIME's contract), through the compiled library (glovepose::compiled), counted
// where they would leave the code (realtime_counters.c interposes glibc's allocators, the pthread
// locks and the system-call wrappers). capi/tests/test_capi_allocations.c checks the C ABI.
//
// Its own program, without doctest (whose checks allocate).
// Usage: glovepose_realtime_test FCN_MODEL UNET_MODEL (the shipped models).
// Last line "N passed, N failed"; exit code 0 when none failed, 77 when GLOVEPOSE_ISA names an
// instruction set this CPU does not execute (skipped).
#include <glovepose/glovepose.hpp>
#include <glovepose/hand/xr_hand.hpp>
#include <glovepose/model/network_variants.hpp>
#include <glovepose/nn/isa.hpp>
#include <glovepose/pose_prediction.hpp>
#include <glovepose/sensor/layout.hpp>

#include <pthread.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <limits>
#include <memory>

#include "realtime_counters.h"

using namespace glovepose;

namespace {
int passed = 0, failed = 0;
void check(bool condition, const char* what) {
  if (condition) {
    ++passed;
  } else {
    ++failed;
    std::printf("FAILED: %s\n", what);
  }
}

// 44 made-up cells; from frame kTearFrame to kMendFrame cell 7 floats (a torn trace: about 0 pF).
constexpr int kTearFrame = 150, kMendFrame = 170;
void synthetic_cells(double t, double* cells) {
  for (int c = 0; c < 44; ++c) cells[c] = 20.0 + 5.0 * std::sin(2.0 * 3.14159265358979 * (0.7 + 0.05 * c) * t + c);
  const int frame = static_cast<int>(std::lround(t * 60.0));
  if (frame >= kTearFrame && frame < kMendFrame) cells[7] = 0.05;
}
// Row r of the glove's 180 from those cells: (M C_c)_r, so that the solve returns them.
double row_value(const Eigen::MatrixXd& m, const double* cells, int r) {
  double sum = 0.0;
  for (int c = 0; c < 44; ++c) sum += m(r, c) * cells[c];
  return sum;
}

// What the per-frame calls of one estimator did: 10,800 rows and 780 other calls after a
// calibration (set-up, not counted).
struct Counts {
  long poses = 0;
  long masked = 0;  // poses with floating cells stood in for
  unsigned long allocations = 0, locks = 0, system_calls = 0;
  bool located = false;  // OpenXR joints were located
};

Counts per_frame_counts(const std::shared_ptr<const PoseModel>& model, int network_threads) {
  EstimatorConfig config;
  config.smoothing = filter::OneEuroConfig{};
  config.joint_transforms = true;
  config.network_threads = network_threads;
  GlovePoseEstimator estimator(model, config);
  const Eigen::MatrixXd m = sensor::TraceLayout::glauser2019().measurement_matrix();
  double cells[44], frame[180];
  estimator.start_calibration();  // set-up: finish_calibration allocates the range
  for (int f = 0; f < 40; ++f) {
    synthetic_cells(f / 60.0, cells);
    for (int r = 0; r < 180; ++r) (void)estimator.push_row(r, row_value(m, cells, r), f / 60.0 + r / 10800.0);
  }
  estimator.finish_calibration();
  LatestHand latest;
  hand::LatestAim latest_aim;
  HandState state;
  hand::XrHandAim aim;
  hand::XrHandJoints xr;
  PredictedPose ahead;

  std::fflush(stdout);
  Counts counts;
  const unsigned long allocations = realtime_allocations(), locks = realtime_locks(), calls = realtime_system_calls();
  double sum = 0.0;  // reads of every output, kept so that none is optimised away
  estimator.start_calibration();  // while a calibration collects, and after
  for (int f = 40; f < 200; ++f) {  // a torn trace's cell from kTearFrame on: stood in for, the regression solved
    if (f == 60) estimator.cancel_calibration();
    synthetic_cells(f / 60.0, cells);
    for (int r = 0; r < 180; ++r)
      if (estimator.push_row(r, row_value(m, cells, r), f / 60.0 + r / 10800.0) == Status::Solved) {
        ++counts.poses;
        counts.masked += (estimator.pose().flags & kPoseMaskedCells) != 0 ? 1 : 0;
      }
    sum += estimator.pose().angles[3] + estimator.joints()[4].position[1] + estimator.cells()[7] + estimator.normalized_cells()[5];
    sum += static_cast<double>(estimator.calibration_progress().frames);
    latest.publish(estimator.state());
    (void)latest.read(state);
    latest_aim.publish(estimator.aim());
    (void)latest_aim.read(aim);
    (void)estimator.pose_at(f / 60.0 + 0.02, ahead);
    (void)estimator.joints_at(f / 60.0 + 0.02, xr);
    (void)estimator.joints_at(f / 60.0 - 0.01, xr);
    (void)predict(state, estimator.locator(), f / 60.0 + 0.02, estimator.config().max_prediction, ahead);
    locate(ahead, estimator.locator(), xr);
    sum += ahead.angles[2] + aim.pinch_strength[0];
  }
  for (int r = 0; r < 180; ++r) frame[r] = 30.0 + 0.01 * r;
  (void)estimator.push_measurements(frame, 180, 4.0);
  synthetic_cells(4.1, cells);
  (void)estimator.push_cells(cells, 44, 4.1);
  // Rejections answer with a status, allocating nothing either.
  (void)estimator.push_row(3, std::numeric_limits<double>::quiet_NaN(), 3.0);
  (void)estimator.push_measurements(frame, 17, 3.0);
  (void)estimator.push_cells(nullptr, 44, 3.0);
  estimator.reset();
  counts.allocations = realtime_allocations() - allocations;
  counts.locks = realtime_locks() - locks;
  counts.system_calls = realtime_system_calls() - calls;
  counts.located = xr.active;
  std::printf("network_threads %d: %ld poses (%ld with a floating cell stood in for), %lu heap allocations, %lu locks, %lu system calls (checksum %g)\n", network_threads,
              counts.poses, counts.masked, counts.allocations, counts.locks, counts.system_calls, sum);
  return counts;
}
}  // namespace

int main(int argc, char** argv) {
  if (argc != 3) {
    std::printf("usage: %s FCN_MODEL UNET_MODEL\n", argv[0]);
    return 2;
  }
  try {
    std::printf("networks: %s\n", nn::isa_word(model::process_isa()));
  } catch (const Error& e) {
    std::printf("skipped: %s\n", e.what());
    return 77;
  }
  std::shared_ptr<const PoseModel> fcn, unet;
  const unsigned long loading = realtime_allocations();
  try {
    fcn = PoseModel::load(argv[1]);
    unet = PoseModel::load(argv[2]);
  } catch (const Error& e) {
    std::printf("cannot load a model: %s\n", e.what());
    return 1;
  }
  check(realtime_allocations() - loading > 10, "loading a model is seen allocating (the counter works)");
  {  // the lock and system-call counters must see calls too: a mutex, a write
    pthread_mutex_t probe = PTHREAD_MUTEX_INITIALIZER;
    const unsigned long locks = realtime_locks(), calls = realtime_system_calls();
    pthread_mutex_lock(&probe);
    pthread_mutex_unlock(&probe);
    std::fflush(stdout);
    (void)!write(1, "", 0);
    check(realtime_locks() - locks == 1 && realtime_system_calls() - calls >= 1, "a lock and a system call are counted (the counters work)");
  }
  for (const auto& model : {fcn, unet}) {  // the default model, and the U-Net on one thread
    const Counts counts = per_frame_counts(model, 1);
    check(counts.poses > 400, "poses were computed (11.25 per 180-row cycle)");
    check(counts.masked > 100, "a floating cell was stood in for (the regression on the others solved in the counted calls)");
    check(counts.allocations == 0, "no heap allocation in the per-frame calls");
    check(counts.locks == 0, "no lock in the per-frame calls");
    check(counts.system_calls == 0, "no system call in the per-frame calls");
    check(counts.located, "OpenXR joints were located");
  }
  // The one documented exception (EstimatorConfig::network_threads): a U-Net shared by a team wakes
  // its parked workers through a mutex and a condition variable. Allocation-free all the same.
  const Counts team = per_frame_counts(unet, 2);
  check(team.poses > 400 && team.allocations == 0, "a team of 2: poses, no heap allocation");
  check(team.locks > 0, "a team of 2 takes locks, as network_threads documents (update it when this changes)");
  std::printf("%d passed, %d failed\n", passed, failed);
  return failed == 0 ? 0 : 1;
}
