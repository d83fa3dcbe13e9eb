// Google Benchmark cases for GlovePoseEstimator, the whole per-frame pipeline (run:
// build/bench/glovepose_bench --benchmark_filter=Estimator). The shipped model (FCN 4 x 512),
// calibrated on the fly on a simulated calibration sequence, with 1-euro smoothing and joint
// transforms on; the input is a simulated session's raw rows. Argument: weight storage, 0 = F32,
// 1 = F16, 2 = BF16, 3 = Fixed16 (the real-time choice; also the label). GLOVEPOSE_BENCH_MODEL=path
// runs another model file instead (an FCN, a previous model) for a comparison in the same session.
// - BM_EstimatorFrame/<storage>: one iteration = one frame: push_measurements of a whole C_m frame
//   of 180 rows, which solves once (solve, calibrate, network, 1-euro, kinematics and
//   joint list). frames/s counts poses.
// - BM_EstimatorFrameContact/<0|1>: BM_EstimatorFrame/3 on a recording with many pinches, the contact
//   stage (hand/contact.hpp) off and on.
// - BM_EstimatorFrameXr/3: BM_EstimatorFrame/3 plus joints_at (OpenXR joints, predicted, with velocities).
// - BM_EstimatorRow/<storage>: one iteration = one push_row at the paper's cadence (a solve and a
//   pose every 16 rows, 11.25 per 180-row cycle): the mean cost of a row as the glove streams.
#include <glovepose/estimator.hpp>
#include <glovepose/sim/corpus_dataset.hpp>

#include <benchmark/benchmark.h>

#include <algorithm>
#include <cstdlib>
#include <map>
#include <memory>
#include <vector>

using namespace glovepose;

namespace {

// A simulated subject's 3 s calibration sequence and 10 s session, with the raw rows; the rows of
// the session frames as doubles, ready to push.
struct Recording {
  io::Dataset data;
  std::size_t first_session_frame = 0;
  std::vector<double> session_rows;  // (frames - first_session_frame) x 180
};

Recording simulate_recording(std::uint64_t seed, double seconds) {
  sim::CorpusConfig config = sim::CorpusConfig::one_session(seed, seconds, 3.0);
  config.recording.raw_rows = true;
  Recording out;
  out.data = sim::to_dataset(sim::simulate_corpus(config), config);
  out.first_session_frame = out.data.first_session_frame();
  out.session_rows.assign(out.data.raw_rows.begin() + static_cast<std::ptrdiff_t>(out.first_session_frame * out.data.row_count),
                          out.data.raw_rows.end());
  return out;
}

const Recording& recording() {
  static const Recording r = simulate_recording(11, 10.0);
  return r;
}

// 40 s of seed 31, whose person pinches often: the contact stage adjusts about a quarter of its
// poses (tests/test_contact.cpp), where seed 11's 10 s have none.
const Recording& pinch_recording() {
  static const Recording r = simulate_recording(31, 40.0);
  return r;
}

std::shared_ptr<const PoseModel> shipped_model(nn::WeightStorage storage) {
  static std::map<nn::WeightStorage, std::shared_ptr<const PoseModel>> models;  // benchmarks run on one thread
  auto& model = models[storage];
  if (!model) {
    PoseModelOptions options;
    options.storage = storage;
    const char* path = std::getenv("GLOVEPOSE_BENCH_MODEL");
    model = PoseModel::load(path && *path ? path : std::string(GLOVEPOSE_SOURCE_DIR) + "/models/glovepose_fcn512.safetensors", options);
  }
  return model;
}

// An estimator with smoothing and joint transforms, calibrated on the calibration sequence's frames.
GlovePoseEstimator calibrated_estimator(nn::WeightStorage storage, EstimatorConfig config = {}, const Recording& r = recording()) {
  config.smoothing = filter::OneEuroConfig{60.0, 1.0, 0.5, 1.0};
  config.joint_transforms = true;
  GlovePoseEstimator estimator(shipped_model(storage), config);
  const io::Dataset& d = r.data;
  std::vector<double> frame(d.row_count);
  estimator.start_calibration();
  for (std::size_t f = 0; f < r.first_session_frame; ++f) {
    frame.assign(d.raw_rows.begin() + static_cast<std::ptrdiff_t>(f * d.row_count),
                 d.raw_rows.begin() + static_cast<std::ptrdiff_t>((f + 1) * d.row_count));
    (void)estimator.push_measurements(frame.data(), static_cast<int>(frame.size()), d.timestamps[f]);
  }
  estimator.finish_calibration();
  // The 3 s sequence is too short for the pose-guided calibration: set offsets as it would leave
  // them, so that every pose pays for them as the default calibration's do.
  if (estimator.model().pose_offset()) {
    hand::Angles offsets{};
    for (std::size_t d = 0; d < hand::kDofCount; ++d) offsets[d] = 0.01 * (static_cast<double>(d % 5) - 2.0);
    estimator.set_calibration(*estimator.calibration(), offsets);
  }
  return estimator;
}

nn::WeightStorage storage_of(const benchmark::State& state) {
  return static_cast<nn::WeightStorage>(state.range(0));  // nn::WeightStorage's order
}

// The session's frames over and over; time keeps running on, one session length per lap.
struct SessionClock {
  const Recording& r;
  std::size_t frames = r.data.frames() - r.first_session_frame;
  double lap = r.data.timestamps.back() - r.data.timestamps[r.first_session_frame] + 1.0 / r.data.frame_rate();
  std::size_t frame = 0;
  double offset = 0.0;

  double timestamp() const { return r.data.timestamps[r.first_session_frame + frame] + offset; }
  const double* rows() const { return r.session_rows.data() + frame * r.data.row_count; }
  void next() {
    if (++frame == frames) {
      frame = 0;
      offset += lap;
    }
  }
};

void BM_EstimatorFrame(benchmark::State& state) {
  GlovePoseEstimator estimator = calibrated_estimator(storage_of(state));
  const int rows = static_cast<int>(recording().data.row_count);
  SessionClock clock{recording()};
  for (auto _ : state) {
    if (estimator.push_measurements(clock.rows(), rows, clock.timestamp()) != Status::Solved) {
      state.SkipWithError("push_measurements did not give a pose");
      break;
    }
    benchmark::DoNotOptimize(estimator.joints());
    clock.next();
  }
  state.counters["frames/s"] = benchmark::Counter(static_cast<double>(state.iterations()), benchmark::Counter::kIsRate);
  state.SetLabel(nn::storage_name(storage_of(state)));
}

// BM_EstimatorFrame/3 on a recording where the person pinches often (pinch_recording), with the
// contact stage off (0) and on (1, EstimatorConfig::contact's defaults): the same frames, so the
// ratio of the two is the stage's cost where it has work. "adjusted": the share of poses it changed.
void BM_EstimatorFrameContact(benchmark::State& state) {
  EstimatorConfig config;
  if (state.range(0) != 0) config.contact = hand::ContactConfig{};
  GlovePoseEstimator estimator = calibrated_estimator(nn::WeightStorage::Fixed16, config, pinch_recording());
  const int rows = static_cast<int>(pinch_recording().data.row_count);
  SessionClock clock{pinch_recording()};
  std::size_t adjusted = 0;
  for (auto _ : state) {
    if (estimator.push_measurements(clock.rows(), rows, clock.timestamp()) != Status::Solved) {
      state.SkipWithError("push_measurements did not give a pose");
      break;
    }
    adjusted += estimator.contact().closed >= 0;
    benchmark::DoNotOptimize(estimator.joints());
    clock.next();
  }
  state.counters["frames/s"] = benchmark::Counter(static_cast<double>(state.iterations()), benchmark::Counter::kIsRate);
  state.counters["adjusted"] = static_cast<double>(adjusted) / static_cast<double>(std::max<benchmark::IterationCount>(state.iterations(), 1));
  state.SetLabel(state.range(0) != 0 ? "Fixed16, contact stage on" : "Fixed16, contact stage off");
}

// BM_EstimatorFrame plus the OpenXR joints an engine asks for (joints_at 11 ms past the newest
// pose: slope, prediction, kinematics with each DoF's axis for the velocities). The prediction window spans
// the trend's 128 poses, the most a fit ever reads (a real stream at 675 poses/s fills it as well).
void BM_EstimatorFrameXr(benchmark::State& state) {
  EstimatorConfig config;
  config.prediction_window = 128.0 / 60.0;
  GlovePoseEstimator estimator = calibrated_estimator(storage_of(state), config);
  const int rows = static_cast<int>(recording().data.row_count);
  SessionClock clock{recording()};
  XrHandJoints joints;
  for (auto _ : state) {
    if (estimator.push_measurements(clock.rows(), rows, clock.timestamp()) != Status::Solved ||
        estimator.joints_at(estimator.pose().timestamp + 0.011, joints) != Status::Ok) {
      state.SkipWithError("no pose or no joints");
      break;
    }
    benchmark::DoNotOptimize(joints);
    clock.next();
  }
  state.counters["frames/s"] = benchmark::Counter(static_cast<double>(state.iterations()), benchmark::Counter::kIsRate);
  state.SetLabel(nn::storage_name(storage_of(state)));
}

void BM_EstimatorRow(benchmark::State& state) {
  GlovePoseEstimator estimator = calibrated_estimator(storage_of(state));
  const std::size_t rows = recording().data.row_count;
  const io::RowClock row_clock = recording().data.row_clock();
  SessionClock clock{recording()};
  std::size_t row = 0;
  const std::uint64_t poses_before = estimator.pose().sequence;
  for (auto _ : state) {
    const double t = row_clock.time(clock.timestamp(), row);
    benchmark::DoNotOptimize(estimator.push_row(static_cast<int>(row), clock.rows()[row], t));
    if (++row == rows) {
      row = 0;
      clock.next();
    }
  }
  const auto poses = static_cast<double>(estimator.pose().sequence - poses_before);
  state.SetItemsProcessed(state.iterations());
  state.counters["frames/s"] = benchmark::Counter(poses, benchmark::Counter::kIsRate);
  state.SetLabel(nn::storage_name(storage_of(state)));
}

}  // namespace

BENCHMARK(BM_EstimatorFrame)->Arg(0)->Arg(1)->Arg(2)->Arg(3)->UseRealTime();
BENCHMARK(BM_EstimatorFrameContact)->Arg(0)->Arg(1)->UseRealTime();
BENCHMARK(BM_EstimatorFrameXr)->Arg(3)->UseRealTime();
BENCHMARK(BM_EstimatorRow)->Arg(0)->Arg(1)->Arg(2)->Arg(3)->UseRealTime();
