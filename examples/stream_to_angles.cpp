// From the glove's row stream to joint angles, stage by stage (until GlovePoseEstimator composes
// them): readout -> least squares -> on-the-fly calibration -> stretch maps -> U-Net -> angles ->
// 1-euro filter -> joint transforms.
//
// Usage: stream_to_angles MODEL.safetensors
// The glove is simulated crudely here: each cell's capacitance swings sinusoidally, and the 180
// compound measurements are taken one after another at 60 x 180 rows per second.
#include <glovepose/glovepose.hpp>
#include <glovepose/nn/model.hpp>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <memory>
#include <optional>
#include <random>

using namespace glovepose;

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: %s MODEL.safetensors\n", argv[0]);
    return 2;
  }
  try {
    // Set-up: everything that allocates or may throw.
    const auto layout = sensor::TraceLayout::glauser2019();
    const auto solver = std::make_shared<const sensor::GloveSolver>(layout);
    sensor::GloveReadout readout(solver);
    sensor::OnTheFlyCalibrator calibrator(layout.cell_names());
    const grid::GridMap map = grid::GridMap::glauser2019();
    const auto model = nn::Model<>::load(argv[1]);
    auto workspace = model.unet.make_workspace();
    hand::Angles lo{}, hi{};
    for (std::size_t d = 0; d < hand::kDofCount; ++d) {
      lo[d] = model.info.joint_limits_min[d];
      hi[d] = model.info.joint_limits_max[d];
    }
    const hand::JointLimits limits(lo, hi);
    filter::OneEuroFilter<hand::kDofCount> smoothing({60.0, 1.0, 0.1, 1.0});
    const hand::Kinematics kinematics;
    hand::Skeleton skeleton;

    // A crude glove: each cell swings between its own bounds at its own pace, plus readout noise.
    std::mt19937 rng(1);
    std::normal_distribution<double> noise(0.0, 0.02);
    const auto cell = [](int c, double t) { return 10.0 + 0.2 * c + 3.0 * (0.5 + 0.5 * std::sin(1.3 * t + 0.7 * c)); };
    const double row_period = 1.0 / (60.0 * 180.0);

    std::optional<sensor::CalibrationRange> range;
    int frames = 0;
    double worst_us = 0.0;
    for (long k = 0; k < 180L * 60 * 8; ++k) {  // 8 seconds of rows
      const double t = static_cast<double>(k) * row_period;
      const int row = static_cast<int>(k % 180);
      double measured = 0.0;
      for (int c = 0; c < layout.cell_count(); ++c) measured += solver->measurement_matrix()(row, c) * cell(c, t);
      if (readout.push_row(row, measured + noise(rng), t) != Status::Solved) continue;
      const auto& frame = readout.frame();
      if (t < 5.0) {  // the first 5 s: the user explores extreme poses while the calibrator watches
        (void)calibrator.add(frame.cells);
        continue;
      }
      if (!range) {
        range = calibrator.finish();
        std::printf("calibrated on %ld frames; flat sensors: %zu\n", calibrator.frames(), range->flat_sensors().size());
      }
      // The per-frame path: no allocation, statuses instead of exceptions.
      const auto start = std::chrono::steady_clock::now();
      Eigen::Matrix<double, 44, 1> normalized;
      std::array<float, grid::kStretchValues> maps{};
      std::array<float, grid::kMapSlots> pose_map{};
      hand::Angles pose_normalized{}, angles{}, smoothed{};
      if (range->normalize(frame.cells, normalized) != Status::Ok) continue;
      if (map.to_stretch_maps(normalized.data(), maps) != Status::Ok) continue;
      if (model.unet.forward(maps, pose_map, workspace) != Status::Ok) continue;
      map.from_pose_map(pose_map, pose_normalized);
      angles = limits.denormalize(pose_normalized);
      (void)smoothing.filter(angles, frame.timestamp, smoothed);
      kinematics.pose(smoothed, skeleton);
      const double us = std::chrono::duration<double, std::micro>(std::chrono::steady_clock::now() - start).count();
      worst_us = std::max(worst_us, us);
      // 60 cycles of 180 rows per second with a solve every 16 rows: 675 solved frames per second.
      if (++frames % 675 == 1) {
        const Eigen::Vector3d tip = kinematics.fingertip(skeleton, hand::Finger::Index);
        std::printf("t = %.2f s: index flexion %.2f / %.2f / %.2f rad, index tip at (%.1f, %.1f, %.1f) mm, "
                    "oldest reading %.0f ms\n",
                    frame.timestamp, smoothed[5], smoothed[6], smoothed[7], tip.x(), tip.y(), tip.z(), 1e3 * frame.oldest_age);
      }
    }
    std::printf("%d frames after calibration; slowest frame (normalise to kinematics) %.0f us\n", frames, worst_us);
    return frames > 0 ? 0 : 1;
  } catch (const Error& e) {
    std::fprintf(stderr, "stream_to_angles: %s\n", e.what());
    return 2;
  }
}
