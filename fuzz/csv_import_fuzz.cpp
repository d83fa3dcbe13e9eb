/// @file csv_import_fuzz.cpp
/// @brief Fuzz target: the bytes as a text import, through both text readers (each refuses the
/// other's format on its first line, so one corpus serves both):
/// - io::Dataset::read_csv (the dataset CSV of `glovepose simulate --csv`), and
/// - sensor::CalibrationRange::load (a saved user calibration of the 44-cell glove), from a stream.
///
/// Invariants: bad input is refused with glovepose::Error only; an accepted CSV gives a dataset that
/// validates, writes CSV that reads back to the same frames, and an accepted calibration gives
/// finite limits with min <= max that normalise a reading to a finite, clamped value.
#include <cstdint>
#include <cstring>
#include <sstream>
#include <string>
#include <vector>

#include <glovepose/grid/glove_description.hpp>
#include <glovepose/sensor/calibration.hpp>
#include <glovepose/io/dataset.hpp>

#include "fuzz_check.hpp"

namespace {

void check_dataset_csv(const std::string& text) {
  glovepose::io::Dataset dataset;
  try {
    std::istringstream in(text);
    dataset = glovepose::io::Dataset::read_csv(in, "glauser2019-44", 60.0);
  } catch (const glovepose::Error&) {
    return;
  }
  dataset.validate();  // throws (and so fails the run) if read_csv let through what validate() refuses
  std::ostringstream written;
  dataset.write_csv(written);
  std::istringstream back(written.str());
  const glovepose::io::Dataset again = glovepose::io::Dataset::read_csv(back, "glauser2019-44", 60.0);
  GLOVEPOSE_FUZZ_REQUIRE(again.cell_count == dataset.cell_count);
  GLOVEPOSE_FUZZ_REQUIRE(again.cells == dataset.cells);
  // Angles of DoFs not labelled are NaN on both sides: compare the bits.
  GLOVEPOSE_FUZZ_REQUIRE(
      again.angles.size() == dataset.angles.size() &&
      (dataset.angles.empty() || std::memcmp(again.angles.data(), dataset.angles.data(), dataset.angles.size() * sizeof(float)) == 0));
  GLOVEPOSE_FUZZ_REQUIRE(again.labelled_dofs() == dataset.labelled_dofs());
  GLOVEPOSE_FUZZ_REQUIRE(again.timestamps == dataset.timestamps);
  GLOVEPOSE_FUZZ_REQUIRE(again.subject == dataset.subject);
  GLOVEPOSE_FUZZ_REQUIRE(again.session == dataset.session);
}

void check_calibration(const std::string& text) {
  static const std::vector<std::string> names = glovepose::grid::GloveDescription::glauser2019().cell_names();
  std::istringstream in(text);
  try {
    const glovepose::sensor::CalibrationRange range = glovepose::sensor::CalibrationRange::load(in, "fuzz input", "glauser2019-44", names);
    GLOVEPOSE_FUZZ_REQUIRE(range.size() == static_cast<int>(names.size()));
    Eigen::VectorXd reading = 0.5 * range.min() + 0.5 * range.max(), normalized(range.size());  // no overflow
    reading[0] = range.max()[0];
    GLOVEPOSE_FUZZ_REQUIRE(glovepose::fuzz::all_finite(reading));
    GLOVEPOSE_FUZZ_REQUIRE(range.normalize(reading, normalized) == glovepose::Status::Ok);
    for (Eigen::Index i = 0; i < normalized.size(); ++i) {
      GLOVEPOSE_FUZZ_REQUIRE(range.min()[i] <= range.max()[i]);
      GLOVEPOSE_FUZZ_REQUIRE(std::isfinite(normalized[i]) && std::abs(normalized[i]) <= range.config().clamp_limit);
    }
  } catch (const glovepose::Error&) {
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  check_dataset_csv(text);
  check_calibration(text);
  return 0;
}
