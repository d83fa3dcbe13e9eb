// Whether Pose::confidence means something (docs/results.md, "Confidence"): new people streamed
// through the estimator as a user runs it, (a) after their guided calibration and (b) from their
// first frame with the continuous calibration; on data with a torn trace (simulate --tear) also the
// frames with cells stood in for and those without, apart. Every trusted
// joint-frame's |error| against the truth and its confidence are kept; printed: the mean error of
// the quarter of joint-frames with the lowest confidence over the quarter with the highest (all
// DoFs pooled, and the median of that ratio within each DoF), the mean confidence against the share
// actually within the tolerance (10 deg), per condition and pooled.
//
//   g++ -std=c++17 -O2 -march=native -Iinclude -Itools -isystem /usr/include/eigen3 tools/experiments/confidence.cpp -o confidence -lpthread
//   ./confidence models/glovepose_fcn512.safetensors test6061.safetensors    # about 10 s for 8 people x 2 min
//   ./confidence models/glovepose_fcn512.safetensors torn/t*.safetensors   # every file's joint-frames pooled
#include <glovepose/core/units.hpp>
#include <glovepose/estimator.hpp>
#include <glovepose/io/dataset.hpp>
#include <glovepose/pose_model.hpp>
#include <glovepose/train/confidence_metrics.hpp>

#include <cmath>
#include <cstdio>
#include <vector>

#include "cli/pose_error_fit.hpp"

using namespace glovepose;

namespace {

void report(const char* name, const train::ConfidenceAccumulator& joints) {
  const train::ConfidenceReport r = joints.report();
  std::printf("%-22s %9ld joint-frames  mean error %5.2f deg  low/high-confidence quarter error %5.2fx (within a DoF, median %4.2fx)  "
              "mean confidence %.3f, share within %.0f deg %.3f\n",
              name, r.joint_frames, r.mean_error_deg, r.quarter_error_ratio, r.within_dof_ratio, r.mean_confidence, r.tolerance_deg,
              r.share_within);
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 3) {
    std::fprintf(stderr, "usage: confidence MODEL DATA [DATA...]   (the joint-frames of every file pooled)\n");
    return 2;
  }
  const auto model = PoseModel::load(argv[1]);
  if (!model->pose_error()) {
    std::fprintf(stderr, "confidence: %s carries no measured errors (glovepose fit-guided writes them)\n", argv[1]);
    return 1;
  }
  EstimatorConfig config;
  config.continuous_calibration = false;
  const double tolerance = config.confidence_tolerance * core::kDegreesPerRadian;
  train::ConfidenceAccumulator guided(tolerance), continuous(tolerance), pooled(tolerance), masked(tolerance), intact(tolerance);
  std::size_t run_count = 0;
  for (int file = 2; file < argc; ++file) {
    const io::Dataset data = io::Dataset::read(argv[file]);
    if (!data.has_true_angles()) {
      std::fprintf(stderr, "confidence: %s has no true angles, expected simulated data\n", argv[file]);
      return 1;
    }
    const std::vector<cli::detail::RunFrames> runs = cli::detail::runs_of(data, train::FrameFilter{});
    run_count += runs.size();
    std::vector<double> row(data.cell_count);
    const auto stream = [&](GlovePoseEstimator& estimator, const std::vector<std::size_t>& frames, train::ConfidenceAccumulator* out) {
      for (std::size_t i : frames) {
        for (std::size_t c = 0; c < data.cell_count; ++c) row[c] = data.cells[i * data.cell_count + c];
        if (estimator.push_cells(row.data(), static_cast<int>(data.cell_count), data.timestamps[i]) != Status::Solved || out == nullptr) continue;
        const Pose& pose = estimator.pose();
        if (!pose.trusted()) continue;
        for (std::size_t d = 0; d < hand::kDofCount; ++d) {
          const double e = (pose.angles[d] - data.true_angles[i * hand::kDofCount + d]) * core::kDegreesPerRadian;
          out->add(d, e, pose.confidence[d]);
          pooled.add(d, e, pose.confidence[d]);
          ((pose.flags & kPoseMaskedCells) != 0 ? masked : intact).add(d, e, pose.confidence[d]);
        }
      }
    };
    for (const cli::detail::RunFrames& run : runs) {
      if (!run.calibration.empty()) {
        GlovePoseEstimator estimator(model, config);
        estimator.start_calibration();
        stream(estimator, run.calibration, nullptr);
        (void)estimator.finish_calibration();
        stream(estimator, run.recording, &guided);
      }
      GlovePoseEstimator estimator(model, config);
      estimator.use_continuous_calibration();
      stream(estimator, run.recording, &continuous);
    }
  }
  std::printf("%zu runs of %d data file(s), model %s, tolerance %.0f deg\n", run_count, argc - 2, argv[1], tolerance);
  report("guided calibration", guided);
  report("continuous, no step", continuous);
  report("both", pooled);
  if (!masked.empty()) {
    report("both, cells stood in", masked);
    report("both, every cell read", intact);
  }
  return 0;
}
