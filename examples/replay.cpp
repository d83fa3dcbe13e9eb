// Replays a recorded session through the estimator, row by row, as the glove delivered it: at the
// recorded pace (or as fast as possible with --fast), calibrating on the fly on each session's
// calibration frames (kind 1). Prints the error per finger against the recorded ground truth and
// writes the poses as CSV when asked.
//
// Usage: replay MODEL.safetensors SESSION.safetensors [--fast] [--csv POSES.csv]
//
// SESSION is a dataset file with raw rows (weights_format.md, "Dataset files"), for example
//   glovepose simulate --subjects 1 --sessions 1 --gloves 1 --minutes 1 --raw-rows --out session.safetensors
#include <glovepose/glovepose.hpp>
#include <glovepose/grid/glove_description.hpp>
#include <glovepose/sensor/calibration.hpp>
#include <glovepose/io/dataset.hpp>
#include <glovepose/train/metrics.hpp>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <memory>
#include <string>
#include <thread>

using namespace glovepose;
using Clock = std::chrono::steady_clock;

namespace {

Clock::duration seconds(double s) { return std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(s)); }

struct Options {
  std::string model, session, csv;
  bool fast = false;
};

Options parse(int argc, char** argv) {
  const std::string usage = "usage: replay MODEL.safetensors SESSION.safetensors [--fast] [--csv POSES.csv]";
  Options o;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--fast")
      o.fast = true;
    else if (a == "--csv" && i + 1 < argc)
      o.csv = argv[++i];
    else if (a.rfind("--", 0) != 0 && o.model.empty())
      o.model = a;
    else if (a.rfind("--", 0) != 0 && o.session.empty())
      o.session = a;
    else
      throw Error("argument '" + a + "' not understood; " + usage);
  }
  if (o.session.empty()) throw Error("expected a model and a session file; " + usage);
  return o;
}

// Frames of one session share subject, glove and session id; a new one restarts the clock.
bool same_session(const io::Dataset& d, std::size_t a, std::size_t b) {
  return d.subject[a] == d.subject[b] && d.glove[a] == d.glove[b] && d.session[a] == d.session[b];
}

// One line per recorded frame: its time and the pose the estimator had at its end.
struct CsvWriter {
  std::unique_ptr<std::FILE, int (*)(std::FILE*)> file{nullptr, &std::fclose};

  explicit CsvWriter(const std::string& path) {
    if (path.empty()) return;
    file.reset(std::fopen(path.c_str(), "w"));
    if (!file) throw Error("cannot write '" + path + "', expected a writable path for --csv");
    std::fprintf(file.get(), "frame,timestamp");
    for (const hand::Dof& dof : hand::kDofs) std::fprintf(file.get(), ",%s", dof.name);
    std::fprintf(file.get(), "\n");
  }
  void write(std::size_t frame, const Pose& pose) {
    if (!file) return;
    std::fprintf(file.get(), "%zu,%.6f", frame, pose.timestamp);
    for (double angle : pose.angles) std::fprintf(file.get(), ",%.6f", angle);
    std::fprintf(file.get(), "\n");
  }
};

}  // namespace

int main(int argc, char** argv) {
  try {
    const Options options = parse(argc, argv);
    const io::Dataset data = io::Dataset::read(options.session);
    const auto model = PoseModel::load(options.model);
    if (!data.has_raw_rows() || !data.has_angles())
      throw Error("'" + options.session + "' holds no raw rows or no angles, expected a recording made with glovepose simulate --raw-rows");
    if (data.glove_layout() != model->glove().id())
      throw Error("'" + options.session + "' was recorded with glove '" + data.glove_layout() + "', the model reads '" +
                  model->glove().id() + "'");
    GlovePoseEstimator estimator(model);
    CsvWriter csv(options.csv);
    train::AngleErrorAccumulator errors;
    std::size_t outliers = 0;
    double slowest_pose = 0.0;

    const std::size_t rows = data.row_count;
    const io::RowClock clock = data.row_clock();  // when each raw row was read
    Clock::time_point session_start;              // when, on this computer's clock, the session's time 0 is replayed
    for (std::size_t f = 0; f < data.frames(); ++f) {
      if (f == 0 || !same_session(data, f - 1, f)) {  // a new session: its clock and stream start again
        estimator.reset();
        session_start = Clock::now() - seconds(data.timestamps[f] - 1.0 / clock.frame_rate);
      }
      const bool calibrating = estimator.calibration_progress().collecting;
      if (data.kind[f] == io::kKindCalibration && !calibrating) estimator.start_calibration();
      if (data.kind[f] == io::kKindRecording && calibrating) estimator.finish_calibration();
      if (data.kind[f] == io::kKindRecording && !estimator.calibration())
        throw Error("frame " + std::to_string(f) +
                    " is recorded before any calibration frame, expected the session's calibration sequence (kind 1) first");

      // The frame's rows, each at its own time.
      const std::uint64_t poses_before = estimator.pose().sequence;
      for (std::size_t r = 0; r < rows; ++r) {
        const double t = clock.time(data.timestamps[f], r);
        if (!options.fast) std::this_thread::sleep_until(session_start + seconds(t));
        if (estimator.push_row(static_cast<int>(r), data.raw_rows[f * rows + r], t) == Status::Solved)
          slowest_pose = std::max(slowest_pose, estimator.pose().compute_seconds);
      }

      // Score the newest pose at the frame's end against the frame's ground truth, as the paper does:
      // recording frames only, without the frames whose reference pose is a collision outlier.
      const Pose& pose = estimator.pose();
      if (data.kind[f] != io::kKindRecording || pose.sequence == poses_before) continue;
      csv.write(f, pose);
      if (data.outlier[f]) {
        ++outliers;
        continue;
      }
      hand::Angles truth{};
      std::copy_n(data.angles.begin() + static_cast<std::ptrdiff_t>(f * hand::kDofCount), hand::kDofCount, truth.begin());
      errors.add(pose.angles, truth);
    }
    if (errors.empty())
      throw Error("'" + options.session + "' gave no recording frame to score, expected calibration frames then recording frames");

    const train::AngleErrorReport report = errors.report();
    std::printf("%zu frames scored (%zu outlier frames left out), %llu poses, slowest pose %.0f us\n", report.frames, outliers,
                static_cast<unsigned long long>(estimator.pose().sequence), 1e6 * slowest_pose);
    std::printf("%-8s %8s %8s %8s   (degrees)\n", "finger", "mean", "rms", "max");
    for (const train::FingerError& finger : report.fingers)
      std::printf("%-8s %8.2f %8.2f %8.2f\n", finger.name, finger.error.mean_deg, finger.error.rms_deg, finger.error.max_deg);
    std::printf("%-8s %8.2f %8.2f %8.2f   %.1f%% of angles within 15 deg\n", "all", report.overall.mean_deg, report.overall.rms_deg,
                report.overall.max_deg, 100.0 * report.share_under_15deg);
    return 0;
  } catch (const Error& e) {
    std::fprintf(stderr, "replay: %s\n", e.what());
    return 2;
  }
}
