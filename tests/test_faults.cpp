// Fault injection in the row stream (issue: reliability). A simulated session is streamed row by
// row through a calibrated estimator twice: clean, and with one fault injected during frames
// [kFaultBegin, kFaultEnd). For every fault the estimator keeps running, never emits a non-finite
// angle, flags the frames it cannot trust, keeps its trusted frames close to the clean stream's,
// and is back to the clean stream's accuracy (and to unflagged frames) kRecoveryFrames after the
// fault ends.
#include <doctest/doctest.h>

#include <glovepose/estimator.hpp>
#include <glovepose/sim/corpus_dataset.hpp>

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <vector>

using namespace glovepose;

namespace {

constexpr std::size_t kFaultBegin = 120, kFaultEnd = 240;  // frames of the session (60 per second)
constexpr double kRowSlot = 1.0 / (180 * 60.0);

const train::Dataset& faults_session() {
  static const train::Dataset d = [] {
    sim::CorpusConfig config;
    config.seed = 43;
    config.subjects = 1;
    config.sessions = 1;
    config.gloves = 1;
    config.minutes = 0.15;  // 9 s
    config.calibration_seconds = 3.0;
    config.threads = 1;
    config.recording.raw_rows = true;  // default noise: readout jitter, rare spikes and drops
    return sim::to_dataset(sim::simulate_corpus(config), config);
  }();
  return d;
}

std::size_t first_session_frame() {
  const train::Dataset& d = faults_session();
  std::size_t f = 0;
  while (d.kind[f] == train::kKindCalibration) ++f;
  return f;
}

std::shared_ptr<const PoseModel> faults_model() {
  static const auto model = PoseModel::load(std::string(GLOVEPOSE_SOURCE_DIR) + "/models/glovepose_unet64.safetensors");
  return model;
}

// The on-the-fly range of the session's calibration sequence, shared by the clean and faulty runs.
const sensor::CalibrationRange& faults_range() {
  static const sensor::CalibrationRange range = [] {
    const train::Dataset& d = faults_session();
    GlovePoseEstimator estimator(faults_model());
    estimator.start_calibration();
    for (std::size_t f = 0; f < first_session_frame(); ++f)
      for (int r = 0; r < 180; ++r)
        (void)estimator.push_row(r, d.raw_rows[f * 180 + static_cast<std::size_t>(r)], d.timestamps[f] - (179 - r) * kRowSlot);
    return estimator.finish_calibration();
  }();
  return range;
}

// One reading as the glove would deliver it; a fault turns it into zero, one or more readings.
struct Reading {
  int row;
  double value;
  double timestamp;
};
// frame (from the session start), the reading, the readings to push.
using Fault = std::function<void(std::size_t, const Reading&, std::vector<Reading>&)>;

struct FrameRecord {
  bool fresh = false;  // a new pose was produced during the frame
  bool valid = false;
  bool finite = true;
  std::uint32_t flags = 0;
  hand::Angles angles{};
};

struct Run {
  std::vector<FrameRecord> frames;  // one per session frame: the latest pose at the frame's end
  long rejected_statuses = 0;
};

Run stream(const Fault& fault) {
  const train::Dataset& d = faults_session();
  GlovePoseEstimator estimator(faults_model());
  estimator.set_calibration(faults_range());
  Run run;
  std::vector<Reading> out;
  std::uint64_t last_sequence = 0;
  const std::size_t first = first_session_frame();
  for (std::size_t f = first; f < d.frames(); ++f) {
    for (int r = 0; r < 180; ++r) {
      const Reading in{r, d.raw_rows[f * 180 + static_cast<std::size_t>(r)], d.timestamps[f] - (179 - r) * kRowSlot};
      out.clear();
      if (fault && f - first >= kFaultBegin && f - first < kFaultEnd)
        fault(f - first, in, out);
      else
        out.push_back(in);
      for (const Reading& x : out) run.rejected_statuses += accepted(estimator.push_row(x.row, x.value, x.timestamp)) ? 0 : 1;
    }
    FrameRecord rec;
    const Pose& p = estimator.pose();
    rec.fresh = p.sequence != last_sequence;
    last_sequence = p.sequence;
    rec.valid = p.valid;
    rec.flags = p.flags;
    rec.angles = p.angles;
    for (double a : p.angles) rec.finite = rec.finite && std::isfinite(a);
    run.frames.push_back(rec);
  }
  return run;
}

const Run& clean_run() {
  static const Run run = stream(nullptr);
  return run;
}

double mean_error_degrees(const Run& run, std::size_t begin, std::size_t end) {
  const train::Dataset& d = faults_session();
  const std::size_t first = first_session_frame();
  double sum = 0.0;
  for (std::size_t i = begin; i < end; ++i)
    for (std::size_t k = 0; k < hand::kDofCount; ++k)
      sum += std::abs(run.frames[i].angles[k] - d.angles[(first + i) * hand::kDofCount + k]);
  return sum * 180.0 / 3.14159265358979 / static_cast<double>((end - begin) * hand::kDofCount);
}

double angle_difference_degrees(const FrameRecord& a, const FrameRecord& b) {
  double worst = 0.0;
  for (std::size_t k = 0; k < hand::kDofCount; ++k) worst = std::max(worst, std::abs(a.angles[k] - b.angles[k]));
  return worst * 180.0 / 3.14159265358979;
}

struct Expectation {
  std::uint32_t flag = 0;          // the flag the fault must raise (0: none required)
  double flagged_share = 0.0;      // of the fault's frames after `detect_after` frames
  std::size_t detect_after = 0;    // frames into the fault before it must be visible
  std::size_t recovery_frames = 6; // frames after the fault ends until the stream is normal again
};

// Mean error over the DoFs of one frame, degrees.
double frame_error_degrees(const FrameRecord& r, std::size_t frame) {
  const train::Dataset& d = faults_session();
  const std::size_t row = (first_session_frame() + frame) * hand::kDofCount;
  double sum = 0.0;
  for (std::size_t k = 0; k < hand::kDofCount; ++k) sum += std::abs(r.angles[k] - d.angles[row + k]);
  return sum * 180.0 / 3.14159265358979 / static_cast<double>(hand::kDofCount);
}

// The checks every fault must pass; returns the run for fault-specific checks. A pose is trusted
// when it is new (produced during its frame) and carries no fault flag. The solve cadence (a
// solve every 16 accepted readings) shifts with every lost or extra reading, and a pose depends on
// the solve's place in the cycle by a few degrees, so trusted poses are compared with the truth
// (the simulator's angles) as the clean stream is, not pose by pose with the clean stream.
Run check_fault(const char* name, const Fault& fault, const Expectation& expect) {
  const Run& clean = clean_run();
  Run run = stream(fault);
  REQUIRE(run.frames.size() == clean.frames.size());
  const std::size_t n = run.frames.size();
  const auto trusted = [](const FrameRecord& r) { return r.fresh && r.valid && (r.flags & kPoseFaultFlags) == 0; };
  double clean_worst = 0.0;
  for (std::size_t i = 6; i < n; ++i)
    if (trusted(clean.frames[i])) clean_worst = std::max(clean_worst, frame_error_degrees(clean.frames[i], i));
  bool finite = true;
  std::size_t flagged = 0, trusted_during = 0;
  double worst_trusted = 0.0, error_during = 0.0, clean_during = 0.0;
  for (std::size_t i = 0; i < n; ++i) {
    finite = finite && run.frames[i].finite;
    if (i >= kFaultBegin + expect.detect_after && i < kFaultEnd && (run.frames[i].flags & expect.flag) != 0) ++flagged;
    if (i >= 6 && trusted(run.frames[i])) worst_trusted = std::max(worst_trusted, frame_error_degrees(run.frames[i], i));
    if (i >= kFaultBegin && i < kFaultEnd && trusted(run.frames[i])) {
      ++trusted_during;
      error_during += frame_error_degrees(run.frames[i], i);
      clean_during += frame_error_degrees(clean.frames[i], i);
    }
  }
  const std::size_t recovered = kFaultEnd + expect.recovery_frames;
  std::size_t flagged_after = 0;  // flagged where the clean stream is not
  for (std::size_t i = recovered; i < n; ++i)
    flagged_after += (run.frames[i].flags & kPoseFaultFlags) != 0 && (clean.frames[i].flags & kPoseFaultFlags) == 0;
  const double share = static_cast<double>(flagged) / static_cast<double>(kFaultEnd - kFaultBegin - expect.detect_after);
  const double error_after = mean_error_degrees(run, recovered, n), clean_after = mean_error_degrees(clean, recovered, n);
  if (trusted_during > 0) {
    error_during /= static_cast<double>(trusted_during);
    clean_during /= static_cast<double>(trusted_during);
  }
  MESSAGE(std::string(name) << ": flagged " << 100.0 * share << "% of the fault's frames; " << trusted_during
                            << " trusted frames in the fault, error " << error_during << " deg (clean " << clean_during
                            << "); worst trusted frame " << worst_trusted << " deg (clean " << clean_worst << "); after "
                            << expect.recovery_frames << " frames: error " << error_after << " deg (clean " << clean_after << "), "
                            << flagged_after << " frames flagged that the clean stream does not flag");
  CHECK(finite);
  CHECK(share >= expect.flagged_share);
  CHECK(error_during <= clean_during + 1.0);
  CHECK(worst_trusted <= clean_worst + 2.0);
  CHECK(flagged_after == 0);
  CHECK(std::abs(error_after - clean_after) < 0.1);
  return run;
}

}  // namespace

TEST_CASE("faults: the clean stream is trusted and accurate") {
  const Run& clean = clean_run();
  std::size_t flagged = 0;
  for (std::size_t i = 6; i < clean.frames.size(); ++i) flagged += (clean.frames[i].flags & kPoseFaultFlags) != 0;
  MESSAGE("clean stream: " << flagged << " of " << clean.frames.size() - 6 << " frames flagged; error "
                           << mean_error_degrees(clean, 6, clean.frames.size()) << " deg");
  CHECK(flagged <= clean.frames.size() / 100);  // the simulator's own rare spikes may be flagged
  CHECK(mean_error_degrees(clean, 6, clean.frames.size()) < 10.0);
}

TEST_CASE("faults: dropped rows") {
  // One reading in five lost on the link: the rows keep their previous readings; nothing to flag.
  check_fault("random drops (20%)", [](std::size_t, const Reading& in, std::vector<Reading>& out) {
    if ((in.row * 7 + static_cast<int>(in.timestamp * 1e4)) % 5 != 0) out.push_back(in);
  }, {});
  // Every row of bottom trace 2 lost: their readings age until the pose is flagged stale.
  check_fault("a burst of lost rows (trace 2)", [](std::size_t, const Reading& in, std::vector<Reading>& out) {
    if (in.row / 12 != 2) out.push_back(in);
  }, {kPoseStaleReadings, 1.0, 3, 6});
}

TEST_CASE("faults: duplicated and out-of-order rows") {
  check_fault("every row twice", [](std::size_t, const Reading& in, std::vector<Reading>& out) {
    out.push_back(in);
    out.push_back(in);
  }, {});
  // Rows delivered in swapped pairs: the late one is older than the last accepted, and rejected.
  Reading held{-1, 0.0, 0.0};
  const Run run = check_fault("rows swapped in pairs", [held](std::size_t, const Reading& in, std::vector<Reading>& out) mutable {
    if (in.row % 2 == 0) {
      held = in;
      return;
    }
    out.push_back(in);
    out.push_back(held);
  }, {kPoseReadingsRejected, 1.0, 0, 6});
  CHECK(run.rejected_statuses >= 90 * static_cast<long>(kFaultEnd - kFaultBegin));
}

TEST_CASE("faults: a stuck sensor") {
  double stuck = -1.0;
  check_fault("row 50 stuck", [stuck](std::size_t, const Reading& in, std::vector<Reading>& out) mutable {
    Reading r = in;
    if (in.row == 50) {
      if (stuck < 0.0) stuck = in.value;
      r.value = stuck;
    }
    out.push_back(r);
  }, {kPoseStuckRows, 1.0, 30, 6});
}

TEST_CASE("faults: a disconnected trace") {
  check_fault("top trace 4 disconnected", [](std::size_t, const Reading& in, std::vector<Reading>& out) {
    Reading r = in;
    if (in.row % 12 == 4) r.value = 0.05;  // stray capacitance only
    out.push_back(r);
  }, {kPoseDisconnectedRows | kPoseOutlierRows, 1.0, 0, 6});
}

TEST_CASE("faults: spikes") {
  const Run run = check_fault("spikes of +30 pF in 1 reading of 500", [](std::size_t, const Reading& in, std::vector<Reading>& out) {
    Reading r = in;
    if ((in.row * 131 + static_cast<long>(in.timestamp * 1e4)) % 500 == 0) r.value += 30.0;
    out.push_back(r);
  }, {kPoseOutlierRows, 0.5, 0, 6});
  (void)run;
}

TEST_CASE("faults: NaN and infinite readings") {
  const Run run = check_fault("NaN and Inf in 1 reading of 10", [](std::size_t, const Reading& in, std::vector<Reading>& out) {
    Reading r = in;
    const long k = in.row * 13 + static_cast<long>(in.timestamp * 1e4);
    if (k % 20 == 0) r.value = std::numeric_limits<double>::quiet_NaN();
    if (k % 20 == 10) r.value = std::numeric_limits<double>::infinity();
    out.push_back(r);
  }, {kPoseReadingsRejected, 0.9, 0, 6});
  CHECK(run.rejected_statuses > 1000);
}

TEST_CASE("faults: glove unplugged and plugged back (a gap in the stream)") {
  // 2 s without any reading; then the readout starts over: no stale pre-gap readings are mixed in,
  // the first poses after it are flagged as recovering, and the smoothing restarts.
  const Run run = check_fault("unplugged for 2 s", [](std::size_t, const Reading&, std::vector<Reading>&) {}, {0, 0.0, 0, 6});
  // During the gap the last pose stays (nothing arrives); the first frame after it is recovering.
  CHECK((run.frames[kFaultEnd].flags & kPoseRecovering) != 0);
}

TEST_CASE("faults: clock jumps") {
  check_fault("clock jumps forward by 100 s", [](std::size_t, const Reading& in, std::vector<Reading>& out) {
    out.push_back(in);
    out.back().timestamp += 100.0;
  }, {kPoseRecovering, 0.0, 0, 7});
  // Backwards: the readings are rejected as out of order until a whole cycle of them shows the
  // clock restarted; then the readout follows the new clock, and again when it jumps back.
  const Run run = check_fault("clock jumps back by 100 s", [](std::size_t, const Reading& in, std::vector<Reading>& out) {
    out.push_back(in);
    out.back().timestamp -= 100.0;
  }, {kPoseRecovering, 0.0, 0, 7});
  CHECK(run.rejected_statuses >= 180);
}
