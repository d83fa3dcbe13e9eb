// Taking the glove off and putting it on again: the detector's state machine on frames made here
// (calibration/donning.hpp), the continuous calibration's restart from a profile, and the estimator
// on simulated removals (sim/recorder.hpp record_removal; its own tests are test_sim.cpp's): each
// one noticed while the glove is off and when it is on again, none while it is worn, and the
// continuous calibration restarted.
#include <glovepose/calibration/donning.hpp>
#include <glovepose/calibration/free_motion.hpp>
#include <glovepose/estimator.hpp>
#include <glovepose/io/dataset.hpp>
#include <glovepose/sim/corpus_dataset.hpp>

#include <doctest/doctest.h>

#include <cmath>
#include <limits>
#include <map>
#include <vector>

#include "alloc_counter.hpp"
#include "test_files.hpp"

using namespace glovepose;
using calibration::DonningConfig;
using calibration::DonningDetector;
using calibration::DonningEvent;

namespace {

// The detector fed `frames` frames at 60 Hz whose every cell reads `level`, from time `t`; returns
// the events with their times.
std::vector<std::pair<DonningEvent, double>> feed(DonningDetector& d, double level, int frames, double& t) {
  std::vector<std::pair<DonningEvent, double>> events;
  std::vector<double> cells(8, level);
  cells[0] = level + 5.0;  // one cell far off: below the 0.75 quantile of 8 cells it does not count
  for (int f = 0; f < frames; ++f, t += 1.0 / 60.0) {
    const DonningEvent e = d.update(cells.data(), t);
    if (e != DonningEvent::None) events.emplace_back(e, t);
  }
  return events;
}

}  // namespace

TEST_CASE("donning: off after off_seconds below the off level, on after on_seconds above the on level, nothing between") {
  const DonningConfig config;
  DonningDetector d(8, config);
  const auto frames = [](double seconds) { return static_cast<int>(std::lround(seconds * 60.0)); };
  double t = 0.0;
  CHECK(feed(d, 0.0, 600, t).empty());  // worn
  CHECK(feed(d, config.off_level - 0.1, frames(config.off_seconds) - 10, t).empty());  // a relaxed hand held a while
  CHECK(feed(d, 0.0, 10, t).empty());
  CHECK_FALSE(d.off());
  const double off_from = t;
  auto events = feed(d, config.off_level - 0.1, frames(config.off_seconds) + 60, t);
  REQUIRE(events.size() == 1);
  CHECK(events[0].first == DonningEvent::Removed);
  CHECK(events[0].second - off_from == doctest::Approx(config.off_seconds).epsilon(0.02));
  CHECK(d.off());
  CHECK(d.level() == doctest::Approx(config.off_level - 0.1));
  CHECK(feed(d, 0.5 * (config.off_level + config.on_level), 300, t).empty());  // between the levels: still off
  CHECK(d.off());
  const double on_from = t;
  events = feed(d, 0.2, frames(config.on_seconds) + 30, t);
  REQUIRE(events.size() == 1);
  CHECK(events[0].first == DonningEvent::Donned);
  CHECK(events[0].second - on_from == doctest::Approx(config.on_seconds).epsilon(0.02));
  CHECK_FALSE(d.off());
  // A non-finite cell leaves the state and the timing; a clock gone back starts the timing over.
  std::vector<double> nan(8, std::numeric_limits<double>::quiet_NaN());
  CHECK(d.update(nan.data(), t) == DonningEvent::None);
  t = 100.0;
  CHECK(feed(d, -0.9, frames(config.off_seconds) - 20, t).empty());
  t = 50.0;  // back by 50 s, well into a dip: the timing starts over
  CHECK(feed(d, -0.9, frames(config.off_seconds) - 1, t).empty());
  CHECK(feed(d, -0.9, 3, t).size() == 1);
  d.reset();
  CHECK_FALSE(d.off());
  DonningConfig crossed;
  crossed.on_level = crossed.off_level - 0.1;
  CHECK_THROWS_AS(DonningDetector(8, crossed), Error);
  CHECK_THROWS_AS(DonningDetector(0, DonningConfig{}), Error);
}

TEST_CASE("donning: the detector's frames allocate nothing") {
  DonningDetector d(44, DonningConfig{});
  std::vector<double> cells(44, -0.95);
  CHECK(test::allocations_during([&] {
          for (int f = 0; f < 200; ++f) (void)d.update(cells.data(), f / 60.0);
        }) == 0);
  CHECK(d.off());
}

TEST_CASE("estimator: a removal is noticed while the glove is off and when it is on, and the calibration restarts from the profile") {
  sim::CorpusConfig config = sim::CorpusConfig::one_session(12, 45.0, 0.0);
  config.world = sim::default_world();
  config.subjects = 2;
  config.sessions = 2;
  config.intra_sessions = 1;
  config.threads = 2;
  config.removal.emplace();
  const io::Dataset data = sim::to_dataset(sim::simulate_corpus(config), config);
  const auto model = PoseModel::load(test::kShippedModel);
  REQUIRE(model->range_map());
  const double donning_end = config.removal->seconds();
  for (int subject = 0; subject < 2; ++subject) {
    CAPTURE(subject);
    GlovePoseEstimator estimator(model);
    REQUIRE(estimator.calibration_source() == CalibrationSource::Continuous);
    std::vector<double> cells(data.cell_count);
    double offset = 0.0, last = 0.0;
    std::int32_t run = -1;
    long off_poses = 0, worn_off_poses = 0, removed_at = -1;
    double donned_at = -1.0, motion_after = -1.0;
    for (std::size_t i = 0; i < data.frames(); ++i) {
      if (data.subject[i] != subject) continue;
      const std::int32_t key = data.session[i] * 4 + data.kind[i];
      if (key != run) offset = last + 1.0 / 60.0 - data.timestamps[i], run = key;  // one clock through the recordings
      last = data.timestamps[i] + offset;
      for (std::size_t c = 0; c < data.cell_count; ++c) cells[c] = data.cells[i * data.cell_count + c];
      const long donnings = estimator.calibration_progress().donnings;
      if (estimator.push_cells(cells.data(), static_cast<int>(cells.size()), last) != Status::Solved) continue;
      const bool removal = data.kind[i] == io::kKindRemoval;
      const double t = data.timestamps[i];
      if ((estimator.pose().flags & kPoseGloveOff) != 0) {
        CHECK_FALSE(estimator.pose().trusted());
        CHECK(estimator.pose().confidence[0] == 0.0);
        ++(removal ? off_poses : worn_off_poses);
        if (removed_at < 0) removed_at = static_cast<long>(i);
      }
      if (estimator.calibration_progress().donnings > donnings) {
        CHECK(donned_at < 0.0);
        donned_at = removal ? t - donning_end : t;  // from the end of the removal: the glove is on
        motion_after = estimator.calibration_progress().motion_frames;
        CHECK(estimator.calibration_source() == CalibrationSource::Continuous);
      }
    }
    CHECK(removed_at >= 0);
    CHECK(off_poses > 60 * 6);  // most of the 10 s off
    CHECK(worn_off_poses == 0);
    CHECK(estimator.calibration_progress().donnings == 1);
    CHECK(donned_at > -config.removal->don_seconds);  // not before the glove was being pulled on
    CHECK(donned_at < 2.0);                           // within 2 s of it being on
    CHECK(motion_after == 0.0);                       // the motion's histograms started over
  }
}

TEST_CASE("continuous range: a restart from a profile starts from it, and a profile cell that is unusable from the prior") {
  const Eigen::VectorXd prior_min = Eigen::VectorXd::Constant(3, 10.0), prior_max = Eigen::VectorXd::Constant(3, 20.0);
  std::vector<calibration::RangeMap::Stage> stages(1);
  stages[0].frames = 100.0;
  stages[0].low = Eigen::MatrixXd::Zero(3, calibration::kRangeFeatures);
  stages[0].high = Eigen::MatrixXd::Zero(3, calibration::kRangeFeatures);
  stages[0].low.col(1).setOnes();   // the 1st percentile
  stages[0].high.col(7).setOnes();  // the 99th
  const calibration::RangeMap map(prior_min, prior_max, stages, calibration::MotionHistogramConfig{});
  calibration::ContinuousRange range(map);
  Eigen::VectorXd profile_min(3), profile_max(3);
  profile_min << 12.0, 11.0, std::numeric_limits<double>::quiet_NaN();
  profile_max << 18.0, 19.0, 20.0;
  CHECK(test::allocations_during([&] { range.reset(profile_min, profile_max); }) == 0);
  CHECK(range.min()(0) == 12.0);
  CHECK(range.max()(1) == 19.0);
  CHECK(range.min()(2) == 10.0);  // NaN: the prior
  CHECK(range.max()(2) == 20.0);
  // With motion, halfway to the first stage by frames the range is halfway from the profile to the map.
  Eigen::VectorXd cells(3);
  for (int f = 0; f < 50; ++f) {
    cells.setConstant(15.0 + (f % 2 ? 0.5 : -0.5) * (1.0 + f * 0.01));
    range.add(cells, f / 60.0);
  }
  range.update();
  const double frames = range.histogram().effective_frames();
  const double a = frames / 100.0;
  double features[calibration::kRangeFeatures];
  range.histogram().features(0, features);
  CHECK(range.min()(0) == doctest::Approx(a * features[1] + (1.0 - a) * 12.0));
  range.reset();
  CHECK(range.min()(0) == 10.0);
}
