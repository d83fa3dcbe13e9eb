/// @file keypoint_file_fuzz.cpp
/// @brief Fuzz target: the bytes as a hand tracker's keypoint file (train::read_keypoint_file, what
/// `glovepose import` reads from a takes list's keypoints column), then, when accepted, as keypoint
/// columns of a glove take (the same reader row by row) and through the hand-shape fit.
///
/// Invariants: bad input is refused with glovepose::Error only; an accepted file has times that
/// increase, one row of the layout's keypoints per time, each keypoint all finite or all NaN and
/// absent keypoints NaN throughout; the shape fit either refuses with glovepose::Error or gives a
/// hand whose bones are 3-150 mm long and a finite, non-negative noise.
#include <cmath>
#include <cstdint>
#include <sstream>
#include <string>

#include <glovepose/hand/keypoint_fit.hpp>
#include <glovepose/train/keypoint_columns.hpp>

#include "fuzz_check.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace glovepose;
  if (size == 0) return 0;
  const double scale = data[0] & 1 ? 1000.0 : 1.0;
  std::istringstream in(std::string(reinterpret_cast<const char*>(data + 1), size - 1));
  train::KeypointFile file;
  try {
    file = train::read_keypoint_file(in, "fuzz.csv", scale, {"frame"});
  } catch (const Error&) {
    return 0;
  }
  const std::size_t count = hand::keypoint_count(file.layout);
  const train::KeypointTrack& track = file.track;
  GLOVEPOSE_FUZZ_REQUIRE(!track.times.empty() && track.points.size() == track.times.size() * count);
  for (std::size_t f = 0; f < track.times.size(); ++f) {
    GLOVEPOSE_FUZZ_REQUIRE(std::isfinite(track.times[f]) && (f == 0 || track.times[f] > track.times[f - 1]));
    for (std::size_t k = 0; k < count; ++k) {
      const Eigen::Vector3d& p = track.points[f * count + k];
      GLOVEPOSE_FUZZ_REQUIRE(p.allFinite() || p.array().isNaN().all());
      GLOVEPOSE_FUZZ_REQUIRE(file.present[k] || p.array().isNaN().all());
    }
  }
  try {
    const hand::HandShapeFit fit = hand::fit_hand_shape(file.layout, track.points, hand::Kinematics());
    GLOVEPOSE_FUZZ_REQUIRE(std::isfinite(fit.noise_mm) && fit.noise_mm >= 0.0 && fit.frames >= 10);
    for (std::size_t f = 0; f < hand::kFingerCount; ++f) {
      const auto base = static_cast<std::size_t>(hand::kFingerBase[f]);
      for (std::size_t k = 1; k < 3; ++k) {
        const double bone = fit.model.rest[base + k].translation().norm();
        GLOVEPOSE_FUZZ_REQUIRE(bone >= 3.0 && bone <= 150.0);
      }
      GLOVEPOSE_FUZZ_REQUIRE(fit.model.tip_length[f] >= 3.0 && fit.model.tip_length[f] <= 150.0);
    }
  } catch (const Error&) {
  }
  return 0;
}
