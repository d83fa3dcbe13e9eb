/// @file estimator_stream_fuzz.cpp
/// @brief Fuzz target: the bytes become a sequence of calls on one GlovePoseEstimator (rows, C_m
/// frames, C_c frames, calibration, reset) over the small model tests/fixtures/unet_w4.safetensors,
/// loaded once. Values and timestamps are drawn from plausible ones (so frames do get solved) and
/// from the hostile ones (NaN, infinities, negative, huge, subnormal, backwards, far-future).
///
/// Invariants checked after every call: no crash, no sanitizer report, no exception out of a
/// noexcept call; the status is a Status enumerator; a pose's sequence never decreases and grows by
/// exactly one on Status::Solved and not otherwise; every angle of a solved pose is finite, the raw
/// angles lie within the model's joint limits; timestamps, ages and joint transforms are finite.
/// After every solved pose, pose_at/joints_at at times around it (before, ahead, far ahead, NaN) and
/// on either hand (the side follows from a setting the input already chose): a status, angles
/// within the joint limits, finite joints with unit quaternions, finite velocities.
#include <fuzzer/FuzzedDataProvider.h>

#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <memory>
#include <vector>

#include <glovepose/estimator.hpp>

#include "fuzz_check.hpp"

namespace {

using glovepose::Status;

/// One frame of C_c (pF) from a simulated session (`glovepose simulate`, subject 0, first frame):
/// a plausible hand, which the fuzzer perturbs.
constexpr std::array<double, 44> kPlausibleCells{
    10.258956,  5.3165617,  4.79115152, 5.52944279, 5.48886776, 5.34741068, 5.7981739,  6.36660528, 6.49165821, 5.87227297, 5.05117512,
    5.44433975, 5.27580309, 5.26548624, 5.15029049, 5.50713873, 5.45572376, 5.23373365, 5.87615442, 5.67038059, 8.6448946,  9.50343418,
    8.6990099,  8.60666847, 9.54970455, 7.76580191, 6.80983877, 4.95926142, 6.18497133, 5.93694401, 6.99730682, 6.3174634,  8.51974964,
    11.0602036, 9.04660225, 8.20644188, 8.49531651, 6.50580883, 5.94312954, 5.56613541, 9.25481415, 8.73732376, 8.3549881,  6.27224588};

/// Per-frame calls per input: each costs a solve and a network forward (~0.5 ms under the
/// sanitizers), so an input of bursts could otherwise run for seconds and be reported as a timeout.
constexpr long kCallBudget = 2000;

/// Seconds between two rows at the paper's cadence (180 rows per frame, 60 frames per second).
constexpr double kRowPeriod = 1.0 / (180.0 * 60.0);

struct Fixture {
  std::shared_ptr<const glovepose::PoseModel> model;
  Eigen::VectorXd cells;  // plausible C_c, pF
  Eigen::VectorXd rows;   // the C_m they produce (M C_c), pF
};

const Fixture& fixture() {
  static const Fixture loaded = [] {
    Fixture f;
    f.model = glovepose::PoseModel::load(GLOVEPOSE_SOURCE_DIR "/tests/fixtures/unet_w4.safetensors");
    f.cells = Eigen::Map<const Eigen::VectorXd>(kPlausibleCells.data(), kPlausibleCells.size());
    f.rows = f.model->solver()->measurement_matrix() * f.cells;
    return f;
  }();
  return loaded;
}

/// Picks 0, 1, 2 of reading() and next_time(): NaN, +infinity, -infinity.
constexpr int kNonFiniteKinds = 3;
double non_finite(int pick) {
  if (pick == 0) return std::numeric_limits<double>::quiet_NaN();
  return pick == 1 ? std::numeric_limits<double>::infinity() : -std::numeric_limits<double>::infinity();
}

/// A reading: mostly `plausible` times a small factor, else one of the values a broken link or
/// firmware sends.
double reading(FuzzedDataProvider& in, double plausible) {
  const int pick = in.ConsumeIntegralInRange<int>(0, 11);
  if (pick < kNonFiniteKinds) return non_finite(pick);
  switch (pick) {
    case 3:
      return -plausible;
    case 4:
      return 0.0;
    case 5:
      return std::numeric_limits<double>::max();
    case 6:
      return std::numeric_limits<double>::denorm_min();
    case 7:
      return in.ConsumeFloatingPoint<double>();  // any double
    default:
      return plausible * (1.0 + in.ConsumeFloatingPointInRange<double>(-0.3, 0.3));
  }
}

/// The next timestamp: mostly a step forward from `clock`, else backwards, a gap, or not a time.
double next_time(FuzzedDataProvider& in, double& clock, double step) {
  const int pick = in.ConsumeIntegralInRange<int>(0, 11);
  if (pick < kNonFiniteKinds) return non_finite(pick);
  switch (pick) {
    case 3:
      return clock - in.ConsumeFloatingPointInRange<double>(0.0, 10.0);  // backwards, not kept
    case 4:
      return clock = in.ConsumeFloatingPoint<double>();  // a restarted or corrupt clock
    case 5:
      return clock += in.ConsumeFloatingPointInRange<double>(0.1, 1e6);  // a gap
    case 6:
      return clock;  // the same instant again
    default:
      return clock += step;
  }
}

/// Noise for bursts: a small generator, so a burst of hundreds of readings costs a few input bytes.
struct Noise {
  std::uint64_t state;
  double next() {  // uniform in [-1, 1)
    state = state * 6364136223846793005ull + 1442695040888963407ull;
    return static_cast<double>(state >> 11) * 0x1.0p-52 - 1.0;
  }
};

class StreamChecker {
 public:
  StreamChecker(const glovepose::GlovePoseEstimator& estimator, bool joint_transforms)
      : estimator_(estimator), joint_transforms_(joint_transforms) {}

  // Checks the invariants after a per-frame call that returned `status`.
  void after(Status status) {
    GLOVEPOSE_FUZZ_REQUIRE(static_cast<unsigned>(status) <= static_cast<unsigned>(Status::Uncalibrated));
    const glovepose::Pose& pose = estimator_.pose();
    if (status == Status::Solved) {
      GLOVEPOSE_FUZZ_REQUIRE(pose.sequence == last_sequence_ + 1);
      GLOVEPOSE_FUZZ_REQUIRE(pose.valid);
      GLOVEPOSE_FUZZ_REQUIRE(glovepose::fuzz::all_finite(pose.angles));
      GLOVEPOSE_FUZZ_REQUIRE(glovepose::fuzz::all_finite(pose.raw_angles));
      const auto& limits = estimator_.model().joint_limits();
      for (std::size_t d = 0; d < glovepose::hand::kDofCount; ++d) {
        const double slack = 1e-9 * (limits.max()[d] - limits.min()[d]);
        GLOVEPOSE_FUZZ_REQUIRE(pose.raw_angles[d] >= limits.min()[d] - slack && pose.raw_angles[d] <= limits.max()[d] + slack);
      }
      GLOVEPOSE_FUZZ_REQUIRE(std::isfinite(pose.timestamp));
      GLOVEPOSE_FUZZ_REQUIRE(std::isfinite(pose.oldest_age));
      GLOVEPOSE_FUZZ_REQUIRE(std::isfinite(pose.compute_seconds) && pose.compute_seconds >= 0.0);
      GLOVEPOSE_FUZZ_REQUIRE(std::isfinite(pose.health.max_residual) && pose.health.max_residual >= 0.0);
      constexpr std::uint32_t kAllFlags = (1u << glovepose::kPoseFlagCount) - 1;
      GLOVEPOSE_FUZZ_REQUIRE((pose.flags & ~kAllFlags) == 0);
      if (joint_transforms_)
        for (const glovepose::hand::JointTransform& joint : estimator_.joints())
          GLOVEPOSE_FUZZ_REQUIRE(glovepose::fuzz::all_finite(joint.position) && glovepose::fuzz::all_finite(joint.rotation));
      for (double offset : {-0.005, 0.0, 0.02, 10.0, std::numeric_limits<double>::quiet_NaN()}) check_at(pose.timestamp + offset);
    } else {
      GLOVEPOSE_FUZZ_REQUIRE(pose.sequence == last_sequence_);  // nothing new without Solved
    }
    last_sequence_ = pose.sequence;
  }

 private:
  void check_at(double t) {
    glovepose::PredictedPose at;
    const Status status = estimator_.pose_at(t, at);
    GLOVEPOSE_FUZZ_REQUIRE(status == Status::Ok || status == Status::NonFinite);
    glovepose::hand::XrHandJoints joints;
    GLOVEPOSE_FUZZ_REQUIRE(estimator_.joints_at(t, joints) == status);
    if (status != Status::Ok) return;
    const auto& limits = estimator_.model().joint_limits();
    for (std::size_t d = 0; d < glovepose::hand::kDofCount; ++d) {
      const double slack = 1e-9 * (limits.max()[d] - limits.min()[d]);
      GLOVEPOSE_FUZZ_REQUIRE(at.angles[d] >= limits.min()[d] - slack && at.angles[d] <= limits.max()[d] + slack);
      GLOVEPOSE_FUZZ_REQUIRE(std::isfinite(at.rate[d]));
    }
    GLOVEPOSE_FUZZ_REQUIRE(at.horizon <= estimator_.config().max_prediction);
    for (std::size_t j = 0; j < glovepose::hand::kXrJointCount; ++j) {
      const glovepose::hand::XrPose& p = joints.locations[j].pose;
      GLOVEPOSE_FUZZ_REQUIRE(std::abs(p.position.x) < 1.0f && std::abs(p.position.y) < 1.0f && std::abs(p.position.z) < 1.0f);
      const float norm = p.orientation.x * p.orientation.x + p.orientation.y * p.orientation.y + p.orientation.z * p.orientation.z +
                         p.orientation.w * p.orientation.w;
      GLOVEPOSE_FUZZ_REQUIRE(std::abs(norm - 1.0f) < 1e-4f);
      const glovepose::hand::XrJointVelocity& v = joints.velocities[j];
      GLOVEPOSE_FUZZ_REQUIRE(std::isfinite(v.linear_velocity.x) && std::isfinite(v.linear_velocity.y) &&
                             std::isfinite(v.linear_velocity.z));
      GLOVEPOSE_FUZZ_REQUIRE(std::isfinite(v.angular_velocity.x) && std::isfinite(v.angular_velocity.y) &&
                             std::isfinite(v.angular_velocity.z));
    }
  }

  const glovepose::GlovePoseEstimator& estimator_;
  bool joint_transforms_;
  std::uint64_t last_sequence_ = 0;
};

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const Fixture& f = fixture();
  FuzzedDataProvider in(data, size);

  // Settings from the first bytes: all valid (the constructor's refusals are set-up, not this target).
  glovepose::EstimatorConfig config;
  config.readout.mean_window = in.ConsumeIntegralInRange<int>(1, 8);
  config.readout.solve_every = in.ConsumeIntegralInRange<int>(1, 200);
  config.readout.clock_restart_readings = in.ConsumeIntegralInRange<int>(0, 20);
  config.readout.stuck_readings = in.ConsumeIntegralInRange<int>(2, 40);
  config.clock_restart_frames = in.ConsumeIntegralInRange<int>(1, 12);
  config.calibration_median_window = in.ConsumeIntegralInRange<int>(1, 25);
  config.calibration_sample_period = in.ConsumeBool() ? 0.0 : 1.0 / 60.0;
  if (in.ConsumeBool())
    config.smoothing = glovepose::filter::OneEuroConfig{60.0, 1.0, in.ConsumeFloatingPointInRange<double>(0.0, 10.0), 1.0};
  config.joint_transforms = in.ConsumeBool();
  // The side from a setting already drawn, so that stored inputs keep their meaning.
  config.handedness = config.readout.stuck_readings % 2 == 0 ? glovepose::hand::Handedness::Right : glovepose::hand::Handedness::Left;
  glovepose::GlovePoseEstimator estimator(f.model, config);
  StreamChecker check(estimator, config.joint_transforms);

  const int rows = static_cast<int>(f.rows.size());
  const int cells = static_cast<int>(f.cells.size());
  std::vector<double> frame;
  double clock = 0.0;
  int next_row = 0;
  long calls_left = kCallBudget;
  while (in.remaining_bytes() > 0 && calls_left > 0) {
    --calls_left;
    switch (in.ConsumeIntegralInRange<int>(0, 10)) {
      case 0: {  // one reading of any row, any value, any time
        int row = next_row;
        switch (in.ConsumeIntegralInRange<int>(0, 4)) {
          case 0:
            row = in.ConsumeIntegral<int>();
            break;
          case 1:
            row = in.ConsumeBool() ? -1 : rows;
            break;
          case 2:
            row = in.ConsumeIntegralInRange<int>(0, rows - 1);
            break;
          default:
            next_row = (next_row + 1) % rows;
            break;
        }
        const double value = reading(in, f.rows[(row % rows + rows) % rows]);
        check.after(estimator.push_row(row, value, next_time(in, clock, kRowPeriod)));
        break;
      }
      case 1: {  // a burst of readings in row order: enough to solve frames; every k-th one is faulty
        const int count = in.ConsumeIntegralInRange<int>(1, 4 * rows);
        calls_left -= count;
        const int fault_every = in.ConsumeIntegralInRange<int>(0, 255);  // 0: no faults
        const double amplitude = in.ConsumeFloatingPointInRange<double>(0.0, 0.2);
        Noise noise{in.ConsumeIntegral<std::uint64_t>()};
        const double fault = reading(in, 1.0);
        for (int k = 0; k < count; ++k) {
          const int row = next_row;
          next_row = (next_row + 1) % rows;
          clock += kRowPeriod;
          double value = f.rows[row] * (1.0 + amplitude * noise.next());
          if (fault_every > 0 && k % fault_every == fault_every - 1) value = fault;
          check.after(estimator.push_row(row, value, clock));
        }
        break;
      }
      case 2:    // a whole C_m frame
      case 3: {  // a whole C_c frame
        const bool measurements = in.ConsumeBool();
        const Eigen::VectorXd& plausible = measurements ? f.rows : f.cells;
        int count = static_cast<int>(plausible.size());
        if (in.ConsumeIntegralInRange<int>(0, 15) == 0) count = in.ConsumeIntegralInRange<int>(-1, count + 1);
        frame.assign(static_cast<std::size_t>(std::max(count, 0)), 0.0);
        const double amplitude = in.ConsumeFloatingPointInRange<double>(0.0, 0.3);
        Noise noise{in.ConsumeIntegral<std::uint64_t>()};
        for (std::size_t i = 0; i < frame.size(); ++i)
          frame[i] = plausible[static_cast<Eigen::Index>(i % plausible.size())] * (1.0 + amplitude * noise.next());
        const int faults = in.ConsumeIntegralInRange<int>(0, 3);
        for (int k = 0; k < faults && !frame.empty(); ++k) {
          const std::size_t i = in.ConsumeIntegralInRange<std::size_t>(0, frame.size() - 1);
          frame[i] = reading(in, frame[i]);
        }
        const double* values = in.ConsumeIntegralInRange<int>(0, 31) == 0 ? nullptr : frame.data();
        const double time = next_time(in, clock, 1.0 / 60.0);
        if (measurements) {
          check.after(estimator.push_measurements(values, count, time));
        } else {
          const double oldest_age = in.ConsumeBool() ? 0.0 : reading(in, 0.02);
          check.after(estimator.push_cells(values, count, time, oldest_age));
        }
        break;
      }
      case 4:
        estimator.start_calibration();
        break;
      case 5:
        try {
          const glovepose::sensor::CalibrationRange& range = estimator.finish_calibration();
          GLOVEPOSE_FUZZ_REQUIRE(range.size() == cells);
          GLOVEPOSE_FUZZ_REQUIRE(glovepose::fuzz::all_finite(range.min()) && glovepose::fuzz::all_finite(range.max()));
        } catch (const glovepose::Error&) {
          // Too few frames or no calibration running: refused, as documented.
        }
        break;
      case 6:
        estimator.cancel_calibration();
        break;
      case 7:
        estimator.reset();
        break;
      case 8: {  // a user range around the plausible hand, of any spread (negative: min > max)
        const double spread = reading(in, 0.2);
        const double shift = in.ConsumeFloatingPointInRange<double>(-0.5, 0.5);
        Eigen::VectorXd lo = f.cells * (1.0 + shift - spread), hi = f.cells * (1.0 + shift + spread);
        if (in.ConsumeBool()) hi[in.ConsumeIntegralInRange<int>(0, cells - 1)] = reading(in, hi[0]);
        try {
          estimator.set_calibration(glovepose::sensor::CalibrationRange(lo, hi, f.model->glove().cell_names(), config.calibration));
        } catch (const glovepose::Error&) {
          // Non-finite or reversed limits: refused at set-up, as documented.
        }
        break;
      }
      case 9: {
        const glovepose::CalibrationProgress progress = estimator.calibration_progress();
        GLOVEPOSE_FUZZ_REQUIRE(progress.frames >= 0);
        GLOVEPOSE_FUZZ_REQUIRE(progress.frames_needed == config.calibration_median_window);
        GLOVEPOSE_FUZZ_REQUIRE(!progress.ready || progress.frames >= progress.frames_needed);
        break;
      }
      default: {  // a sudden jump of the plausible hand: moves the calibration's min and max
        const double scale = in.ConsumeFloatingPointInRange<double>(0.5, 2.0);
        frame.assign(f.cells.data(), f.cells.data() + f.cells.size());
        for (double& v : frame) v *= scale;
        check.after(estimator.push_cells(frame.data(), cells, clock += 1.0 / 60.0));
        break;
      }
    }
  }
  return 0;
}
