// train::RecordingImporter: CSV takes with named columns read back to the frames they were written
// from (the reference: the arrays the test wrote, exact at 9 significant digits), and every kind of
// bad take refused with its file, line and column named.
#include <glovepose/train/recording_import.hpp>
#include <glovepose/train/samples.hpp>

#include <doctest/doctest.h>

#include <algorithm>
#include <charconv>
#include <cmath>
#include <numeric>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#if __has_include(<fnmatch.h>)
#include <fnmatch.h>  // POSIX: the reference for --ignore patterns
#endif

using namespace glovepose;

namespace {

// A 5-cell glove with cells named as a glove maker would, on the first slots of the built-in map.
grid::GloveDescription small_glove() {
  const grid::GridMap paper = grid::GridMap::glauser2019();
  std::vector<grid::Slot> slots(paper.cell_slots().begin(), paper.cell_slots().begin() + 5);
  return grid::GloveDescription("five-cell", {"thumb_bend", "index_bend", "middle_bend", "ring_bend", "pinky_bend"},
                                grid::GridMap(slots, paper.dof_slots()));
}

std::string text(double v) {
  char buf[64];
  const auto r = std::to_chars(buf, buf + sizeof buf, v, std::chars_format::general, 17);
  return std::string(buf, r.ptr);
}

// Frames the test writes: per frame 5 cell readings and 25 angles, random but moving.
struct Frames {
  std::vector<float> cells, angles;
  std::size_t count() const { return cells.size() / 5; }
};
Frames random_frames(std::size_t n, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> reading(1.0f, 3.0f), angle(-1.0f, 1.0f);
  Frames f;
  for (std::size_t i = 0; i < n * 5; ++i) f.cells.push_back(reading(rng));
  for (std::size_t i = 0; i < n * hand::kDofCount; ++i) f.angles.push_back(angle(rng));
  return f;
}

// The frames as CSV: the columns in the order given; a cell is named by its glove name, a DoF by
// hand::kDofs; "subject", "timestamp", "frame" etc. filled from `extra(column, frame)`.
template <typename Extra>
std::string csv(const Frames& f, const std::vector<std::string>& columns, Extra extra, double angle_scale = 1.0) {
  const grid::GloveDescription glove = small_glove();
  std::string out;
  for (std::size_t k = 0; k < columns.size(); ++k) out += (k ? "," : "") + columns[k];
  out += "\n";
  for (std::size_t i = 0; i < f.count(); ++i) {
    for (std::size_t k = 0; k < columns.size(); ++k) {
      const auto& names = glove.cell_names();
      const auto cell = std::find(names.begin(), names.end(), columns[k]);
      std::string value;
      if (cell != names.end())
        value = text(f.cells[i * 5 + static_cast<std::size_t>(cell - names.begin())]);
      else {
        std::size_t d = 0;
        while (d < hand::kDofCount && columns[k] != hand::kDofs[d].name) ++d;
        value = d < hand::kDofCount ? text(f.angles[i * hand::kDofCount + d] * angle_scale) : extra(columns[k], i);
      }
      out += (k ? "," : "") + value;
    }
    out += "\n";
  }
  return out;
}

std::vector<std::string> all_columns(std::vector<std::string> extra) {
  const grid::GloveDescription glove = small_glove();
  for (const std::string& name : glove.cell_names()) extra.push_back(name);
  for (const hand::Dof& d : hand::kDofs) extra.push_back(d.name);
  return extra;
}

train::CsvImportOptions options(double rate = 20.0) {
  train::CsvImportOptions o;
  o.frame_rate = rate;
  return o;
}

std::string import_error(const std::string& take_text, train::CsvTake take, train::CsvImportOptions o = options()) {
  train::RecordingImporter importer(small_glove(), o);
  std::istringstream in(take_text);
  try {
    importer.add(in, take);
  } catch (const Error& e) {
    CHECK(importer.dataset().frames() == 0);  // nothing half-read is kept
    return e.what();
  }
  FAIL("the take was accepted: " << take_text.substr(0, 200));
  return "";
}

}  // namespace

TEST_CASE("import: named columns in any order read back to the frames written, with ids, kinds and times") {
  const Frames f = random_frames(40, 1);
  std::vector<std::string> columns = all_columns({"subject", "session", "timestamp_ms", "frame", "kind"});
  std::shuffle(columns.begin(), columns.end(), std::mt19937(2));
  const std::string take = csv(f, columns, [](const std::string& column, std::size_t i) -> std::string {
    if (column == "subject") return i < 20 ? "4" : "6";
    if (column == "session") return "2";
    if (column == "timestamp_ms") return text(1000.0 + 12.5 * static_cast<double>(i % 20));
    if (column == "kind") return i % 20 < 5 ? "calibration" : "recording";
    return std::to_string(i);  // "frame": ignored
  });
  train::CsvImportOptions o = options();
  o.ignored_columns = {"frame"};
  train::RecordingImporter importer(small_glove(), o);
  std::istringstream in(take);
  importer.add(in, {"take.csv", {}, {}, {}});
  const io::Dataset& data = importer.dataset();
  data.validate();
  REQUIRE(data.frames() == 40);
  CHECK(data.cell_count == 5);
  CHECK(data.glove_layout() == "five-cell");
  CHECK(data.frame_rate() == 20.0);
  CHECK(data.cells == f.cells);
  CHECK(data.angles == f.angles);
  for (std::size_t i = 0; i < 40; ++i) {
    CAPTURE(i);
    CHECK(data.subject[i] == (i < 20 ? 4 : 6));
    CHECK(data.session[i] == 2);
    CHECK(data.donning[i] == 2);
    CHECK(data.glove[i] == 0);
    CHECK(data.outlier[i] == 0);
    CHECK(data.kind[i] == (i % 20 < 5 ? io::kKindCalibration : io::kKindRecording));
    CHECK(data.timestamps[i] == doctest::Approx(1.0 + 0.0125 * static_cast<double>(i % 20)).epsilon(1e-15));
  }
  CHECK(importer.flat_sensors().empty());
}

TEST_CASE("import: without a time column frames are 1/rate apart per run, degrees, ids and kind from the take") {
  const Frames f = random_frames(30, 3);
  const std::string take = csv(
      f, all_columns({}), [](const std::string&, std::size_t) { return std::string(); }, core::kDegreesPerRadian);
  train::CsvImportOptions o = options(50.0);
  o.degrees = true;
  train::RecordingImporter importer(small_glove(), o);
  std::istringstream calibration(take), recording(take), again(take);
  importer.add(calibration, {"cal.csv", 3, 1, io::kKindCalibration});
  importer.add(recording, {"rec.csv", 3, 1, io::kKindRecording});
  importer.add(again, {"rec2.csv", 3, 1, io::kKindRecording});  // same run: its times go on
  const io::Dataset& data = importer.dataset();
  data.validate();
  REQUIRE(data.frames() == 90);
  for (std::size_t i = 0; i < 90; ++i) {
    CAPTURE(i);
    CHECK(data.subject[i] == 3);
    CHECK(data.session[i] == 1);
    CHECK(data.kind[i] == (i < 30 ? io::kKindCalibration : io::kKindRecording));
    const double expected = static_cast<double>(i < 30 ? i : i - 30) / 50.0;  // 1/50 s steps, each run from 0
    CHECK(data.timestamps[i] == doctest::Approx(expected).epsilon(1e-12));
  }
  for (std::size_t i = 0; i < f.angles.size(); ++i) {
    // Written as degrees with 17 digits, read back as radians: within float rounding.
    CHECK(data.angles[i] == doctest::Approx(f.angles[i]).epsilon(1e-6));
    CHECK(data.angles[60 * hand::kDofCount + i] == data.angles[i]);
  }
}

TEST_CASE("import: a sensor flat over a calibration take is refused with file, lines and column, or kept and listed") {
  Frames f = random_frames(12, 4);
  for (std::size_t i = 0; i < 12; ++i) f.cells[i * 5 + 2] = 2.0f + 0.001f * static_cast<float>(i % 3);  // 0.1% of its value
  const std::string take =
      "# a glove maker's calibration\n" + csv(f, all_columns({}), [](const std::string&, std::size_t) { return std::string(); });
  const std::string error = import_error(take, {"cal_s1.csv", 1, {}, io::kKindCalibration});
  CHECK(error.find("CSV file 'cal_s1.csv', lines 3-14") == 0);
  CHECK(error.find("column 'middle_bend': flat (2 to 2.002") != std::string::npos);
  CHECK(error.find("within 1% of its value") != std::string::npos);
  // The same rows as a recording are not a calibration: accepted.
  {
    train::RecordingImporter importer(small_glove(), options());
    std::istringstream in(take);
    importer.add(in, {"rec_s1.csv", 1, {}, io::kKindRecording});
    CHECK(importer.dataset().frames() == 12);
  }
  train::CsvImportOptions o = options();
  o.allow_flat = true;
  train::RecordingImporter importer(small_glove(), o);
  std::istringstream in(take);
  importer.add(in, {"cal_s1.csv", 1, {}, io::kKindCalibration});
  REQUIRE(importer.flat_sensors().size() == 1);
  const train::FlatSensor& flat = importer.flat_sensors()[0];
  CHECK(flat.cell == "middle_bend");
  CHECK(flat.first_line == 3);
  CHECK(flat.last_line == 14);
  CHECK(flat.min == 2.0);
  CHECK(flat.max == doctest::Approx(2.002).epsilon(1e-6));
  // A glove described with a looser rule (0.05%) does not call a 0.1% range flat.
  grid::GloveSettings settings;
  settings.calibration.flat_relative_range = 0.0005;
  const grid::GloveDescription five = small_glove();
  train::RecordingImporter loose(grid::GloveDescription(five.id(), five.cell_names(), five.map(), settings), options());
  std::istringstream in2(take);
  loose.add(in2, {"cal_s1.csv", 1, {}, io::kKindCalibration});
  CHECK(loose.flat_sensors().empty());
  // Its message names the rule in use.
  settings.calibration.flat_relative_range = 0.002;
  train::RecordingImporter strict(grid::GloveDescription(five.id(), five.cell_names(), five.map(), settings), options());
  std::istringstream in3(take);
  CHECK_THROWS_WITH_AS(strict.add(in3, {"cal_s1.csv", 1, {}, io::kKindCalibration}), doctest::Contains("a range within 0.2% of its value"),
                       Error);
}

TEST_CASE("import: the frame rate comes from --rate or the glove description, and the two must agree") {
  const Frames f = random_frames(4, 2);
  const std::string take = csv(f, all_columns({}), [](const std::string&, std::size_t) { return std::string(); });
  grid::GloveSettings settings;
  settings.rate_hz = 25.0;
  const grid::GloveDescription five = small_glove();
  const grid::GloveDescription described(five.id(), five.cell_names(), five.map(), settings);
  train::RecordingImporter importer(described, options(0.0));  // no rate given: the description's
  std::istringstream in(take);
  importer.add(in, {"t.csv", 1, {}, io::kKindRecording});
  CHECK(importer.dataset().frame_rate() == 25.0);
  CHECK(importer.dataset().timestamps[1] == doctest::Approx(1.0 / 25.0).epsilon(1e-12));
  CHECK(train::RecordingImporter(described, options(25.0)).dataset().frame_rate() == 25.0);
  CHECK_THROWS_WITH_AS(train::RecordingImporter(described, options(20.0)),
                       doctest::Contains("frame rate 20, but glove 'five-cell' is described at 25 frames per second"), Error);
  CHECK_THROWS_WITH_AS(train::RecordingImporter(five, options(0.0)), doctest::Contains("(or a glove description with 'rate_hz')"), Error);
}

TEST_CASE("import: bad takes are refused naming the file, line and column and what was expected") {
  const Frames f = random_frames(3, 5);
  const auto none = [](const std::string& column, std::size_t i) -> std::string {
    return column == "timestamp" ? text(0.1 * static_cast<double>(i)) : "0";
  };
  const std::string good = csv(f, all_columns({"subject", "timestamp"}), none);
  const train::CsvTake take{"t.csv", {}, {}, {}};
  const auto replace = [&](std::string text, const std::string& from, const std::string& to) {
    const std::size_t at = text.find(from);
    REQUIRE(at != std::string::npos);
    return text.replace(at, from.size(), to);
  };
  const std::string header = good.substr(0, good.find('\n'));

  CHECK(import_error("", take) ==
        "CSV file 't.csv', line 1: no header, expected the column names (the glove's cells, optionally the 25 DoFs, "
        "subject, session, glove, kind, timestamp)");
  CHECK(import_error(header + "\n", take) == "CSV file 't.csv': no frames after the header, expected at least one row of readings");
  CHECK(import_error(replace(good, "ring_bend,", ""), take)
            .find("CSV file 't.csv', line 1: no column 'ring_bend', expected one column per cell") == 0);
  CHECK(import_error(replace(good, "ring_bend", "ring_bent"), take)
            .find("CSV file 't.csv', line 1, column 6 'ring_bent': unknown column, expected a cell of glove 'five-cell'") == 0);
  CHECK(import_error(replace(good, "ring_bend", "thumb_bend"), take)
            .find("CSV file 't.csv', line 1, column 6 'thumb_bend': named like column 3, expected each column once") == 0);
  CHECK(import_error(replace(good, "subject,", "session,"), take) ==
        "CSV file 't.csv', line 1: no 'subject' column and no subject given for the file, expected one of them");

  // Line 3 (the second frame): its third field is the thumb cell.
  const std::size_t line3 = good.find('\n', good.find('\n') + 1) + 1;
  std::string bad = good;
  const std::size_t third = bad.find(',', bad.find(',', line3) + 1) + 1;
  bad.replace(third, bad.find(',', third) - third, "1.5pF");
  CHECK(import_error(bad, take) == "CSV file 't.csv', line 3, column 'thumb_bend': '1.5pF' is not a number");
  bad = good;
  bad.replace(third, bad.find(',', third) - third, "nan");
  CHECK(import_error(bad, take) == "CSV file 't.csv', line 3, column 'thumb_bend': 'nan' is not a finite number");
  bad = good;
  bad.replace(line3, bad.find(',', line3) - line3, "-1");
  CHECK(import_error(bad, take) == "CSV file 't.csv', line 3, column 'subject': '-1' is not a non-negative integer");
  bad = good;
  bad.insert(good.find('\n', line3), ",7");
  CHECK(import_error(bad, take) == "CSV file 't.csv', line 3: 33 fields, expected 32 (one per column of line 1)");
  bad = good;
  const std::size_t time3 = bad.find(',', line3) + 1;
  bad.replace(time3, bad.find(',', time3) - time3, "0");
  CHECK(import_error(bad, take).find("CSV file 't.csv', line 3: time 0 s is not after the frame before (0 s) of subject 0, session 0") ==
        0);
  bad = good;
  bad.replace(time3, bad.find(',', time3) - time3, "14:03:07.250");  // a logger's time of day
  CHECK(import_error(bad, take).find("CSV file 't.csv', line 3, column 'timestamp': '14:03:07.250' is a time of day, expected a number of "
                                     "seconds") == 0);
  CHECK(import_error(bad, take).find("`glovepose import --ignore COLUMN`") != std::string::npos);
  CHECK(import_error(replace(replace(good, "subject", "kind"), "\n0,", "\nwarmup,"), {"t.csv", 1, {}, {}}) ==
        "CSV file 't.csv', line 2, column 'kind': 'warmup' is not a kind, expected recording, calibration, 0 or 1");
  CHECK(import_error(replace(good, "subject,timestamp", "subject,timestamp,timestamp_ms"), take)
            .find("line 1: both timestamp and timestamp_ms") != std::string::npos);

  // Takes must agree on angles; a failed take leaves the frames of the ones before.
  train::RecordingImporter importer(small_glove(), options());
  std::istringstream first(good);
  importer.add(first, take);
  const std::string no_angles =
      csv(f, {"subject", "timestamp", "thumb_bend", "index_bend", "middle_bend", "ring_bend", "pinky_bend"}, none);
  std::istringstream second(no_angles);
  CHECK_THROWS_WITH_AS(importer.add(second, {"u.csv", {}, {}, {}}),
                       "CSV file 'u.csv', line 1: has no DoF columns, expected the DoFs as the recording takes before it (a "
                       "calibration take, given with --calibration or kind calibration, may be sensors only; recording takes all carry "
                       "the reference or none do)",
                       Error);
  CHECK(importer.dataset().frames() == 3);
  std::istringstream third_take(good);  // same subject and session, times from 0 again: not after the last frame
  CHECK_THROWS_WITH_AS(importer.add(third_take, take),
                       "CSV file 't.csv', line 2: time 0 s is not after the frame before (0.2 s) of subject 0, session 0, "
                       "expected increasing times within a run (give each take its own session id)",
                       Error);
  CHECK(importer.dataset().frames() == 3);
  importer.dataset().validate();

  CHECK_THROWS_WITH_AS(train::RecordingImporter(small_glove(), options(0.0)),
                       doctest::Contains("frame rate 0, expected a positive number of frames per second"), Error);
  train::CsvImportOptions ignoring = options();
  ignoring.ignored_columns = {"index_bend"};
  CHECK_THROWS_AS(train::RecordingImporter(small_glove(), ignoring), Error);
  CHECK_THROWS_WITH_AS(train::RecordingImporter(small_glove(), options()).add({"/no/such/file.csv", 0, {}, {}}),
                       "CSV file '/no/such/file.csv': cannot open, expected a readable file", Error);
}

TEST_CASE("import: a calibration take may be sensors only, before or after the labelled takes of its session") {
  const Frames calibration = random_frames(40, 31), recording = random_frames(60, 32);
  const auto none = [](const std::string&, std::size_t) { return std::string("4"); };
  const std::string sensors = csv(calibration, {"subject", "thumb_bend", "index_bend", "middle_bend", "ring_bend", "pinky_bend"}, none);
  const std::string labelled = csv(recording, all_columns({"subject"}), none);
  const train::CsvTake calibration_take{"cal.csv", {}, 2, io::kKindCalibration};
  const train::CsvTake recording_take{"rec.csv", {}, 2, io::kKindRecording};
  for (const bool calibration_first : {true, false}) {
    CAPTURE(calibration_first);
    train::RecordingImporter importer(small_glove(), options());
    std::istringstream a(calibration_first ? sensors : labelled), b(calibration_first ? labelled : sensors);
    importer.add(a, calibration_first ? calibration_take : recording_take);
    importer.add(b, calibration_first ? recording_take : calibration_take);
    importer.finish();
    const io::Dataset& data = importer.dataset();
    REQUIRE(data.frames() == 100);
    CHECK(data.labelled_dofs() == hand::all_dofs());
    std::size_t recorded = 0;
    for (std::size_t i = 0; i < data.frames(); ++i) {
      const bool calibrating = data.kind[i] == io::kKindCalibration;
      for (std::size_t d = 0; d < hand::kDofCount; ++d) {
        const float angle = data.angles[i * hand::kDofCount + d];
        if (calibrating) {
          CHECK(std::isnan(angle));  // no reference in the calibration take
        } else {
          CHECK(angle == recording.angles[recorded * hand::kDofCount + d]);
        }
      }
      recorded += !calibrating;
    }
    CHECK(recorded == 60);
    data.validate();
    // It calibrates its session on the fly, as a labelled calibration take would.
    const train::Samples samples =
        train::make_samples(data, {}, model::CalibrationMode::OnTheFly, nullptr, hand::JointLimits(), 1, small_glove().calibration());
    CHECK(samples.frames() == 60);
  }
  // A recording take must carry the reference when the others do.
  train::RecordingImporter importer(small_glove(), options());
  std::istringstream first(labelled), second(sensors);
  importer.add(first, recording_take);
  CHECK_THROWS_WITH_AS(importer.add(second, {"rec2.csv", {}, 3, io::kKindRecording}),
                       doctest::Contains("has no DoF columns, expected the DoFs as the recording takes before it"), Error);
  // A labelled dataset's calibration frame has NaN angles only when it has none at all.
  io::Dataset data = importer.dataset();
  data.angles[0] = NAN;
  CHECK_THROWS_WITH_AS(data.validate(), doctest::Contains("expected a finite angle"), Error);
}

TEST_CASE("import: a take labelling some DoFs: the others are NaN and not labelled, and every take must label the same") {
  const Frames f = random_frames(4, 6);
  std::vector<std::string> columns = all_columns({"subject"});
  const auto dropped = [](const std::string& name) { return name == "thumb_base_abduction" || name == "pinky_base_twist"; };
  columns.erase(std::remove_if(columns.begin(), columns.end(), dropped), columns.end());
  const std::string take = csv(f, columns, [](const std::string&, std::size_t) { return std::string("1"); });
  train::RecordingImporter importer(small_glove(), options());
  std::istringstream in(take);
  importer.add(in, {"part.csv", {}, {}, {}});
  const io::Dataset& data = importer.dataset();
  data.validate();
  hand::DofSet expected = hand::all_dofs();
  expected[hand::dof_from_name("thumb_base_abduction")] = expected[hand::dof_from_name("pinky_base_twist")] = false;
  CHECK(data.labelled_dofs() == expected);
  for (std::size_t i = 0; i < f.angles.size(); ++i) {
    CAPTURE(i);
    if (expected[i % hand::kDofCount])
      CHECK(data.angles[i] == f.angles[i]);
    else
      CHECK(std::isnan(data.angles[i]));
  }
  const std::string other = csv(f, all_columns({"subject"}), [](const std::string&, std::size_t) { return std::string("2"); });
  std::istringstream second(other);
  CHECK_THROWS_WITH_AS(importer.add(second, {"all.csv", {}, {}, {}}),
                       doctest::Contains("CSV file 'all.csv', line 1: DoF columns thumb_base_abduction,"), Error);
  CHECK(importer.dataset().frames() == 4);
}

TEST_CASE("import: --ignore patterns match as POSIX fnmatch does and never skip a cell or DoF column") {
  CHECK(io::column_matches("AccX", "Acc?"));
  CHECK(!io::column_matches("AccXY", "Acc?"));
  CHECK(io::column_matches("Q0", "Q*"));
  CHECK(io::column_matches("", "*"));
  CHECK(!io::column_matches("P10", "P1"));
#if __has_include(<fnmatch.h>)
  // The matcher against the C library's fnmatch (no brackets, no escapes: '*' and '?' only).
  std::mt19937 rng(3);
  const std::string alphabet = "ab*?";
  for (int i = 0; i < 20000; ++i) {
    std::string name, pattern;
    for (int k = static_cast<int>(rng() % 7); k > 0; --k) name += "ab"[rng() % 2];
    for (int k = static_cast<int>(rng() % 6); k > 0; --k) pattern += alphabet[rng() % alphabet.size()];
    CAPTURE(name);
    CAPTURE(pattern);
    CHECK(io::column_matches(name, pattern) == (fnmatch(pattern.c_str(), name.c_str(), 0) == 0));
  }
#endif
  // A logger's extra columns skipped by pattern; "*_bend" would match every cell, which stays read.
  train::CsvImportOptions o = options();
  o.ignored_columns = {"Acc?", "Q*", "*_bend", "Status"};
  train::RecordingImporter importer(small_glove(), o);
  std::istringstream in(
      "subject,AccX,AccY,thumb_bend,index_bend,middle_bend,ring_bend,pinky_bend,Q0,Qw,Status\n"
      "0,1,2,1.5,1.6,1.7,1.8,1.9,0.1,0.2,ok\n");
  importer.add(in, {"logger.csv", {}, {}, {}});
  const std::vector<float> cells(importer.dataset().cells.begin(), importer.dataset().cells.end());
  CHECK(cells == std::vector<float>{1.5f, 1.6f, 1.7f, 1.8f, 1.9f});
  std::istringstream unknown("subject,AccXY,thumb_bend,index_bend,middle_bend,ring_bend,pinky_bend\n0,1,1,1,1,1,1\n");
  CHECK_THROWS_WITH_AS(importer.add(unknown, {"logger2.csv", {}, {}, {}}), doctest::Contains("column 2 'AccXY': unknown column"), Error);
}
