// README's C++ example as a program (README, "Use"), built twice by the consumer project: against
// the compiled library (glovepose::compiled), where the unit must compile declarations only, and
// header-only (glovepose::glovepose). Feeds a made-up row stream (not a glove's: the readout flags
// its rows as disagreeing, so few poses are trusted); exits 0 when poses came.
#include <glovepose/glovepose.hpp>

#include <cmath>
#include <cstdio>

#if defined(GLOVEPOSE_COMPILED_LIB) && (defined(EIGEN_WORLD_VERSION) || defined(XSIMD_VERSION_MAJOR) || defined(NLOHMANN_JSON_VERSION_MAJOR))
#error "glovepose.hpp brought Eigen, xsimd or nlohmann-json into a unit that links glovepose::compiled"
#endif

using namespace glovepose;

namespace {
long poses_driven = 0, poses = 0;
void drive_hand(const hand::Angles& angles, const hand::JointList& joints) {
  if (std::isfinite(angles[0]) && joints[0].rotation[3] != 0.0f) ++poses_driven;
}
// A stand-in for the glove: every row of the 15 x 12 readout, its value drifting slowly.
double reading(int row, long cycle) { return 20.0 + 5.0 * std::sin(0.05 * static_cast<double>(cycle) + 0.3 * row); }
}  // namespace

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: readme_example MODEL_FILE\n");
    return 2;
  }
  try {
    auto model = PoseModel::load(argv[1]);  // set-up: throws glovepose::Error
    EstimatorConfig config;
    config.joint_transforms = true;  // optional 21-joint list for a skeleton
    GlovePoseEstimator estimator(model, config);

    estimator.start_calibration();  // the user follows the model's calibration sequence ...
    const int rows = 180;
    double timestamp = 0.0;
    for (long cycle = 0; cycle < 200; ++cycle)
      for (int row = 0; row < rows; ++row, timestamp += 1.0 / 10800.0) (void)estimator.push_row(row, reading(row, cycle), timestamp);
    std::printf("calibration: %ld frames taken\n", estimator.calibration_progress().frames);
    estimator.finish_calibration();

    for (long cycle = 200; cycle < 260; ++cycle)
      for (int row = 0; row < rows; ++row, timestamp += 1.0 / 10800.0) {
        const double value = reading(row, cycle);
        // per frame: noexcept, no allocation; a Status for bad input
        if (estimator.push_row(row, value, timestamp) == Status::Solved) {
          ++poses;
          const Pose& pose = estimator.pose();  // angles (rad), timestamp, oldest_age, compute_seconds, flags
          if (pose.trusted()) drive_hand(pose.angles, estimator.joints());
        }
      }
  } catch (const Error& e) {
    std::fprintf(stderr, "readme_example: %s\n", e.what());
    return 1;
  }
  std::printf("%ld poses, %ld trusted and driven\n", poses, poses_driven);
  return poses > 0 ? 0 : 1;
}
