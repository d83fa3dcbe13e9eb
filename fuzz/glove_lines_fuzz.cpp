/// @file glove_lines_fuzz.cpp
/// @brief Fuzz target: a flag byte, then text read as a glove's stream by the tool's line reader
/// (tools/cli/glove_lines.hpp: `glovepose view --stdin`, `glovepose predict --raw`) into one
/// GlovePoseEstimator over tests/fixtures/unet_w4.safetensors (the built-in glove: lines of 44 cells
/// and raw rows of its wiring both parse), loaded once. The flag chooses a saved calibration
/// (every frame a pose) or an on-the-fly one of 0.05-3 s of stream time.
///
/// Invariants: refusals are glovepose::Error only; every line counted is understood or skipped
/// (lines = inputs + skipped), poses and refusals within the inputs, a first reason kept when
/// anything was skipped or refused; the callback sees one status per input and a Solved status
/// exactly once per pose, each with finite angles within the model's joint limits; with a saved
/// calibration a stream that ends well has a pose.
#include <fuzzer/FuzzedDataProvider.h>

#include <cstdint>
#include <memory>
#include <sstream>
#include <string>

#include <glovepose/estimator.hpp>

#include "fuzz_check.hpp"
#include "glove_lines.hpp"

namespace {

const std::shared_ptr<const glovepose::PoseModel>& model() {
  static const auto loaded = glovepose::PoseModel::load(GLOVEPOSE_SOURCE_DIR "/tests/fixtures/unet_w4.safetensors");
  return loaded;
}

// A range that moves every cell (1 to 20 pF; the fixture's plausible cells lie within).
glovepose::sensor::CalibrationRange saved_range(const glovepose::PoseModel& m) {
  const auto n = static_cast<Eigen::Index>(m.cell_count());
  return glovepose::sensor::CalibrationRange(Eigen::VectorXd::Constant(n, 1.0), Eigen::VectorXd::Constant(n, 20.0), m.glove().cell_names());
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  FuzzedDataProvider input(data, size);
  const std::uint8_t flags = input.ConsumeIntegral<std::uint8_t>();
  const std::string text = input.ConsumeRemainingBytesAsString();
  glovepose::GlovePoseEstimator estimator(model());
  const bool saved = (flags & 1) != 0;
  std::optional<double> seconds;
  if (saved)
    estimator.set_calibration(saved_range(*model()));
  else
    seconds = 0.05 + 3.0 * (flags >> 1) / 127.0;
  const glovepose::cli::GloveLineFormat format(*model(), (flags & 2) != 0);
  glovepose::cli::GloveLineCounts counts;
  std::istringstream in(text);
  std::ostringstream told;
  long statuses = 0, solved = 0;
  const glovepose::hand::JointLimits& limits = model()->joint_limits();
  bool ended_well = true;
  try {
    glovepose::cli::read_glove_lines(
        glovepose::cli::GloveLineSource{in, "stdin", "fuzz", &told}, format, estimator, seconds, counts, [&](glovepose::Status status) {
          ++statuses;
          if (status != glovepose::Status::Solved) return;
          ++solved;
          const auto& pose = estimator.pose();
          GLOVEPOSE_FUZZ_REQUIRE(glovepose::fuzz::all_finite(pose.angles));
          for (std::size_t d = 0; d < glovepose::hand::kDofCount; ++d)
            GLOVEPOSE_FUZZ_REQUIRE(pose.raw_angles[d] >= limits.min()[d] - 1e-9 && pose.raw_angles[d] <= limits.max()[d] + 1e-9);
        });
  } catch (const glovepose::Error&) {
    ended_well = false;  // a stream it cannot use: refused with a reason
  }
  GLOVEPOSE_FUZZ_REQUIRE(counts.lines == counts.inputs + counts.skipped);
  GLOVEPOSE_FUZZ_REQUIRE(statuses == counts.inputs && solved == counts.poses);
  GLOVEPOSE_FUZZ_REQUIRE(counts.poses + counts.rejected <= counts.inputs);
  GLOVEPOSE_FUZZ_REQUIRE(counts.skipped == 0 || !counts.first_skipped.empty());
  GLOVEPOSE_FUZZ_REQUIRE(counts.rejected == 0 || !counts.first_rejected.empty());
  if (ended_well) GLOVEPOSE_FUZZ_REQUIRE(counts.poses > 0);
  return 0;
}
