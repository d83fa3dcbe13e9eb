// The calibration session apart from the estimator: which frames it takes (the sample period, a
// restarted clock, non-finite frames), the sequence's clock and steps, its range against a min/max
// computed here, and a per-frame add() that allocates nothing.
#include <glovepose/calibration_session.hpp>

#include <doctest/doctest.h>

#include <string>
#include <vector>

#include "alloc_counter.hpp"

using namespace glovepose;

namespace {

calibration::Sequence two_steps() {
  calibration::Step a;
  a.name = "a";
  a.seconds = 2.0;
  calibration::Step b;
  b.name = "b";
  b.seconds = 3.0;
  return calibration::Sequence("test", {a, b}, 0.5);
}

const std::vector<std::string> kNames = {"c0", "c1", "c2"};

}  // namespace

TEST_CASE("calibration session: takes a frame per sample period, none before start or after stop") {
  CalibrationSession session(kNames, 1, sensor::CalibrationConfig{}, 0.05);
  Eigen::VectorXd cells(3);
  cells << 1.0, 2.0, 3.0;
  session.add(cells, 0.0);
  CHECK(session.progress().frames == 0);  // not started
  CHECK_THROWS_WITH_AS((void)session.range(), doctest::Contains("no calibration running"), Error);
  session.start();
  for (int f = 0; f < 100; ++f) session.add(cells, f / 100.0);  // 100 Hz for 1 s, a frame every 0.05 s: 20
  CHECK(session.progress().frames == 20);
  CHECK(session.progress().collecting);
  CHECK(session.progress().step == -1);  // no sequence
  cells(1) = std::numeric_limits<double>::quiet_NaN();
  session.add(cells, 2.0);
  CHECK(session.progress().frames == 20);  // a non-finite frame is not taken
  cells(1) = 2.0;
  session.add(cells, 0.97);  // within the period of the last frame taken (0.95): not taken
  CHECK(session.progress().frames == 20);
  session.restart_clock();
  session.add(cells, 0.97);  // the stream started over: taken whatever its time
  CHECK(session.progress().frames == 21);
  session.stop();
  session.add(cells, 5.0);
  CHECK(session.progress().frames == 21);
  CHECK_FALSE(session.progress().collecting);
}

TEST_CASE("calibration session: the range is the min and max of the frames taken (window 1), computed here") {
  CalibrationSession session(kNames, 1, sensor::CalibrationConfig{}, 0.0);
  session.start();
  CHECK_THROWS_AS((void)session.range(), Error);  // no frame yet
  Eigen::VectorXd lo = Eigen::VectorXd::Constant(3, 1e9), hi = Eigen::VectorXd::Constant(3, -1e9);
  Eigen::VectorXd cells(3);
  for (int f = 0; f < 50; ++f) {
    cells << 1.0 + 0.1 * (f % 7), 5.0 - 0.2 * (f % 5), 2.0 + 0.05 * f;
    lo = lo.cwiseMin(cells);
    hi = hi.cwiseMax(cells);
    session.add(cells, f * 0.01);
  }
  const sensor::CalibrationRange range = session.range();
  CHECK(session.collecting());  // range() does not end the session
  for (Eigen::Index c = 0; c < 3; ++c) {
    CHECK(range.min()(c) == doctest::Approx(lo(c)));
    CHECK(range.max()(c) == doctest::Approx(hi(c)));
  }
}

TEST_CASE("calibration session: with a sequence, keeps its frames and times, says the step, adds without allocating") {
  const calibration::Sequence sequence = two_steps();
  CalibrationSession session(kNames, 5, sensor::CalibrationConfig{}, 0.1, &sequence);
  session.start();
  Eigen::VectorXd cells(3);
  const double t0 = 100.0;  // the stream's clock: the sequence's starts at its first frame
  std::size_t allocations = 0;
  for (int f = 0; f <= 80; ++f) {  // 8 s at 10 Hz, longer than the sequence's 5 s
    cells << f, 2.0 * f, -f;
    allocations += test::allocations_during([&] { session.add(cells, t0 + f * 0.1); });
    if (f == 15) {
      CHECK(session.progress().step == 0);
      CHECK(session.progress().sequence_seconds == doctest::Approx(1.5));
    }
    if (f == 30) CHECK(session.progress().step == 1);
  }
  CHECK(allocations == 0);
  CHECK(session.progress().step == -1);  // after the last step
  // Room for the whole sequence (5 s at 0.1 s, and two to spare): the frames after it are not kept.
  REQUIRE(session.sequence_frames() == 52);
  for (Eigen::Index f = 0; f < session.sequence_frames(); ++f) {
    CHECK(session.sequence_time(f) == doctest::Approx(f * 0.1));
    CHECK(session.sequence_cells(f)(1) == doctest::Approx(2.0 * f));
  }
  session.start();  // a restart forgets the sequence's frames and clock
  CHECK(session.sequence_frames() == 0);
  CHECK(session.progress().step == -1);
}

TEST_CASE("calibration session: a bad sample period is refused, naming it") {
  CHECK_THROWS_WITH_AS(CalibrationSession(kNames, 1, sensor::CalibrationConfig{}, -1.0), doctest::Contains("sample period"), Error);
  CHECK_THROWS_WITH_AS(CalibrationSession(kNames, 1, sensor::CalibrationConfig{}, std::nan("")), doctest::Contains("sample period"), Error);
}
