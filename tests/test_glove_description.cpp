#include <glovepose/grid/glove_description.hpp>
#include <glovepose/sensor/calibration.hpp>

#include <doctest/doctest.h>

#include "test_files.hpp"

#include <array>
#include <cmath>
#include <fstream>
#include <iterator>
#include <set>
#include <string>
#include <vector>

using namespace glovepose;
using namespace glovepose::grid;

namespace {

using glovepose::test::temp_path;

bool same_slot(const Slot& a, const Slot& b) { return a.channel == b.channel && a.row == b.row && a.col == b.col; }

// The paper's Fig. 12 ablation starts from "just 14 sensors covering the main joints": cells 0, 20
// (thumb), 21-24, 32-36, 40-42 (Sec. 3.1, stage (i)). All 14 sense stretch along the finger, so each
// has a channel-0 slot in GridMap::glauser2019(); the test reads the slots from there.
constexpr std::array<int, 14> kMainJointCells = {0, 20, 21, 22, 23, 24, 32, 33, 34, 35, 36, 40, 41, 42};

std::string cell_entry(const std::string& name, const Slot& s) {
  return "{\"name\": \"" + name + "\", \"channel\": " + std::to_string(s.channel) + ", \"row\": " + std::to_string(s.row) +
         ", \"col\": " + std::to_string(s.col) + "}";
}

// The 25 DoFs in the paper's pose-map places, written in reverse kDofs order (order must not matter).
std::string paper_dofs() {
  const auto slots = GridMap::paper_pose_slots();
  std::string out;
  for (std::size_t i = hand::kDofCount; i-- > 0;)
    out += std::string(out.empty() ? "" : ", ") + "{\"name\": \"" + hand::kDofs[i].name + "\", \"row\": " + std::to_string(slots[i].row) +
           ", \"col\": " + std::to_string(slots[i].col) + "}";
  return "[" + out + "]";
}

std::string glove_text(const std::string& cells, const std::string& dofs = paper_dofs(),
                       const std::string& head = "\"format\": \"glovepose-glove\", \"version\": 1, \"id\": \"test\"") {
  return "{" + head + ", \"cells\": " + cells + ", \"dofs\": " + dofs + "}";
}

const std::string kTwoCells = "[" + cell_entry("a", {0, 0, 0}) + ", " + cell_entry("b", {1, 0, 0}) + "]";

}  // namespace

TEST_CASE("glove description: the built-in glove is the paper's GridMap and round-trips through JSON") {
  const GloveDescription builtin = GloveDescription::glauser2019();
  const GridMap paper = GridMap::glauser2019();
  CHECK(builtin.id() == "glauser2019-44");
  REQUIRE(builtin.cell_count() == 44);
  CHECK(builtin.cell_names().front() == "cell_0");
  CHECK(builtin.cell_names().back() == "cell_43");
  CHECK(builtin.cell_index("cell_21") == 21);
  CHECK_THROWS_WITH_AS((void)builtin.cell_index("cell_44"), doctest::Contains("no cell named 'cell_44'"), Error);

  const std::string text = builtin.to_json();
  const GloveDescription back = GloveDescription::from_json(text);
  CHECK(back == builtin);
  CHECK(back.to_json() == text);  // the writer is deterministic
  CHECK(GloveDescription::from_metadata(builtin.to_metadata()) == builtin);
  REQUIRE(back.cell_count() == paper.cell_count());
  for (std::size_t c = 0; c < 44; ++c) {
    INFO("cell " << c);
    CHECK(back.cell_names()[c] == "cell_" + std::to_string(c));
    CHECK(same_slot(back.map().cell_slots()[c], paper.cell_slots()[c]));
  }
  for (std::size_t d = 0; d < hand::kDofCount; ++d) {
    INFO(hand::kDofs[d].name);
    CHECK(same_slot(back.map().dof_slots()[d], paper.dof_slots()[d]));
  }

  // Through a file too.
  const std::string path = temp_path("glauser2019.glove.json");
  builtin.write(path);
  CHECK(GloveDescription::read(path) == builtin);
}

TEST_CASE("glove description: a 14-cell glove of the main-joint cells (paper Fig. 12) maps its cells") {
  const GridMap paper = GridMap::glauser2019();
  std::string cells;
  for (int id : kMainJointCells) {
    const Slot& s = paper.cell_slots()[static_cast<std::size_t>(id)];
    REQUIRE(s.channel == 0);  // main-joint cells measure stretch along the finger
    cells += std::string(cells.empty() ? "" : ", ") + cell_entry("cell_" + std::to_string(id), s);
  }
  const GloveDescription glove = GloveDescription::from_json(
      glove_text("[" + cells + "]", paper_dofs(), "\"format\": \"glovepose-glove\", \"version\": 1, \"id\": \"main-joints-14\""));
  CHECK(glove.id() == "main-joints-14");
  REQUIRE(glove.cell_count() == 14);

  // The names select the 14 columns of 44-cell data; each cell lands where it does on the full glove.
  const GloveDescription full = GloveDescription::glauser2019();
  std::array<double, 44> full_cells{};
  for (int c = 0; c < 44; ++c) full_cells[static_cast<std::size_t>(c)] = 0.5 + 0.01 * c;
  std::array<double, 14> cells14{};
  for (int c = 0; c < 14; ++c)
    cells14[static_cast<std::size_t>(c)] =
        full_cells[static_cast<std::size_t>(full.cell_index(glove.cell_names()[static_cast<std::size_t>(c)]))];
  std::array<float, kStretchValues> maps14{}, maps44{};
  REQUIRE(glove.map().to_stretch_maps(cells14.data(), maps14) == Status::Ok);
  REQUIRE(full.map().to_stretch_maps(full_cells.data(), maps44) == Status::Ok);
  int filled = 0;
  for (std::size_t i = 0; i < maps14.size(); ++i) {
    if (maps14[i] == 0.0f) continue;
    ++filled;
    CHECK(maps14[i] == maps44[i]);
    CHECK(i < static_cast<std::size_t>(kMapSlots));  // only the "along" map is used
  }
  CHECK(filled == 14);
  // Thumb main joints: cell 0 at (row 0, column 2), cell 20 at (row 0, column 3); pinky distal: cell 32.
  CHECK(maps14[static_cast<std::size_t>(Slot{0, 0, 2}.flat())] == static_cast<float>(full_cells[0]));
  CHECK(maps14[static_cast<std::size_t>(Slot{0, 0, 3}.flat())] == static_cast<float>(full_cells[20]));
  CHECK(maps14[static_cast<std::size_t>(Slot{0, 4, 4}.flat())] == static_cast<float>(full_cells[32]));

  // DoFs listed in reverse order still land in their paper slots.
  for (std::size_t d = 0; d < hand::kDofCount; ++d) CHECK(same_slot(glove.map().dof_slots()[d], GridMap::paper_pose_slots()[d]));
  CHECK(GloveDescription::from_json(glove.to_json()) == glove);
}

TEST_CASE("glove description: more cells than the 50 slots of the stretch maps is refused") {
  std::string cells;
  for (int c = 0; c < 60; ++c)
    cells += std::string(cells.empty() ? "" : ", ") + cell_entry("c" + std::to_string(c), {c / 25 % 2, c / 5 % 5, c % 5});
  CHECK_THROWS_WITH_AS(GloveDescription::from_json(glove_text("[" + cells + "]")),
                       doctest::Contains("cells[50] ('c50') is stretch cell 51, but the stretch maps (2 x 5 x 5) have only 50 slots"),
                       Error);
  // 50 cells fill every slot and are fine.
  cells.clear();
  for (int c = 0; c < 50; ++c)
    cells += std::string(cells.empty() ? "" : ", ") + cell_entry("c" + std::to_string(c), {c / 25, c / 5 % 5, c % 5});
  CHECK(GloveDescription::from_json(glove_text("[" + cells + "]")).cell_count() == 50);
}

TEST_CASE("glove description: each malformed input is refused with a message naming the problem") {
  const auto refused = [](const std::string& text, const std::string& expected) {
    INFO(text);
    CHECK_THROWS_WITH_AS(GloveDescription::from_json(text), doctest::Contains(expected.c_str()), Error);
  };
  CHECK(GloveDescription::from_json(glove_text(kTwoCells)).cell_count() == 2);  // the base case is valid

  // Not JSON, not an object.
  refused("{\"format\": ", "glove description: not valid JSON");
  refused("", "not valid JSON");
  refused("[1, 2]", "not a JSON object");
  // Format and version.
  refused(glove_text(kTwoCells, paper_dofs(), "\"format\": \"glovepose-model\", \"version\": 1, \"id\": \"x\""),
          "'format' is 'glovepose-model', expected 'glovepose-glove'");
  refused("{\"format\": \"glovepose-model\", \"width\": \"64\"}", "'format' is 'glovepose-model', expected 'glovepose-glove'");
  refused(glove_text(kTwoCells, paper_dofs(), "\"format\": \"glovepose-glove\", \"version\": 2, \"id\": \"x\""),
          "'version' is 2, expected 1");
  refused(glove_text(kTwoCells, paper_dofs(), "\"format\": \"glovepose-glove\", \"version\": \"1\", \"id\": \"x\""),
          "'version' is \"1\", expected 1");
  // Missing and unknown fields.
  refused(glove_text(kTwoCells, paper_dofs(), "\"format\": \"glovepose-glove\", \"version\": 1"),
          "the top-level object lacks the key 'id'");
  refused("{\"format\": \"glovepose-glove\", \"version\": 1, \"id\": \"x\", \"cells\": " + kTwoCells + "}", "lacks the key 'dofs'");
  refused(glove_text(kTwoCells, paper_dofs(), "\"format\": \"glovepose-glove\", \"version\": 1, \"id\": \"x\", \"colour\": 3"),
          "the top-level object has the unknown key 'colour'");
  refused(glove_text(kTwoCells, paper_dofs(), "\"format\": \"glovepose-glove\", \"version\": 1, \"id\": \"\""), "'id' is empty");
  refused(glove_text("[{\"name\": \"a\", \"channel\": 0, \"row\": 0}]"), "cells[0] ('a') lacks the key 'col'");
  refused(glove_text("[{\"name\": \"a\", \"channel\": 0, \"row\": 0, \"column\": 0}]"),
          "cells[0] has the unknown key 'column', expected only 'name', 'channel', 'row', 'col'");
  refused(glove_text("[{\"channel\": 0, \"row\": 0, \"col\": 0}]"), "cells[0] lacks the key 'name'");
  refused(glove_text("[{\"name\": 7, \"channel\": 0, \"row\": 0, \"col\": 0}]"), "cells[0]: 'name' is 7, expected a string");
  refused(glove_text("{}"), "'cells' is an object, expected an array of cells");
  refused(glove_text("[3]"), "cells[0] is 3, expected an object");
  // Zero cells, duplicate names.
  refused(glove_text("[]"), "'cells' is empty, expected at least one cell");
  refused(glove_text("[" + cell_entry("a", {0, 0, 0}) + ", " + cell_entry("a", {0, 0, 1}) + "]"),
          "cells[1] ('a') has the name of cells[0], expected unique cell names");
  refused(glove_text("[" + cell_entry("", {0, 0, 0}) + "]"), "cells[0]: 'name' is empty");
  // Slots out of range or taken twice.
  refused(glove_text("[" + cell_entry("a", {2, 0, 0}) + "]"), "cells[0] ('a'): 'channel' is 2, expected an integer 0..1");
  refused(glove_text("[" + cell_entry("a", {0, 5, 0}) + "]"), "cells[0] ('a'): 'row' is 5, expected an integer 0..4");
  refused(glove_text("[" + cell_entry("a", {0, 0, -1}) + "]"), "cells[0] ('a'): 'col' is -1, expected an integer 0..4");
  refused(glove_text("[{\"name\": \"a\", \"channel\": 0, \"row\": 1.0, \"col\": 0}]"), "'row' is 1.0, expected an integer 0..4");
  refused(glove_text("[{\"name\": \"a\", \"channel\": 0, \"row\": 99999999999999999999, \"col\": 0}]"),
          "'row' is 1e+20, expected an integer 0..4");
  refused(glove_text("[" + cell_entry("a", {1, 2, 3}) + ", " + cell_entry("b", {1, 2, 3}) + "]"),
          "cells[1] ('b') is placed at (channel 1, row 2, column 3), the slot of cells[0] ('a'), expected one cell per slot");

  // DoFs: unknown name, missing, repeated, out of range, slot taken twice.
  const auto slots = GridMap::paper_pose_slots();
  const auto dof_entry = [&](const std::string& name, int row, int col) {
    return "{\"name\": \"" + name + "\", \"row\": " + std::to_string(row) + ", \"col\": " + std::to_string(col) + "}";
  };
  const auto dofs_with = [&](std::size_t replaced, const std::string& entry, bool drop = false) {
    std::string out;
    for (std::size_t d = 0; d < hand::kDofCount; ++d) {
      if (d == replaced && drop) continue;
      out += std::string(out.empty() ? "" : ", ") + (d == replaced ? entry : dof_entry(hand::kDofs[d].name, slots[d].row, slots[d].col));
    }
    return "[" + out + "]";
  };
  refused(glove_text(kTwoCells, dofs_with(5, dof_entry("index_flex", 1, 1))),
          "dofs[5]: unknown DoF 'index_flex', expected one of the names of hand::kDofs: thumb_base_abduction,");
  refused(glove_text(kTwoCells, dofs_with(24, "", true)), "'dofs' lacks pinky_base_twist, expected each of the 25 DoFs exactly once");
  refused(glove_text(kTwoCells, "[]"), "'dofs' lacks thumb_base_abduction, thumb_base_flexion,");
  refused(glove_text(kTwoCells, "{}"), "'dofs' is an object, expected an array of the 25 DoFs");
  refused(glove_text(kTwoCells, dofs_with(1, dof_entry("thumb_base_abduction", 4, 4))),
          "dofs[1] ('thumb_base_abduction') repeats the DoF of dofs[0], expected each of the 25 DoFs exactly once");
  refused(glove_text(kTwoCells, dofs_with(1, dof_entry("thumb_base_flexion", 0, 5))),
          "dofs[1] ('thumb_base_flexion'): 'col' is 5, expected an integer 0..4");
  refused(
      glove_text(kTwoCells, dofs_with(1, dof_entry("thumb_base_flexion", 0, 0))),
      "dofs[1] ('thumb_base_flexion') is placed at (row 0, column 0), the slot of DoF 'thumb_base_abduction', expected one DoF per slot");
  refused(glove_text(kTwoCells, dofs_with(1, "{\"name\": \"thumb_base_flexion\", \"channel\": 0, \"row\": 0, \"col\": 1}")),
          "dofs[1] has the unknown key 'channel', expected only 'name', 'row', 'col'");
}

TEST_CASE("glove description: files: unreadable and malformed files name the path") {
  CHECK_THROWS_WITH_AS(GloveDescription::read(temp_path("no_such.glove.json")),
                       doctest::Contains(("glove description file '" + temp_path("no_such.glove.json") + "': cannot open").c_str()), Error);
  const std::string path = temp_path("bad.glove.json");
  std::ofstream(path) << "{\"format\": \"glovepose-glove\", \"version\": 1}";
  CHECK_THROWS_WITH_AS(
      GloveDescription::read(path),
      doctest::Contains(("glove description file '" + path + "': glove description: the top-level object lacks the key 'id'").c_str()),
      Error);
  CHECK_THROWS_WITH_AS(GloveDescription::read(GLOVEPOSE_TEST_TMP_DIR), doctest::Contains("glove description file"), Error);  // a folder
  CHECK_THROWS_WITH_AS(GloveDescription::glauser2019().write(temp_path("no_such_folder/x.json")),
                       doctest::Contains("cannot open for writing"), Error);
}

TEST_CASE("glove description: the constructor checks names against the map") {
  const GridMap map = GridMap::glauser2019();
  CHECK_THROWS_WITH_AS(GloveDescription("x", {"a"}, map), doctest::Contains("1 cell names, expected 44"), Error);
  CHECK_THROWS_WITH_AS(GloveDescription("", std::vector<std::string>(44, "a"), map), doctest::Contains("empty id"), Error);
  std::vector<std::string> names;
  for (int c = 0; c < 44; ++c) names.push_back("n" + std::to_string(c));
  names[9] = "n3";
  CHECK_THROWS_WITH_AS(GloveDescription("x", names, map), doctest::Contains("cell 9 is named 'n3' like cell 3"), Error);
  names[9] = "";
  CHECK_THROWS_WITH_AS(GloveDescription("x", names, map), doctest::Contains("cell 9 has an empty name"), Error);
  names[9] = "n9";
  const GloveDescription renamed("x", names, map);
  CHECK(renamed != GloveDescription::glauser2019());
  // Ids and names with characters JSON must escape survive the round trip.
  names[0] = "quote \" backslash \\ newline \n";
  const GloveDescription odd("glove \"7\"", names, map);
  CHECK(GloveDescription::from_json(odd.to_json()) == odd);
}

TEST_CASE("glove description: joint limits, rate and calibration: defaults, round trip, what they mean") {
  // Defaults: the built-in glove's, and the calibration's own default flat rule.
  const GloveDescription plain = GloveDescription::from_json(glove_text(kTwoCells));
  CHECK(!plain.rate_hz());
  CHECK(plain.calibration().flat_relative_range == sensor::CalibrationConfig{}.min_relative_range);
  CHECK(plain.calibration().min_range_to_noise == sensor::CalibrationConfig{}.min_range_to_noise);
  CHECK(plain.calibration().median_frames(60.0) == 20);  // the paper's 20 frames at 60 Hz
  CHECK(plain.calibration().median_frames(20.0) == 7);   // a third of a second at 20 Hz
  CHECK(plain.calibration().median_frames(1.0) == 1);    // at least one frame
  const hand::JointLimits reference;
  CHECK(plain.joint_limits().min() == reference.min());
  CHECK(plain.joint_limits().max() == reference.max());
  CHECK(plain.to_json().find("rate_hz") == std::string::npos);  // defaults are not written
  CHECK(plain.to_json().find("calibration") == std::string::npos);

  // Own settings: two DoFs' limits in degrees, a rate, a median and a flat rule.
  std::string dofs = paper_dofs();
  const auto add_limits = [&](const std::string& name, const std::string& limits) {
    const std::string key = "{\"name\": \"" + name + "\"";
    const std::size_t at = dofs.find(key);
    REQUIRE(at != std::string::npos);
    dofs.insert(dofs.find('}', at), limits);
  };
  add_limits("index_base_flexion", ", \"min_degrees\": -25, \"max_degrees\": 100.5");
  add_limits("thumb_base_abduction", ", \"max_degrees\": 40, \"min_degrees\": -12");
  const std::string text = "{\"format\": \"glovepose-glove\", \"version\": 1, \"id\": \"own\", \"cells\": " + kTwoCells +
                           ", \"dofs\": " + dofs +
                           ", \"rate_hz\": 20, \"calibration\": {\"median_seconds\": 0.5, \"flat_relative_range\": 0.001, "
                           "\"min_range_to_noise\": 8.5}}";
  const GloveDescription own = GloveDescription::from_json(text);
  REQUIRE(own.rate_hz());
  CHECK(*own.rate_hz() == 20.0);
  CHECK(own.calibration().median_seconds == 0.5);
  CHECK(own.calibration().flat_relative_range == 0.001);
  CHECK(own.calibration().min_range_to_noise == 8.5);
  CHECK(own.calibration().config().min_range_to_noise == 8.5);
  CHECK(own.calibration().median_frames(*own.rate_hz()) == 10);
  const hand::JointLimits limits = own.joint_limits();
  const double pi = 3.14159265358979323846;
  for (std::size_t d = 0; d < hand::kDofCount; ++d) {
    INFO(hand::kDofs[d].name);
    const std::string name = hand::kDofs[d].name;
    if (name == "index_base_flexion") {
      CHECK(limits.min()[d] == doctest::Approx(-25.0 * pi / 180.0).epsilon(1e-15));
      CHECK(limits.max()[d] == doctest::Approx(100.5 * pi / 180.0).epsilon(1e-15));
    } else if (name == "thumb_base_abduction") {
      CHECK(limits.min()[d] == doctest::Approx(-12.0 * pi / 180.0).epsilon(1e-15));
      CHECK(limits.max()[d] == doctest::Approx(40.0 * pi / 180.0).epsilon(1e-15));
    } else {
      CHECK(limits.min()[d] == reference.min()[d]);  // the others keep the reference's, exactly
      CHECK(limits.max()[d] == reference.max()[d]);
    }
  }
  // Round trip: the same description, and the same text again.
  const GloveDescription back = GloveDescription::from_json(own.to_json());
  CHECK(back == own);
  CHECK(back.to_json() == own.to_json());
  CHECK(!(own == plain));
  // Each setting takes part in equality.
  GloveSettings other = own.settings();
  other.rate_hz = 21.0;
  CHECK(GloveDescription("own", own.cell_names(), own.map(), other) != own);
  other = own.settings();
  other.calibration.median_seconds = 0.4;
  CHECK(GloveDescription("own", own.cell_names(), own.map(), other) != own);
  other = own.settings();
  other.calibration.min_range_to_noise = 0.0;  // the noise rule off: kept as 0, not as the default
  const GloveDescription off("own", own.cell_names(), own.map(), other);
  CHECK(off != own);
  CHECK(GloveDescription::from_json(off.to_json()).calibration().min_range_to_noise == 0.0);
  // A description at the default noise rule writes no key for it (its text as before the key).
  other.calibration.min_range_to_noise = sensor::CalibrationConfig{}.min_range_to_noise;
  const GloveDescription default_noise("own", own.cell_names(), own.map(), other);
  CHECK(default_noise.to_json().find("min_range_to_noise") == std::string::npos);
  CHECK(GloveDescription::from_json(default_noise.to_json()) == default_noise);
  other = own.settings();
  other.limits_degrees[0] = std::nullopt;
  CHECK(GloveDescription("own", own.cell_names(), own.map(), other) != own);
  CHECK(GloveDescription("own", own.cell_names(), own.map(), own.settings()) == own);
}

TEST_CASE("glove description: malformed joint limits, rate and calibration are refused naming the field") {
  const auto refused = [](const std::string& dofs, const std::string& tail, const std::string& expected) {
    const std::string text =
        "{\"format\": \"glovepose-glove\", \"version\": 1, \"id\": \"x\", \"cells\": " + kTwoCells + ", \"dofs\": " + dofs + tail + "}";
    INFO(text);
    CHECK_THROWS_WITH_AS(GloveDescription::from_json(text), doctest::Contains(expected.c_str()), Error);
  };
  const auto with = [](const std::string& limits) {
    std::string dofs = paper_dofs();
    const std::size_t at = dofs.find("{\"name\": \"index_base_flexion\"");
    dofs.insert(dofs.find('}', at), limits);
    return dofs;
  };
  const std::string dofs = paper_dofs();
  refused(with(", \"min_degrees\": -25"), "",
          "('index_base_flexion') has 'min_degrees' without 'max_degrees', expected both limits or neither");
  refused(with(", \"max_degrees\": 90"), "", "has 'max_degrees' without 'min_degrees'");
  refused(with(", \"min_degrees\": 90, \"max_degrees\": 90"), "", "has limits [90, 90] degrees, expected min_degrees < max_degrees");
  refused(with(", \"min_degrees\": -400, \"max_degrees\": 90"), "", "within [-360, 360]");
  refused(with(", \"min_degrees\": \"-25\", \"max_degrees\": 90"), "", "'min_degrees' is \"-25\", expected a number");
  refused(with(", \"min_deg\": -25"), "", "has the unknown key 'min_deg'");
  refused(dofs, ", \"rate_hz\": 0", "'rate_hz' is 0, expected frames per second > 0");
  refused(dofs, ", \"rate_hz\": -60", "'rate_hz' is -60");
  refused(dofs, ", \"rate_hz\": \"60\"", "'rate_hz' is \"60\", expected a number");
  refused(dofs, ", \"calibration\": 3", "'calibration' is 3, expected an object");
  refused(dofs, ", \"calibration\": {\"median_seconds\": 0}", "'calibration.median_seconds' is 0, expected a time > 0 s");
  refused(dofs, ", \"calibration\": {\"flat_relative_range\": 1}",
          "'calibration.flat_relative_range' is 1, expected a fraction >= 0 and < 1");
  refused(dofs, ", \"calibration\": {\"flat_relative_range\": -0.1}", "'calibration.flat_relative_range' is -0.1");
  refused(dofs, ", \"calibration\": {\"median_window\": 20}", "'calibration' has the unknown key 'median_window'");
  refused(dofs, ", \"calibration\": {\"min_range_to_noise\": -1}",
          "'calibration.min_range_to_noise' is -1, expected a multiple of the noise SD >= 0 and at most 1000");
  refused(dofs, ", \"calibration\": {\"min_range_to_noise\": 5000}", "'calibration.min_range_to_noise' is 5000");
  refused(dofs, ", \"calibration\": {\"min_range_to_noise\": \"12\"}", "'min_range_to_noise' is \"12\", expected a number");
  // The constructor checks the same.
  GloveSettings bad;
  bad.limits_degrees[3] = DofLimitsDegrees{10.0, -10.0};
  const GloveDescription two = GloveDescription::from_json(glove_text(kTwoCells));
  const std::string expected = std::string("DoF '") + hand::kDofs[3].name + "' has limits [10, -10] degrees";
  CHECK_THROWS_WITH_AS(GloveDescription("x", two.cell_names(), two.map(), bad), doctest::Contains(expected.c_str()), Error);
  bad = GloveSettings{};
  bad.calibration.median_seconds = std::nan("");
  CHECK_THROWS_WITH_AS(GloveDescription("x", two.cell_names(), two.map(), bad), doctest::Contains("median_seconds"), Error);
  bad = GloveSettings{};
  bad.calibration.min_range_to_noise = std::nan("");
  CHECK_THROWS_WITH_AS(GloveDescription("x", two.cell_names(), two.map(), bad), doctest::Contains("'calibration.min_range_to_noise' is nan"),
                       Error);
}

TEST_CASE("glove description: the example of a device that is not a glove loads, and weights_format.md shows it whole") {
  const std::string path = std::string(GLOVEPOSE_SOURCE_DIR) + "/examples/wearable_device.glove.json";
  const GloveDescription device = GloveDescription::read(path);
  CHECK(device.id() == "wearable-16");
  CHECK(device.cell_count() == 16);
  CHECK(device.map().extra_input_count() == 16);  // every channel an extra input: none on the stretch maps
  CHECK(device.cell_names().front() == "channel_00");
  CHECK(device.cell_names().back() == "channel_15");
  REQUIRE(device.rate_hz().has_value());
  CHECK(*device.rate_hz() == 30.0);
  // The 25 DoFs where the built-in glove's pose map has them.
  const GloveDescription paper = GloveDescription::glauser2019();
  for (std::size_t d = 0; d < hand::kDofCount; ++d) CHECK(same_slot(device.map().dof_slots()[d], paper.map().dof_slots()[d]));
  // The documentation's block is the file, byte for byte.
  std::ifstream doc(std::string(GLOVEPOSE_SOURCE_DIR) + "/weights_format.md"), file(path);
  const std::string doc_text((std::istreambuf_iterator<char>(doc)), std::istreambuf_iterator<char>());
  const std::string file_text((std::istreambuf_iterator<char>(file)), std::istreambuf_iterator<char>());
  CHECK(doc_text.find("```json\n" + file_text + "```\n") != std::string::npos);
  // What the library writes of it reads back equal.
  CHECK(GloveDescription::from_json(device.to_json()) == device);
}
