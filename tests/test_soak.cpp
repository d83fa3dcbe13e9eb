// The soak run, bounded for CI (issue: reliability): three estimators on threads sharing one
// loaded model, each fed minutes of simulated 60 Hz row stream with random faults of every kind
// (tools/soak/soak.hpp; `glovepose soak` runs the same for hours). Every cycle must end in a pose or a
// status that explains why not, every pose must be finite and in sequence, every fault must be
// recovered from within the bound, memory must not grow and nothing may allocate after warm-up.
#include <doctest/doctest.h>

#include "soak/soak.hpp"

#include <sstream>
#include <string>

#include "alloc_counter.hpp"

using namespace glovepose;

namespace {

std::shared_ptr<const PoseModel> soak_model() {
  static const auto model = PoseModel::load(std::string(GLOVEPOSE_SOURCE_DIR) + "/models/glovepose_fcn512.safetensors");
  return model;
}

// 30 s of simulated motion after a 3 s calibration sequence (about 4 s of CPU to simulate).
const io::Dataset& soak_source() {
  static const io::Dataset source = sim::simulate_soak_source(2026, 0.5, 3.0);
  return source;
}

std::string printed(const sim::SoakReport& report) {
  std::ostringstream text;
  report.print(text);
  return text.str();
}

// Poses that carried `flag`.
std::uint64_t poses_flagged(const sim::SoakReport& report, PoseFlag flag) {
  std::size_t bit = 0;
  while ((1u << bit) != flag) ++bit;
  return report.poses_by_flag[bit];
}

}  // namespace

TEST_CASE("soak: three estimators sharing one model through minutes of faulty stream") {
  sim::SoakConfig config;
  config.stream_minutes = 1.5;  // x 3 estimators: 4.5 minutes of stream, about 70 faults
  config.estimators = 3;
  config.seed = 7;
  // Shorter stretches than the default, so that each estimator's 80 s after the warm-up hold at
  // least 16 faults: more than one shuffled round of all 11 kinds.
  config.clean_seconds_min = 1.0;  // 60 cycles: still far beyond the recovery bound
  config.clean_seconds_max = 3.0;
  config.fault_seconds_max = 2.0;
  config.allocation_count = test::allocation_count;
  const sim::SoakReport report = sim::run_soak(soak_model(), soak_source(), config);
  MESSAGE(printed(report));
  for (const std::string& failure : report.failures()) FAIL_CHECK(failure);
  CHECK(report.passed());

  // Every cycle was played and accounted for: the calibration sequence, then the stream.
  const auto calibration_cycles = static_cast<std::uint64_t>(std::llround(report.calibration_seconds * 60.0));
  CHECK(report.cycles == 3 * (calibration_cycles + 90 * 60));
  CHECK(report.trusted_cycles + report.flagged_cycles + report.no_pose_total() == report.cycles);
  // Every kind of fault came (in shuffled rounds of all kinds) and was recovered from.
  for (int k = 0; k < sim::kFaultKindCount; ++k) {
    CAPTURE(sim::to_string(static_cast<sim::FaultKind>(k)));
    CHECK(report.faults[static_cast<std::size_t>(k)] >= 3);
    CHECK(report.recoveries[static_cast<std::size_t>(k)].count == report.faults[static_cast<std::size_t>(k)]);
  }
  // The faults were seen: readings rejected, restarts (NotReady), flagged poses of each detector.
  CHECK(report.statuses[static_cast<std::size_t>(Status::NonFinite)] > 0);
  CHECK(report.statuses[static_cast<std::size_t>(Status::TimestampBackwards)] > 0);
  CHECK(report.statuses[static_cast<std::size_t>(Status::NotReady)] > 0);
  // The shipped model's continuous calibration gives poses from the first frame: none uncalibrated.
  CHECK(report.statuses[static_cast<std::size_t>(Status::Uncalibrated)] == 0);
  // (A disconnected trace's rows are left out of the solve, its poses trusted: tests/test_faults.cpp.)
  for (PoseFlag flag : {kPoseStaleReadings, kPoseStuckRows, kPoseOutlierRows}) {
    CAPTURE(flag);
    CHECK(poses_flagged(report, flag) > 0);
  }
  // The default readout holds one reading per row: a restart's first solve already has whole rows,
  // so no pose is ever "recovering" (the next test and tests/test_faults.cpp see it with longer means).
  REQUIRE(config.estimator.readout.mean_window == 1);
  CHECK(poses_flagged(report, kPoseRecovering) == 0);
  // Most of the stream is clean, so most cycles end in a trusted pose.
  CHECK(report.trusted_cycles > report.cycles / 2);
  // Memory was measured (Linux) and allocations counted.
  CHECK(report.rss_after_warmup_kib > 0);
  CHECK(report.allocations_counted);
}

TEST_CASE("soak: the run fails when a check does not hold") {
  // A recovery bound no restart can meet (the paper's 5-reading mean needs 5 cycles to fill): the
  // run must say so, and the rows still filling are flagged.
  sim::SoakConfig config;
  config.estimator.readout.mean_window = 5;
  config.stream_minutes = 0.5;
  config.estimators = 1;
  config.seed = 3;
  config.warmup_seconds = 2.0;
  config.recovery_bound_cycles = 1;
  const sim::SoakReport report = sim::run_soak(soak_model(), soak_source(), config);
  CHECK_FALSE(report.passed());
  bool named = false;
  for (const std::string& failure : report.failures()) named = named || failure.find("a recovery took") != std::string::npos;
  CHECK(named);
  CHECK(printed(report).find("soak: FAILED") != std::string::npos);
  CHECK(poses_flagged(report, kPoseRecovering) > 0);
}

TEST_CASE("soak: set-up errors name what is wrong") {
  sim::SoakConfig config;
  config.estimators = 0;
  CHECK_THROWS_WITH_AS(sim::run_soak(soak_model(), soak_source(), config), doctest::Contains("--estimators 0"), Error);
  config = sim::SoakConfig{};
  config.stream_minutes = 0.1;  // 6 s: shorter than the warm-up
  CHECK_THROWS_WITH_AS(sim::run_soak(soak_model(), soak_source(), config), doctest::Contains("warm-up"), Error);
  io::Dataset no_rows = soak_source();
  no_rows.row_count = 0;
  no_rows.raw_rows.clear();
  CHECK_THROWS_WITH_AS(sim::run_soak(soak_model(), no_rows, sim::SoakConfig{}), doctest::Contains("raw rows"), Error);
}
