/// @file calibration_files_fuzz.cpp
/// @brief Fuzz target: the bytes through the four text readers of calibration and the model's own
/// errors (model::PoseErrorModel::parse, the "pose_error" metadata behind the confidence):
/// calibration::Sequence::parse (a calibration sequence file), calibration::PoseOffsetModel::parse
/// (the "pose_offset" metadata of model files), calibration::RangeMap::parse (their "range_map")
/// and calibration::UserCalibration::load (a saved user calibration with its offsets, from a stream).
///
/// Invariants: bad input is refused with glovepose::Error only; an accepted sequence writes text
/// that parses to the same text and has steps within the joint limits; an accepted offset model
/// round-trips and maps zero features to its finite bias; an accepted range map round-trips and
/// keeps a finite range with min <= max through frames at and beyond its prior; an accepted user
/// calibration has finite offsets and a range that normalises to finite values; an accepted pose
/// error round-trips and gives confidences in [0, 1] under every condition, rate and stood-in cell.
#include <cmath>
#include <cstdint>
#include <optional>
#include <sstream>
#include <string>

#include <glovepose/calibration/free_motion.hpp>
#include <glovepose/calibration/pose_offset.hpp>
#include <glovepose/calibration/sequence.hpp>
#include <glovepose/calibration/user_calibration.hpp>
#include <glovepose/model/pose_error.hpp>

#include "fuzz_check.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace glovepose;
  const std::string text(reinterpret_cast<const char*>(data), size);
  try {
    const calibration::Sequence s = calibration::Sequence::parse(text, "fuzz");
    const std::string again = calibration::Sequence::parse(s.to_json(), "again").to_json();
    GLOVEPOSE_FUZZ_REQUIRE(again == s.to_json());
    GLOVEPOSE_FUZZ_REQUIRE(!s.steps().empty() && std::isfinite(s.total_seconds()) && s.total_seconds() > 0.0);
    GLOVEPOSE_FUZZ_REQUIRE(s.step_at(0.0) == 0 && s.step_at(s.total_seconds()) == -1);
  } catch (const Error&) {
  }
  try {
    const calibration::PoseOffsetModel m = calibration::PoseOffsetModel::parse(text, "fuzz");
    const calibration::PoseOffsetModel again = calibration::PoseOffsetModel::parse(m.to_json(), "again");
    GLOVEPOSE_FUZZ_REQUIRE(again.feature_count() == m.feature_count() && again.cells() == m.cells());
    const hand::Angles zero = m.offsets(Eigen::VectorXd::Zero(m.feature_count()));
    for (std::size_t d = 0; d < hand::kDofCount; ++d) GLOVEPOSE_FUZZ_REQUIRE(zero[d] == m.bias()(static_cast<Eigen::Index>(d)));
  } catch (const Error&) {
  }
  try {
    const calibration::RangeMap m = calibration::RangeMap::parse(text, "fuzz");
    const calibration::RangeMap again = calibration::RangeMap::parse(m.to_json(), "again");
    GLOVEPOSE_FUZZ_REQUIRE(again.cells() == m.cells() && again.stages().size() == m.stages().size());
    if (m.cells() <= 64 && m.histogram().bins <= 4096) {  // bounded work per input
      calibration::ContinuousRange follow(m, 0.25);
      const Eigen::VectorXd span = m.prior_max() - m.prior_min();
      for (int f = 0; f < 40; ++f) {
        const Eigen::VectorXd frame = m.prior_min() + span * ((f % 7) * 0.5 - 1.0);
        (void)follow.add(frame, f * 0.1);
        GLOVEPOSE_FUZZ_REQUIRE(follow.min().allFinite() && follow.max().allFinite() && (follow.min().array() <= follow.max().array()).all());
      }
    }
  } catch (const Error&) {
  }
  try {
    const model::PoseErrorModel m = model::PoseErrorModel::parse(text, "fuzz");
    const model::PoseErrorModel again = model::PoseErrorModel::parse(m.to_json(), "again");
    GLOVEPOSE_FUZZ_REQUIRE(again.to_json() == m.to_json());
    const int masked[] = {0, 1, -1, 1000000};
    hand::Angles rate{}, out{};
    rate.fill(1e300);
    for (const model::ErrorCondition c : {model::ErrorCondition::Guided, model::ErrorCondition::MinMax, model::ErrorCondition::Training,
                                          model::ErrorCondition::Continuous})
      for (const double frames : {0.0, 30.0, 1e9})
        if (m.confidence(c, frames, &rate, masked, 4, 0.17, out))
          for (double v : out) GLOVEPOSE_FUZZ_REQUIRE(v >= 0.0 && v <= 1.0);
  } catch (const Error&) {
  }
  try {
    std::istringstream stream(text);
    const calibration::UserCalibration u = calibration::UserCalibration::load(stream, "fuzz", "g", {"a", "b"});
    if (u.offsets)
      for (double o : *u.offsets) GLOVEPOSE_FUZZ_REQUIRE(std::isfinite(o));
    Eigen::Vector2d raw(1.0, -1.0), out;
    GLOVEPOSE_FUZZ_REQUIRE(u.range.normalize(raw, out) == Status::Ok && out.allFinite());
  } catch (const Error&) {
  }
  return 0;
}
