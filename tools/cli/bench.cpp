// glovepose bench: the latency of one pose on this machine, stage by stage, for every weight storage of each
//   model (default: the two shipped ones), against the paper's 5 ms inference budget; the frames per
//   second of batched inference; the machine it ran on. Stages are timed one call at a time with
//   the steady clock over N poses of a simulated session (default 2000) and reported as p50 / p99 /
//   max; "whole frame" is GlovePoseEstimator::push_measurements of a 180-row frame (solve,
//   calibration, network, 1-euro, joint list), the per-stage rows are the same steps called on
//   their own, so their sum is close to, not exactly, the whole.
#include <glovepose/core/statistics.hpp>
#include <glovepose/estimator.hpp>
#include <glovepose/filter/one_euro.hpp>
#include <glovepose/hand/joint_list.hpp>
#include <glovepose/hand/xr_hand.hpp>
#include <glovepose/model/architecture.hpp>
#include <glovepose/model/pose_network.hpp>
#include <glovepose/pose_model_options.hpp>
#include <glovepose/sim/corpus_dataset.hpp>

#include <nlohmann/json.hpp>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "commands.hpp"
#include "session_options.hpp"

namespace glovepose::cli {
namespace {

using Clock = std::chrono::steady_clock;
using nlohmann::json;

constexpr double kBudgetMs = 5.0;  // the paper's inference budget per pose (Sec. 5)
constexpr long kBatchFrames = 2048;
constexpr nn::WeightStorage kStorages[] = {nn::WeightStorage::F32, nn::WeightStorage::F16, nn::WeightStorage::BF16,
                                           nn::WeightStorage::Fixed16};

struct BenchOptions {
  std::vector<std::string> models;  // empty: the shipped ones
  int poses = 2000;
  bool json = false;
};

// A simulated person's 3 s calibration sequence and a session, with every raw row.
struct Session {
  io::Dataset data;
  std::size_t first_session_frame = 0;
};

Session simulate_session() {
  sim::CorpusConfig config = sim::CorpusConfig::one_session(7, 15.0, 3.0);
  config.recording.raw_rows = true;
  Session s;
  s.data = sim::to_dataset(sim::simulate_corpus(config), config);
  s.first_session_frame = s.data.first_session_frame();
  return s;
}

struct Spread {
  double p50 = 0, p99 = 0, max = 0;  // microseconds
};

Spread spread_of(const std::vector<double>& us) {
  return {core::percentile(us, 0.5), core::percentile(us, 0.99), *std::max_element(us.begin(), us.end())};
}

// Per-stage call times of one model in one storage.
struct Result {
  std::string model, architecture, storage;
  std::vector<std::pair<std::string, Spread>> stages;
  Spread frame;
  double batch_one_thread = 0, batch_all_threads = 0;  // frames per second
};

template <typename F>
double time_us(F&& f) {
  const auto start = Clock::now();
  f();
  return std::chrono::duration<double, std::micro>(Clock::now() - start).count();
}

Result bench_model(const std::string& path, nn::WeightStorage storage, const Session& session, int poses) {
  PoseModelOptions options;
  options.storage = storage;
  const auto model = PoseModel::load(path, options);
  if (!model->solver()) throw Error("'" + path + "' is not a model of the built-in glove's wiring, expected one whose rows can be solved");
  EstimatorConfig config;
  config.smoothing = filter::OneEuroConfig{60.0, 1.0, 0.5, 1.0};
  config.joint_transforms = true;
  config.calibration_method = CalibrationMethod::MinMax;
  GlovePoseEstimator estimator(model, config);
  const io::Dataset& d = session.data;
  const auto rows = static_cast<int>(d.row_count);
  std::vector<double> frame(d.row_count);
  const auto load_frame = [&](std::size_t f) {
    for (std::size_t r = 0; r < d.row_count; ++r) frame[r] = d.raw_rows[f * d.row_count + r];
  };
  estimator.start_calibration();
  for (std::size_t f = 0; f < session.first_session_frame; ++f) {
    load_frame(f);
    (void)estimator.push_measurements(frame.data(), rows, d.timestamps[f]);
  }
  estimator.finish_calibration();

  // The stages on their own, with objects of their own.
  const auto& solver = *model->solver();
  const sensor::CalibrationRange& range = *estimator.calibration();
  auto workspace = model->network().make_workspace();
  // The U-Net's three steps apart: the glove's maps, the network alone, the pose map.
  const bool unet = model->network().architecture() == model::Architecture::UNet;
  std::vector<float> planes(static_cast<std::size_t>(model->network().input_values()));
  filter::OneEuroFilter<hand::kDofCount> smoothing(*config.smoothing);
  const hand::Kinematics kinematics;
  hand::Skeleton skeleton;
  hand::JointList joints{};
  hand::XrHandJoints xr;
  Eigen::VectorXd measurements(rows), cells(model->cell_count()), normalized(model->cell_count());
  hand::Angles unit{}, angles{}, smoothed{};
  std::array<float, grid::kMapSlots> pose_map{};
  std::vector<std::string> names = {"solve", "calibration"};
  if (unet)
    names.insert(names.end(), {"stretch maps", "network", "pose map"});
  else
    names.push_back("network");
  names.insert(names.end(), {"angles", "1-euro", "joint list", "OpenXR joints"});
  std::vector<std::vector<double>> times(names.size());
  std::vector<double> whole;
  const std::size_t session_frames = d.frames() - session.first_session_frame;
  double lap = 0.0;
  for (int i = 0; i < poses; ++i) {
    const std::size_t f = session.first_session_frame + static_cast<std::size_t>(i) % session_frames;
    if (i > 0 && f == session.first_session_frame) lap += d.timestamps.back() - d.timestamps[session.first_session_frame] + 1.0 / 60.0;
    const double t = d.timestamps[f] + lap;
    load_frame(f);
    Status status = Status::Ok;
    whole.push_back(time_us([&] { status = estimator.push_measurements(frame.data(), rows, t); }));
    if (status != Status::Solved) throw Error("frame " + std::to_string(f) + " gave no pose (" + to_string(status) + ")");
    std::size_t s = 0;
    times[s++].push_back(time_us([&] {
      measurements = Eigen::Map<const Eigen::VectorXd>(frame.data(), rows);
      (void)solver.solve(measurements, cells);
    }));
    times[s++].push_back(time_us([&] { (void)range.normalize(cells, normalized); }));
    if (unet) {
      times[s++].push_back(time_us([&] { (void)model->glove().map().to_input_planes(normalized.data(), planes.data()); }));
      times[s++].push_back(time_us([&] { (void)model->network().forward(planes.data(), pose_map.data(), workspace); }));
      times[s++].push_back(time_us([&] { model->glove().map().from_pose_map(pose_map, unit); }));
    } else {
      times[s++].push_back(
          time_us([&] { (void)model->network().normalized_dofs(model->glove().map(), normalized.data(), unit, workspace); }));
    }
    times[s++].push_back(time_us([&] { angles = model->joint_limits().denormalize(unit); }));
    times[s++].push_back(time_us([&] { (void)smoothing.filter(angles, t, smoothed); }));
    times[s++].push_back(time_us([&] {
      kinematics.pose(smoothed, skeleton);
      hand::to_joint_list(kinematics, skeleton, joints);
    }));
    times[s++].push_back(time_us([&] { (void)estimator.joints_at(t + 0.011, xr); }));
  }
  Result result;
  result.model = path;
  result.architecture = model->info().architecture_name();
  result.storage = nn::storage_name(storage);
  for (std::size_t s = 0; s < names.size(); ++s) result.stages.emplace_back(names[s], spread_of(times[s]));
  result.frame = spread_of(whole);

  // Batched inference of calibrated cells (evaluation, offline processing).
  std::vector<float> batch(static_cast<std::size_t>(kBatchFrames) * static_cast<std::size_t>(model->cell_count()));
  for (long f = 0; f < kBatchFrames; ++f) {
    const std::size_t source = session.first_session_frame + static_cast<std::size_t>(f) % session_frames;
    for (std::size_t c = 0; c < d.cell_count; ++c) cells(static_cast<Eigen::Index>(c)) = d.cells[source * d.cell_count + c];
    (void)range.normalize(cells, normalized);
    for (Eigen::Index c = 0; c < normalized.size(); ++c)
      batch[static_cast<std::size_t>(f * normalized.size() + c)] = static_cast<float>(normalized(c));
  }
  const auto frames_per_second = [&](int threads) {
    const double us = time_us([&] {
      (void)model->network().normalized_dofs_batch(model->glove().map(), batch.data(), model->cell_count(), kBatchFrames, threads);
    });
    return static_cast<double>(kBatchFrames) / (us * 1e-6);
  };
  (void)frames_per_second(1);  // warm-up
  result.batch_one_thread = frames_per_second(1);
  result.batch_all_threads = frames_per_second(static_cast<int>(std::max(1u, std::thread::hardware_concurrency())));
  return result;
}

std::string cpu_model() {
  std::ifstream in("/proc/cpuinfo");
  std::string line;
  while (std::getline(in, line))
    if (line.rfind("model name", 0) == 0) {
      const std::size_t colon = line.find(':');
      if (colon != std::string::npos) return line.substr(line.find_first_not_of(' ', colon + 1));
    }
  return "unknown";
}

json spread_json(const Spread& s) { return {{"p50_us", s.p50}, {"p99_us", s.p99}, {"max_us", s.max}}; }

void print_table(const std::vector<Result>& results, const BenchOptions& o, const json& machine) {
  std::printf("glovepose bench: %s, %s logical cores, SIMD %s; %d poses per line (one call at a time, steady clock)\n\n",
              machine["cpu"].get<std::string>().c_str(), std::to_string(machine["logical_cores"].get<unsigned>()).c_str(),
              machine["simd"].get<std::string>().c_str(), o.poses);
  for (const Result& r : results) {
    std::printf("%s (%s), %s weights\n", r.model.c_str(), r.architecture.c_str(), r.storage.c_str());
    std::printf("  %-16s %9s %9s %9s\n", "stage", "p50 us", "p99 us", "max us");
    for (const auto& [name, s] : r.stages) std::printf("  %-16s %9.1f %9.1f %9.1f\n", name.c_str(), s.p50, s.p99, s.max);
    std::printf("  %-16s %9.1f %9.1f %9.1f   p99 = %.1f%% of the paper's %.0f ms budget\n", "whole frame", r.frame.p50, r.frame.p99,
                r.frame.max, 100.0 * r.frame.p99 / (kBudgetMs * 1e3), kBudgetMs);
    std::printf("  batched inference: %.0f frames/s on 1 thread, %.0f on %u\n\n", r.batch_one_thread, r.batch_all_threads,
                machine["logical_cores"].get<unsigned>());
  }
}

int bench(BenchOptions o) {
  if (o.models.empty()) o.models = {shipped_model_path(kShippedModel), shipped_model_path(kShippedUNet)};
  const Session session = simulate_session();
  std::vector<Result> results;
  for (const std::string& path : o.models)
    for (nn::WeightStorage storage : kStorages) results.push_back(bench_model(path, storage, session, o.poses));
  const json machine = {{"cpu", cpu_model()},
                        {"logical_cores", std::max(1u, std::thread::hardware_concurrency())},
                        {"simd", nn::isa_word(model::process_isa())}};
  if (!o.json) {
    print_table(results, o, machine);
    return 0;
  }
  json out = {{"machine", machine}, {"poses", o.poses}, {"budget_ms", kBudgetMs}, {"results", json::array()}};
  for (const Result& r : results) {
    json stages = json::object();
    for (const auto& [name, s] : r.stages) stages[name] = spread_json(s);
    out["results"].push_back({{"model", r.model},
                              {"architecture", r.architecture},
                              {"weights", r.storage},
                              {"stages", stages},
                              {"frame", spread_json(r.frame)},
                              {"frame_p99_budget_share", r.frame.p99 / (kBudgetMs * 1e3)},
                              {"batch_frames_per_second", {{"threads_1", r.batch_one_thread}, {"threads_all", r.batch_all_threads}}}});
  }
  std::cout << out.dump(2) << "\n";
  return 0;
}

}  // namespace

Command add_bench(CLI::App& tool) {
  auto o = std::make_shared<BenchOptions>();
  CLI::App* command = tool.add_subcommand(
      "bench",
      "The latency of one pose on this machine, stage by stage (p50 / p99 / max), for every weight storage of each model, against "
      "the paper's 5 ms inference budget; the frames per second of batched inference; the machine it ran on.");
  add_model_file(*command, o->models, "a model to time (repeatable; default: the shipped FCN and U-Net)")->allow_extra_args(false);
  add_number(*command, "--poses", "N", o->poses, "poses timed per model and weight storage (default 2000, at least 10)")
      ->check(at_least(10));
  command->add_flag("--json", o->json, "print the results as JSON instead of a table");
  return {command, [o] { return bench(*o); }};
}

}  // namespace glovepose::cli
