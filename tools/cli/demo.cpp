// glovepose demo: the product's main job, end to end: a simulated new user (subject 0 of simulation seed S,
//   default 2026; the shipped model was trained on seed 101 and its calibration fitted on seed 21)
//   puts the glove on, performs the simulator's calibration sequence, then a session of poses.
//   Every reading is streamed row by row through GlovePoseEstimator (default settings: a solve
//   every 16 rows, joint transforms on), and the latest pose at each readout-cycle end is
//   compared with the true angles. Prints a table (angle errors, speed, latency, calibration) and
//   writes it and three SVG pictures to DIR: angles over time (paper Fig. 15), the cumulative
//   error curve (Fig. 14) and predicted beside true skeletons (Fig. 11).
#include <glovepose/calibration/pose_offset.hpp>
#include <glovepose/core/statistics.hpp>
#include <glovepose/estimator.hpp>
#include <glovepose/hand/joint_list.hpp>
#include <glovepose/hand/kinematics.hpp>
#include <glovepose/io/atomic_file.hpp>
#include <glovepose/model/pose_network.hpp>
#include <glovepose/pose_model_options.hpp>
#include <glovepose/sensor/calibration.hpp>
#include <glovepose/sim/corpus_dataset.hpp>
#include <glovepose/train/metrics.hpp>

#include <algorithm>
#include <array>
#include <limits>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>
#include <string>
#include <vector>

#include "commands.hpp"
#include "new_user.hpp"
#include "session_options.hpp"
#include "svg.hpp"

namespace glovepose::cli {
namespace {

namespace fs = std::filesystem;

// The DoFs of the angles-over-time picture: the index finger's three flexions (paper Fig. 15) and
// the thumb's base flexion.
constexpr const char* kPlottedDofs[] = {"index_base_flexion", "index_middle_flexion", "index_tip_flexion", "thumb_base_flexion"};
constexpr double kPlottedSeconds = 20.0;  // of the session, in the angles-over-time picture
constexpr int kSkeletonFrames = 4;        // frames of the skeleton picture, evenly spaced in the session
// How long before a cycle end the newest reading is when the pose at that cycle end is asked for
// (GlovePoseEstimator::pose_at): an engine rendering ahead of the glove.
constexpr double kHorizons[] = {0.0, 0.010, 0.020, 0.040};
constexpr std::size_t kHorizonCount = std::size(kHorizons);

struct DemoOptions {
  SessionOptions session;  // --model, --weights, --seed
  std::string out = "demo-out";
  double minutes = 1.5;
};

// What streaming the session produced.
struct SessionRun {
  std::vector<std::size_t> compared_frames;      // dataset frames compared with the truth (collision outliers left out)
  std::vector<hand::Angles> predicted;           // latest pose at each compared frame's cycle end
  std::vector<double> compute_seconds;           // Pose::compute_seconds of every pose
  std::vector<double> oldest_age;                // Pose::oldest_age of every pose
  std::vector<std::size_t> skeleton_frames;      // dataset frames of the skeleton picture
  std::vector<hand::JointList> skeleton_joints;  // the estimator's joint list at those frames
  std::vector<hand::Angles> skeleton_angles;     // and its angles
  // Per horizon, per session frame: the newest pose and pose_at(cycle end) when the newest reading
  // was the horizon before the cycle end, and how far ahead of the newest pose that was.
  std::array<std::vector<hand::Angles>, kHorizonCount> held, ahead;
  std::array<std::vector<double>, kHorizonCount> ahead_of_pose;
  std::size_t rows = 0, rejected_rows = 0;
  double wall_seconds = 0.0;  // streaming the session, all rows
};

// Streams frame f's readings row by row, each at the end of its row slot (sim/recorder.hpp);
// calls before_row(time) before each reading and on_pose() after every reading that produced a
// pose. Returns the readings rejected.
template <typename OnPose, typename BeforeRow>
std::size_t stream_frame(GlovePoseEstimator& estimator, const NewUser& user, std::size_t f, OnPose on_pose, BeforeRow before_row) {
  const io::Dataset& d = user.data;
  const auto rows = static_cast<int>(d.row_count);
  std::size_t rejected = 0;
  for (int r = 0; r < rows; ++r) {
    const double time = row_time(user, f, static_cast<std::size_t>(r));
    before_row(time);
    const Status status = estimator.push_row(r, d.raw_rows[f * d.row_count + static_cast<std::size_t>(r)], time);
    if (status == Status::Solved)
      on_pose();
    else if (status != Status::Ok && status != Status::NotReady && status != Status::Uncalibrated)
      ++rejected;
  }
  return rejected;
}

struct CalibrationResult {
  long frames = 0;
  double seconds = 0.0;
  std::vector<std::string> flat_sensors;
  bool guided = false;  // pose-guided offsets applied
};

CalibrationResult calibrate(GlovePoseEstimator& estimator, const NewUser& user) {
  estimator.start_calibration();
  for (std::size_t f = 0; f < user.first_session_frame; ++f)
    stream_frame(
        estimator, user, f, [] {}, [](double) {});
  CalibrationResult result;
  result.frames = estimator.calibration_progress().frames;
  result.seconds = static_cast<double>(user.first_session_frame) / user.cycle_rate;
  result.flat_sensors = estimator.finish_calibration().flat_sensors();
  result.guided = estimator.calibration_method() == CalibrationMethod::PoseGuided;
  return result;
}

// Evenly spaced session frames whose true pose is no collision outlier.
std::vector<std::size_t> pick_skeleton_frames(const NewUser& user) {
  const io::Dataset& d = user.data;
  const std::size_t begin = user.first_session_frame, count = d.frames() - begin;
  std::vector<std::size_t> picked;
  for (int k = 0; k < kSkeletonFrames; ++k) {
    std::size_t f = begin + static_cast<std::size_t>((k + 0.5) / kSkeletonFrames * static_cast<double>(count));
    while (f < d.frames() && d.outlier[f]) ++f;
    if (f < d.frames() && (picked.empty() || picked.back() != f)) picked.push_back(f);
  }
  return picked;
}

SessionRun stream_session(GlovePoseEstimator& estimator, const NewUser& user) {
  const io::Dataset& d = user.data;
  SessionRun run;
  run.skeleton_frames = pick_skeleton_frames(user);
  const std::size_t frames = d.frames() - user.first_session_frame;
  run.compute_seconds.reserve(frames * 12);
  run.oldest_age.reserve(frames * 12);
  run.predicted.reserve(frames);
  // Per horizon h, the next session frame whose pose_at(cycle end) is asked for once the stream
  // reaches its cycle end less h (before the first later reading is pushed).
  std::array<std::size_t, kHorizonCount> next_query;
  next_query.fill(user.first_session_frame);
  const auto query = [&](double now) {
    for (std::size_t h = 0; h < kHorizonCount; ++h)
      while (next_query[h] < d.frames() && d.timestamps[next_query[h]] - kHorizons[h] < now) {
        const double t = d.timestamps[next_query[h]++];
        PredictedPose pose;
        if (estimator.pose_at(t, pose) != Status::Ok) pose.angles = estimator.pose().angles;  // no pose yet: counted as held
        run.held[h].push_back(estimator.pose().angles);
        run.ahead[h].push_back(pose.angles);
        run.ahead_of_pose[h].push_back(t - estimator.pose().timestamp);
      }
  };
  const auto start = std::chrono::steady_clock::now();
  for (std::size_t f = user.first_session_frame; f < d.frames(); ++f) {
    run.rejected_rows += stream_frame(
        estimator, user, f,
        [&] {
          run.compute_seconds.push_back(estimator.pose().compute_seconds);
          run.oldest_age.push_back(estimator.pose().oldest_age);
        },
        query);
    run.rows += d.row_count;
    if (!estimator.pose().valid) continue;
    if (std::find(run.skeleton_frames.begin(), run.skeleton_frames.end(), f) != run.skeleton_frames.end()) {
      run.skeleton_joints.push_back(estimator.joints());
      run.skeleton_angles.push_back(estimator.pose().angles);
    }
    if (d.outlier[f]) continue;  // the true pose collides with itself: no reference (as in the paper)
    run.compared_frames.push_back(f);
    run.predicted.push_back(estimator.pose().angles);
  }
  run.wall_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  query(std::numeric_limits<double>::infinity());  // the last cycle ends
  if (run.predicted.empty() || run.skeleton_joints.size() != run.skeleton_frames.size())
    throw Error("the session gave " + std::to_string(run.predicted.size()) + " poses to compare, expected one per readout cycle");
  return run;
}

const double* true_angles(const io::Dataset& d, std::size_t f, hand::Angles& out) {
  const std::vector<float>& truth = d.has_true_angles() ? d.true_angles : d.angles;
  for (std::size_t k = 0; k < hand::kDofCount; ++k) out[k] = truth[f * hand::kDofCount + k];
  return out.data();
}

// Mean angle error (degrees) of per-session-frame angles against the truth, collision outliers left out.
double mean_error(const NewUser& user, const std::vector<hand::Angles>& per_frame) {
  train::AngleErrorAccumulator errors;
  hand::Angles truth{};
  for (std::size_t i = 0; i < per_frame.size(); ++i) {
    const std::size_t f = user.first_session_frame + i;
    if (!user.data.outlier[f]) errors.add(per_frame[i].data(), true_angles(user.data, f, truth));
  }
  return errors.report().overall.mean_deg;
}

train::AngleErrorReport measure_errors(const NewUser& user, const SessionRun& run) {
  train::AngleErrorAccumulator errors;
  hand::Angles truth{};
  for (std::size_t i = 0; i < run.predicted.size(); ++i)
    errors.add(run.predicted[i].data(), true_angles(user.data, run.compared_frames[i], truth));
  return errors.report();
}

std::string format_table(const DemoOptions& o, const std::string& model_path, const NewUser& user, const CalibrationResult& calibration,
                         const SessionRun& run, const train::AngleErrorReport& report) {
  std::string out;
  char line[512];
  const auto add = [&](const char* format, auto... args) {
    if constexpr (sizeof...(args) == 0) {
      out += format;  // plain text: no printf with a non-literal format and no arguments (clang's -Wformat-security)
    } else {
      std::snprintf(line, sizeof line, format, args...);
      out += line;
    }
  };
  const double session_seconds = static_cast<double>(user.data.frames() - user.first_session_frame) / user.cycle_rate;
  const std::size_t poses = run.compute_seconds.size();
  double compute = 0.0;
  for (double s : run.compute_seconds) compute += s;
  std::string flat;
  for (const std::string& name : calibration.flat_sensors) flat += (flat.empty() ? "" : ", ") + name;

  add("glovepose demo: a new user (simulation seed %llu, subject 0), model %s (%s on disk, %s in memory)\n",
      static_cast<unsigned long long>(o.session.seed), model_path.c_str(), stored_dtypes(model_path).c_str(),
      nn::storage_name(o.session.storage));
  add("calibration  %.1f s sequence streamed row by row: %ld frames taken, flat sensors: %s; %s\n", calibration.seconds, calibration.frames,
      flat.empty() ? "none" : flat.c_str(), calibration.guided ? "pose-guided" : "min-max");
  add("session      %.1f s: %zu rows streamed (%zu rejected), %zu poses (a solve every 16 rows),\n", session_seconds, run.rows,
      run.rejected_rows, poses);
  add("             %zu cycle ends compared with the truth (%zu with a self-colliding true pose left out, as the paper does)\n\n",
      report.frames, user.data.frames() - user.first_session_frame - report.frames);
  add("%-22s %8s %8s %8s\n", "angle error (degrees)", "mean", "rms", "max");
  for (const train::FingerError& f : report.fingers)
    add("  %-20s %8.2f %8.2f %8.2f\n", f.name, f.error.mean_deg, f.error.rms_deg, f.error.max_deg);
  add("  %-20s %8.2f %8.2f %8.2f\n", "all 25 angles", report.overall.mean_deg, report.overall.rms_deg, report.overall.max_deg);
  add("  median %.2f, p95 %.2f; angles under 15 degrees: %.1f%%\n\n", report.median_deg, report.p95_deg, 100.0 * report.share_under_15deg);
  add("speed and latency\n");
  add("  poses per second of compute   %10.0f  (poses / sum of Pose::compute_seconds)\n", static_cast<double>(poses) / compute);
  add("  the stream's pose rate        %10.0f  per second of glove time\n", static_cast<double>(poses) / session_seconds);
  add("  compute per pose              p50 %7.1f us   p99 %7.1f us\n", 1e6 * core::percentile(run.compute_seconds, 0.5),
      1e6 * core::percentile(run.compute_seconds, 0.99));
  add("  age of the oldest row         p50 %7.1f ms   p99 %7.1f ms\n", 1e3 * core::percentile(run.oldest_age, 0.5),
      1e3 * core::percentile(run.oldest_age, 0.99));
  add("  whole stream                  %.1f s of glove time in %.2f s wall (%.1fx real time)\n", session_seconds, run.wall_seconds,
      session_seconds / run.wall_seconds);
  add("\npose at a requested time: the pose at each cycle end asked for when the newest reading is the horizon before it\n");
  add("  %-12s %22s %26s %18s\n", "horizon (ms)", "newest pose held (deg)", "pose_at, extrapolated (deg)", "ahead of pose (ms)");
  for (std::size_t h = 0; h < kHorizonCount; ++h)
    add("  %-12.0f %22.2f %26.2f %18.1f\n", 1e3 * kHorizons[h], mean_error(user, run.held[h]), mean_error(user, run.ahead[h]),
        1e3 * core::percentile(run.ahead_of_pose[h], 0.5));
  return out;
}

// ---- pictures ------------------------------------------------------------------------------

// A range around [lo, hi] on multiples of `step`, at least two steps wide.
std::pair<double, double> padded_range(double lo, double hi, double step) {
  lo = std::floor(lo / step) * step;
  hi = std::ceil(hi / step) * step;
  if (hi - lo < 2 * step) hi = lo + 2 * step;
  return {lo, hi};
}

void draw_angles_over_time(const NewUser& user, const SessionRun& run, const std::string& path) {
  const double session_start = user.data.timestamps[user.first_session_frame];
  const std::size_t dofs = std::size(kPlottedDofs);
  const double panel_width = 820, panel_height = 130, left = 70, top = 50, gap = 40;
  svg::Document doc(left + panel_width + 30, top + dofs * (panel_height + gap) + 10);
  doc.text(left, 24, "Predicted vs true angles over the first seconds of the session (new user, streamed row by row)", 15);
  for (std::size_t p = 0; p < dofs; ++p) {
    const std::size_t dof = hand::dof_from_name(kPlottedDofs[p]);
    std::vector<double> times, predicted, truth;
    for (std::size_t i = 0; i < run.predicted.size(); ++i) {
      const std::size_t f = run.compared_frames[i];
      const double t = user.data.timestamps[f] - session_start;
      if (t > kPlottedSeconds) break;
      times.push_back(t);
      predicted.push_back(run.predicted[i][dof] * core::kDegreesPerRadian);
      hand::Angles true_pose{};
      truth.push_back(true_angles(user.data, f, true_pose)[dof] * core::kDegreesPerRadian);
    }
    const auto [lo, hi] =
        std::minmax({*std::min_element(predicted.begin(), predicted.end()), *std::min_element(truth.begin(), truth.end()),
                     *std::max_element(predicted.begin(), predicted.end()), *std::max_element(truth.begin(), truth.end())});
    const double step = hi - lo > 90 ? 30 : (hi - lo > 40 ? 20 : 10);
    const auto [y_min, y_max] = padded_range(lo, hi, step);
    svg::Axes axes(doc, left, top + p * (panel_height + gap), panel_width, panel_height, 0.0, std::max(times.back(), 1.0), y_min, y_max);
    axes.draw(times.back() > 10 ? 2.0 : 1.0, step, p + 1 == dofs ? "time in the session (s)" : "", "degrees", kPlottedDofs[p]);
    axes.plot(times, truth, "#1f5fbf", 1.6);
    axes.plot(times, predicted, "#d62728", 1.2);
    if (p == 0) {
      axes.legend(0, "#1f5fbf", "true");
      axes.legend(1, "#d62728", "predicted");
    }
  }
  doc.save(path);
}

void draw_cumulative_error(const train::AngleErrorReport& report, const std::string& path) {
  svg::Document doc(640, 430);
  svg::Axes axes(doc, 70, 50, 540, 320, 0, train::kCurveMaxDeg, 0, 100);
  axes.draw(5, 10, "error threshold (degrees)", "% of angles below", "Cumulative angle error (paper Fig. 14), all 25 angles");
  std::vector<double> thresholds, shares;
  for (const train::CurvePoint& point : report.curve) {
    thresholds.push_back(point.threshold_deg);
    shares.push_back(100.0 * point.share);
  }
  axes.plot(thresholds, shares, "#d62728", 2.0);
  axes.plot({15.0, 15.0}, {0.0, 100.0}, "#808080", 1.0, "4 3");
  // This run's share at 15 degrees, and the paper's for its real glove over its key poses, for scale.
  const double share = 100.0 * report.share_under_15deg;
  char label[80];
  std::snprintf(label, sizeof label, "this demo: %.1f%% of angles under 15 deg", share);
  doc.circle(axes.px(15), axes.py(share), 4, "#d62728");
  doc.circle(axes.px(15), axes.py(92), 4, "#404040");
  doc.circle(axes.px(20), axes.py(40), 4, "#d62728");
  doc.text(axes.px(20) + 10, axes.py(40) + 4, label, 12, "start", "#d62728");
  doc.circle(axes.px(20), axes.py(32), 4, "#404040");
  doc.text(axes.px(20) + 10, axes.py(32) + 4, "paper, real glove, key poses: 92% under 15 deg", 12, "start", "#404040");
  doc.save(path);
}

// The fixed view of the skeleton picture: fingers up, seen from the back of the hand turned by
// 50 degrees towards the thumb, so flexion (towards the palm, -Z) and abduction (X) both show.
svg::Point project(const hand::JointTransform& joint) {
  constexpr double kYaw = 50.0 * core::kRadiansPerDegree;
  const double x = joint.position[0], y = joint.position[1], z = joint.position[2];
  return {x * std::cos(kYaw) - z * std::sin(kYaw), y};
}

void draw_skeletons(const NewUser& user, const SessionRun& run, const hand::HandModel& hand_model, const std::string& path) {
  // True joint lists from the same kinematics the estimator uses.
  const hand::Kinematics kinematics(hand_model);
  const std::vector<hand::JointList> truths = [&] {
    std::vector<hand::JointList> lists;
    for (std::size_t f : run.skeleton_frames) {
      hand::Angles truth{};
      true_angles(user.data, f, truth);
      hand::Skeleton skeleton;
      kinematics.pose(truth, skeleton);
      hand::to_joint_list(kinematics, skeleton, lists.emplace_back());
    }
    return lists;
  }();
  // One scale for every hand: the bounding box of all projected joints.
  double x_lo = 1e9, x_hi = -1e9, y_lo = 1e9, y_hi = -1e9;
  for (const auto* lists : {&truths, &run.skeleton_joints})
    for (const hand::JointList& joints : *lists)
      for (const hand::JointTransform& joint : joints) {
        const svg::Point p = project(joint);
        x_lo = std::min(x_lo, p.first), x_hi = std::max(x_hi, p.first), y_lo = std::min(y_lo, p.second), y_hi = std::max(y_hi, p.second);
      }
  const double cell = 170, margin = 12, top = 70;
  const double scale = (cell - 2 * margin) / std::max(x_hi - x_lo, y_hi - y_lo);
  svg::Document doc(2 * cell * run.skeleton_frames.size() + 20, top + cell + 40);
  doc.text(10, 22, "True (blue) and predicted (red) hands, evenly spaced frames of the session (paper Fig. 11)", 15);
  const double session_start = user.data.timestamps[user.first_session_frame];
  for (std::size_t k = 0; k < run.skeleton_frames.size(); ++k) {
    const std::size_t f = run.skeleton_frames[k];
    double error = 0.0;
    hand::Angles truth{};
    true_angles(user.data, f, truth);
    for (std::size_t d = 0; d < hand::kDofCount; ++d)
      error += std::abs(run.skeleton_angles[k][d] - truth[d]) * core::kDegreesPerRadian / hand::kDofCount;
    char caption[96];
    std::snprintf(caption, sizeof caption, "t = %.1f s, mean error %.1f deg", user.data.timestamps[f] - session_start, error);
    const double x0 = 10 + 2 * cell * static_cast<double>(k);
    doc.text(x0 + cell, top - 22, caption, 12, "middle");
    doc.rect(x0, top - 12, 2 * cell, cell + 30, "none", "#d0d0d0");
    const auto draw_hand = [&](const hand::JointList& joints, double left, const std::string& colour, const std::string& label) {
      const auto pixel = [&](std::size_t j) {
        const svg::Point p = project(joints[j]);
        return svg::Point{left + margin + (p.first - x_lo) * scale, top + cell - margin - (p.second - y_lo) * scale};
      };
      for (std::size_t j = 1; j < hand::kJointCount; ++j) {
        const svg::Point a = pixel(j), b = pixel(static_cast<std::size_t>(hand::kJointParent[j]));
        doc.line(a.first, a.second, b.first, b.second, colour, 3.0);
      }
      std::vector<svg::Point> knuckles;  // the palm's far edge, index to pinky
      for (hand::Joint j : {hand::Joint::IndexProximal, hand::Joint::MiddleProximal, hand::Joint::RingProximal, hand::Joint::PinkyProximal})
        knuckles.push_back(pixel(static_cast<std::size_t>(j)));
      doc.polyline(knuckles, colour, 2.0);
      for (std::size_t j = 0; j < hand::kJointCount; ++j) doc.circle(pixel(j).first, pixel(j).second, 2.5, "#202020");
      doc.text(left + cell / 2, top + cell + 12, label, 12, "middle", colour);
    };
    draw_hand(truths[k], x0, "#1f5fbf", "true");
    draw_hand(run.skeleton_joints[k], x0 + cell, "#d62728", "predicted");
  }
  doc.save(path);
}

int demo(const DemoOptions& o) {
  const std::string model_path = o.session.model_path();
  const auto model = o.session.load_model();
  std::error_code error;
  fs::create_directories(o.out, error);
  if (error || !fs::is_directory(o.out))
    throw Error("cannot create the output folder '" + o.out + "' (" + error.message() + "), expected a writable path");

  const NewUser user = simulate_new_user(o.session.seed, o.minutes, *model);
  EstimatorConfig config;  // the default readout: a solve every 16 rows of their latest readings
  config.joint_transforms = true;
  GlovePoseEstimator estimator(model, config);
  const CalibrationResult calibration = calibrate(estimator, user);
  const SessionRun run = stream_session(estimator, user);
  const train::AngleErrorReport report = measure_errors(user, run);

  const std::string table = format_table(o, model_path, user, calibration, run, report);
  const fs::path out(o.out);
  const std::string files[] = {(out / "summary.txt").string(), (out / "angles_over_time.svg").string(),
                               (out / "cumulative_error.svg").string(), (out / "skeletons.svg").string()};
  io::write_file_whole(files[0], "summary", [&](std::ostream& summary) { summary << table; });
  draw_angles_over_time(user, run, files[1]);
  draw_cumulative_error(report, files[2]);
  draw_skeletons(user, run, hand::HandModel::chosen_or_reference(estimator.config().hand), files[3]);
  std::cout << table << "\nwrote";
  for (const std::string& file : files) std::cout << " " << file;
  std::cout << "\n";
  return 0;
}

}  // namespace

Command add_demo(CLI::App& tool) {
  auto o = std::make_shared<DemoOptions>();
  CLI::App* command = tool.add_subcommand(
      "demo",
      "The product's main job, end to end: a simulated new user puts the glove on, performs the calibration sequence, then a "
      "session of poses, streamed row by row through the estimator; prints a table (angle errors, speed, latency, calibration) "
      "and writes it and three SVG pictures (angles over time, cumulative error, skeletons) to --out.");
  o->session.add_to(*command, "simulation seed of the new user (default 2026; the shipped model saw seeds 101 and 21)");
  command->add_option("--out", o->out, "where the table and pictures go (default: demo-out)")->type_name("DIR");
  add_number(*command, "--minutes", "M", o->minutes, "length of the session after the 30 s calibration (default 1.5)")
      ->check(above(0.0, 600.0));
  return {command, [o] { return demo(*o); }};
}

}  // namespace glovepose::cli
