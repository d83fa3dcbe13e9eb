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
// - BM_EstimatorFrameFloating/<0|1>: BM_EstimatorFrame/3 with the floating-cell stand-in
//   (sensor/floating_cells.hpp) off and on: its cost on an intact glove (the running statistics).
// - BM_EstimatorFrameContinuous/<0|1>: BM_EstimatorFrame/3 with the calibration fixed (as there) or
//   continuous (calibration/free_motion.hpp: the motion's histograms fed every frame, the range
//   re-derived every 0.25 s of stream time); needs a model with a range map (the shipped one).
// - BM_EstimatorFrameConfidence/<0|1>: BM_EstimatorFrame/3 on the shipped model without and with its
//   own errors (model/pose_error.hpp): the per-joint confidence's cost (25 erf, the rate's slope).
// - BM_EstimatorFrameXr/3: BM_EstimatorFrame/3 plus joints_at (OpenXR joints, predicted, with velocities).
// - BM_EstimatorRow/<storage>: one iteration = one push_row at the paper's cadence (a solve and a
//   pose every 16 rows, 11.25 per 180-row cycle): the mean cost of a row as the glove streams.
// - BM_CapiFrame/<library>/<storage>: an engine's frame through the C ABI, the library loaded at run
//   time: glovepose_estimator_push_measurements of the 180 rows and glovepose_estimator_get_pose,
//   the default estimator settings, on the shipped model. The libraries are named by
//   GLOVEPOSE_BENCH_CAPI="label=path,label=path" (bench/capi_frame.sh builds the shipped library and
//   its header-only peers and runs them side by side); each label names the instruction set its
//   networks run (glovepose_isa, where the library has it). Linux only (dlopen).
#include <glovepose/calibration/free_motion.hpp>
#include <glovepose/estimator.hpp>
#include <glovepose/model/model_file.hpp>
#include <glovepose/model/pose_network.hpp>
#include <glovepose/pose_model_options.hpp>
#include <glovepose/sim/corpus_dataset.hpp>

#include <benchmark/benchmark.h>
#include <glovepose_c.h>

#include <algorithm>
#include <cstdlib>
#include <map>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#if defined(__linux__)
#  include <dlfcn.h>
#endif

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

// The shipped model with Fixed16 weights and without its own errors: a pose's confidence is then
// its trust flag alone.
std::shared_ptr<const PoseModel> model_without_errors() {
  static std::shared_ptr<const PoseModel> model;
  if (!model) {
    const char* path = std::getenv("GLOVEPOSE_BENCH_MODEL");
    model = model::load_model_file(path && *path ? path : std::string(GLOVEPOSE_SOURCE_DIR) + "/models/glovepose_fcn512.safetensors",
                                   [](model::ModelFile&& file) {
                                     file.info.pose_error.reset();
                                     PoseModelOptions options;
                                     options.storage = nn::WeightStorage::Fixed16;
                                     PoseModel::Network network = PoseModel::Network::from_tensors(file.info, file.tensors, options.storage);
                                     return std::make_shared<const PoseModel>(std::move(file.info), std::move(network), options);
                                   });
  }
  return model;
}

// An estimator with smoothing and joint transforms, calibrated on the calibration sequence's frames.
GlovePoseEstimator calibrated_estimator(nn::WeightStorage storage, EstimatorConfig config = {}, const Recording& r = recording(),
                                        std::shared_ptr<const PoseModel> model = nullptr) {
  config.smoothing = filter::OneEuroConfig{60.0, 1.0, 0.5, 1.0};
  config.joint_transforms = true;
  GlovePoseEstimator estimator(model ? std::move(model) : shipped_model(storage), config);
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

// The iterations of the whole-frame benchmarks: one frame of `r`'s rows each, then `after()`.
template <typename After>
void push_frames(benchmark::State& state, GlovePoseEstimator& estimator, const Recording& r, After after) {
  const int rows = static_cast<int>(r.data.row_count);
  SessionClock clock{r};
  for (auto _ : state) {
    if (estimator.push_measurements(clock.rows(), rows, clock.timestamp()) != Status::Solved) {
      state.SkipWithError("push_measurements did not give a pose");
      break;
    }
    after();
    benchmark::DoNotOptimize(estimator.joints());
    clock.next();
  }
  state.counters["frames/s"] = benchmark::Counter(static_cast<double>(state.iterations()), benchmark::Counter::kIsRate);
}

void BM_EstimatorFrame(benchmark::State& state) {
  GlovePoseEstimator estimator = calibrated_estimator(storage_of(state));
  push_frames(state, estimator, recording(), [] {});
  state.SetLabel(nn::storage_name(storage_of(state)));
}

// BM_EstimatorFrame/3 on a recording where the person pinches often (pinch_recording), with the
// contact stage off (0) and on (1, EstimatorConfig::contact's defaults): the same frames, so the
// ratio of the two is the stage's cost where it has work. "adjusted": the share of poses it changed.
void BM_EstimatorFrameContact(benchmark::State& state) {
  EstimatorConfig config;
  if (state.range(0) != 0) config.contact = hand::ContactConfig{};
  GlovePoseEstimator estimator = calibrated_estimator(nn::WeightStorage::Fixed16, config, pinch_recording());
  std::size_t adjusted = 0;
  push_frames(state, estimator, pinch_recording(), [&] { adjusted += estimator.contact().closed >= 0; });
  state.counters["adjusted"] = static_cast<double>(adjusted) / static_cast<double>(std::max<benchmark::IterationCount>(state.iterations(), 1));
  state.SetLabel(state.range(0) != 0 ? "Fixed16, contact stage on" : "Fixed16, contact stage off");
}

// BM_EstimatorFrame/3 with EstimatorConfig::floating_cells off (0) and on (1, the default): the same
// frames of an intact glove, so the ratio is what the running statistics cost every frame.
void BM_EstimatorFrameFloating(benchmark::State& state) {
  EstimatorConfig config;
  config.floating_cells.enabled = state.range(0) != 0;
  GlovePoseEstimator estimator = calibrated_estimator(nn::WeightStorage::Fixed16, config);
  push_frames(state, estimator, recording(), [] {});
  state.SetLabel(state.range(0) != 0 ? "Fixed16, floating-cell stand-in on" : "Fixed16, floating-cell stand-in off");
}

void BM_EstimatorFrameContinuous(benchmark::State& state) {
  GlovePoseEstimator estimator = calibrated_estimator(nn::WeightStorage::Fixed16);
  if (state.range(0) != 0) {
    if (!estimator.model().range_map()) {
      state.SkipWithError("the model carries no range map");
      return;
    }
    estimator.use_continuous_calibration();
  }
  push_frames(state, estimator, recording(), [] {});
  state.SetLabel(state.range(0) != 0 ? "Fixed16, continuous calibration" : "Fixed16, fixed calibration");
}

void BM_EstimatorFrameConfidence(benchmark::State& state) {
  GlovePoseEstimator estimator =
      state.range(0) != 0 ? calibrated_estimator(nn::WeightStorage::Fixed16)
                          : calibrated_estimator(nn::WeightStorage::Fixed16, EstimatorConfig{}, recording(), model_without_errors());
  if (state.range(0) != 0 && !estimator.model().pose_error()) {
    state.SkipWithError("the model carries no errors of its own");
    return;
  }
  push_frames(state, estimator, recording(), [] {});
  state.SetLabel(state.range(0) != 0 ? "Fixed16, confidence from the model's errors" : "Fixed16, confidence from the trust flag");
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
  hand::XrHandJoints joints;
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

#if defined(__linux__)
// The C ABI functions an engine's frame uses, from one library loaded with dlopen (RTLD_LOCAL: two
// libraries with the same symbols side by side).
struct CapiLibrary {
  std::string label;
  void* handle = nullptr;
  decltype(&glovepose_model_load) model_load = nullptr;
  decltype(&glovepose_model_free) model_free = nullptr;
  decltype(&glovepose_estimator_config_default) config_default = nullptr;
  decltype(&glovepose_estimator_create) estimator_create = nullptr;
  decltype(&glovepose_estimator_free) estimator_free = nullptr;
  decltype(&glovepose_calibration_start) calibration_start = nullptr;
  decltype(&glovepose_calibration_finish) calibration_finish = nullptr;
  decltype(&glovepose_estimator_push_measurements) push_measurements = nullptr;
  decltype(&glovepose_estimator_get_pose) get_pose = nullptr;
  decltype(&glovepose_pose_init) pose_init = nullptr;
  decltype(&glovepose_last_error) last_error = nullptr;
  decltype(&glovepose_isa) isa = nullptr;  // null in a library without it

  static CapiLibrary open(const std::string& label, const std::string& path) {
    CapiLibrary lib;
    lib.label = label;
    lib.handle = dlopen(path.c_str(), RTLD_NOW | RTLD_LOCAL);
    if (!lib.handle) throw Error("GLOVEPOSE_BENCH_CAPI: cannot load '" + path + "': " + dlerror());
    auto need = [&](auto& function, const char* name) {
      function = reinterpret_cast<std::remove_reference_t<decltype(function)>>(dlsym(lib.handle, name));
      if (!function) throw Error("GLOVEPOSE_BENCH_CAPI: '" + path + "' has no " + name + ", expected the C ABI");
    };
    need(lib.model_load, "glovepose_model_load");
    need(lib.model_free, "glovepose_model_free");
    need(lib.config_default, "glovepose_estimator_config_default");
    need(lib.estimator_create, "glovepose_estimator_create");
    need(lib.estimator_free, "glovepose_estimator_free");
    need(lib.calibration_start, "glovepose_calibration_start");
    need(lib.calibration_finish, "glovepose_calibration_finish");
    need(lib.push_measurements, "glovepose_estimator_push_measurements");
    need(lib.get_pose, "glovepose_estimator_get_pose");
    need(lib.pose_init, "glovepose_pose_init");
    need(lib.last_error, "glovepose_last_error");
    lib.isa = reinterpret_cast<decltype(&glovepose_isa)>(dlsym(lib.handle, "glovepose_isa"));
    return lib;
  }
};

// The shipped model in `storage`, an estimator with the default settings calibrated on the
// recording's calibration sequence, and the session's frames pushed one per iteration.
void BM_CapiFrame(benchmark::State& state, const CapiLibrary& lib) {
  const std::string model_path = std::string(GLOVEPOSE_SOURCE_DIR) + "/models/glovepose_fcn512.safetensors";
  glovepose_model* model = nullptr;
  glovepose_estimator* estimator = nullptr;
  glovepose_estimator_config config;
  config.struct_size = sizeof config;
  if (lib.model_load(model_path.c_str(), static_cast<int32_t>(state.range(0)), nullptr, &model) != GLOVEPOSE_OK ||
      lib.config_default(&config) != GLOVEPOSE_OK || lib.estimator_create(model, &config, &estimator) != GLOVEPOSE_OK) {
    state.SkipWithError(lib.last_error());
    lib.model_free(model);
    return;
  }
  const Recording& r = recording();
  const io::Dataset& d = r.data;
  const int rows = static_cast<int>(d.row_count);
  (void)lib.calibration_start(estimator);
  std::vector<double> frame(d.row_count);
  for (std::size_t f = 0; f < r.first_session_frame; ++f) {
    std::copy_n(d.raw_rows.begin() + static_cast<std::ptrdiff_t>(f * d.row_count), d.row_count, frame.begin());
    (void)lib.push_measurements(estimator, frame.data(), rows, d.timestamps[f]);
  }
  if (lib.calibration_finish(estimator) != GLOVEPOSE_OK) state.SkipWithError(lib.last_error());
  glovepose_pose pose;
  lib.pose_init(&pose);
  SessionClock clock{r};
  for (auto _ : state) {
    const glovepose_result pushed = lib.push_measurements(estimator, clock.rows(), rows, clock.timestamp());
    const glovepose_result read = lib.get_pose(estimator, &pose);
    benchmark::DoNotOptimize(pose.angles[0]);
    if (pushed != GLOVEPOSE_SOLVED || read != GLOVEPOSE_OK) {
      state.SkipWithError("a frame gave no pose");
      break;
    }
    clock.next();
  }
  state.SetLabel(lib.label + (lib.isa ? std::string(" ") + lib.isa() : std::string()));
  state.counters["frames/s"] = benchmark::Counter(static_cast<double>(state.iterations()), benchmark::Counter::kIsRate);
  lib.estimator_free(estimator);
  lib.model_free(model);
}

// One BM_CapiFrame per library of GLOVEPOSE_BENCH_CAPI and storage, registered before main runs.
const int kCapiBenchmarks = [] {
  const char* libraries = std::getenv("GLOVEPOSE_BENCH_CAPI");
  if (libraries == nullptr || *libraries == '\0') return 0;
  static std::vector<CapiLibrary> loaded;
  loaded.reserve(8);
  std::stringstream list(libraries);
  for (std::string item; std::getline(list, item, ',');) {
    const auto equals = item.find('=');
    if (equals == std::string::npos) throw Error("GLOVEPOSE_BENCH_CAPI item '" + item + "', expected label=path");
    if (loaded.size() == loaded.capacity()) throw Error("GLOVEPOSE_BENCH_CAPI: more than 8 libraries");
    loaded.push_back(CapiLibrary::open(item.substr(0, equals), item.substr(equals + 1)));
  }
  for (std::size_t l = 0; l < loaded.size(); ++l)
    benchmark::RegisterBenchmark(("BM_CapiFrame/" + loaded[l].label).c_str(),
                                 [&lib = loaded[l]](benchmark::State& state) { BM_CapiFrame(state, lib); })
        ->Arg(0)->Arg(1)->Arg(2)->Arg(3)->UseRealTime();
  return static_cast<int>(loaded.size());
}();
#endif

}  // namespace

BENCHMARK(BM_EstimatorFrame)->Arg(0)->Arg(1)->Arg(2)->Arg(3)->UseRealTime();
BENCHMARK(BM_EstimatorFrameContact)->Arg(0)->Arg(1)->UseRealTime();
BENCHMARK(BM_EstimatorFrameFloating)->Arg(0)->Arg(1)->UseRealTime();
BENCHMARK(BM_EstimatorFrameContinuous)->Arg(0)->Arg(1)->UseRealTime();
BENCHMARK(BM_EstimatorFrameConfidence)->Arg(0)->Arg(1)->UseRealTime();
BENCHMARK(BM_EstimatorFrameXr)->Arg(3)->UseRealTime();
BENCHMARK(BM_EstimatorRow)->Arg(0)->Arg(1)->Arg(2)->Arg(3)->UseRealTime();
