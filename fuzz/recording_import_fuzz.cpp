/// @file recording_import_fuzz.cpp
/// @brief Fuzz target: the bytes as a glove maker's CSV take for train::RecordingImporter (a 5-cell
/// glove whose cells are named a..e), after a valid take without angles already imported (unless
/// the first byte says not to). The first byte chooses the options: degrees, allow_flat, the take's
/// kind, subject and session.
///
/// Invariants: bad input is refused with glovepose::Error only, and a refused take leaves the
/// dataset as it was; an accepted one validates, adds at least one frame, keeps every value finite
/// (NaN exactly for the DoFs not labelled), and reports flat sensors only when they are allowed.
#include <cstdint>
#include <sstream>
#include <string>

#include <glovepose/train/recording_import.hpp>

#include "fuzz_check.hpp"

namespace {

glovepose::grid::GloveDescription five_cells() {
  const glovepose::grid::GridMap paper = glovepose::grid::GridMap::glauser2019();
  std::vector<glovepose::grid::Slot> slots(paper.cell_slots().begin(), paper.cell_slots().begin() + 5);
  return glovepose::grid::GloveDescription("fuzz-5", {"a", "b", "c", "d", "e"}, glovepose::grid::GridMap(slots, paper.dof_slots()));
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace glovepose;
  if (size == 0) return 0;
  const std::uint8_t flags = data[0];
  const std::string text(reinterpret_cast<const char*>(data + 1), size - 1);

  train::CsvImportOptions options;
  options.frame_rate = 60.0;
  options.degrees = flags & 1;
  options.allow_flat = flags & 2;
  options.ignored_columns = {"frame"};
  train::RecordingImporter importer(five_cells(), options);
  if (!(flags & 32)) {
    std::istringstream first("subject,timestamp,a,b,c,d,e\n0,0,1,2,3,4,5\n0,0.5,2,3,4,5,6\n");
    importer.add(first, {"first.csv", {}, {}, io::kKindCalibration});
  }
  const io::Dataset before = importer.dataset();

  train::CsvTake take{"fuzz.csv", {}, {}, {}};
  if (flags & 4) take.kind = io::kKindCalibration;
  if (flags & 8) take.subject = 1;
  if (flags & 16) take.session = 2;
  std::istringstream in(text);
  try {
    importer.add(in, take);
  } catch (const Error&) {
    const io::Dataset& after = importer.dataset();
    GLOVEPOSE_FUZZ_REQUIRE(after.cells == before.cells && after.timestamps == before.timestamps && after.kind == before.kind &&
                           after.subject == before.subject && after.angles == before.angles);
    return 0;
  }
  const io::Dataset& after = importer.dataset();
  after.validate();  // throws (and so fails the run) if the importer let through what validate() refuses
  GLOVEPOSE_FUZZ_REQUIRE(after.frames() > before.frames());
  GLOVEPOSE_FUZZ_REQUIRE(fuzz::all_finite(after.cells) && fuzz::all_finite(after.timestamps));
  const hand::DofSet labelled = after.labelled_dofs();
  for (std::size_t i = 0; i < after.angles.size(); ++i)
    GLOVEPOSE_FUZZ_REQUIRE(labelled[i % hand::kDofCount] ? std::isfinite(after.angles[i]) : std::isnan(after.angles[i]));
  GLOVEPOSE_FUZZ_REQUIRE(options.allow_flat || importer.flat_sensors().empty());
  return 0;
}
