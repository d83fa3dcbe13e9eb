// `glovepose import` with a hand tracker's keypoints instead of angles: keypoint columns in a take
// and a keypoint file on the tracker's own clock become labels close to the simulated truth, and
// every kind of bad keypoint input is refused naming the file, line and column, nothing written.
#include <doctest/doctest.h>

#include <glovepose/sim/corpus.hpp>
#include <glovepose/sim/keypoint_tracker.hpp>
#include <glovepose/train/keypoint_columns.hpp>
#include <glovepose/train/metrics.hpp>
#include <glovepose/train/recording_import.hpp>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

using namespace glovepose;

namespace {

const std::filesystem::path kTmp = std::filesystem::path(GLOVEPOSE_TEST_TMP_DIR) / "keypoint_import";

// A simulated session of the built-in glove and the keypoints a tracker saw of it.
struct Take {
  sim::Recording rec;
  train::KeypointTrack track;
  hand::KeypointLayout layout;

  Take(std::uint64_t seed, hand::KeypointLayout layout_, double offset, double rate_hz) : layout(layout_) {
    sim::CorpusConfig c;
    c.subjects = 1;
    c.sessions = 1;
    c.intra_sessions = 1;
    c.minutes = 40.0 / 60.0;
    c.calibration_seconds = 0.0;
    c.seed = seed;
    c.world = sim::worlds().front();  // clean: the truth is the reference
    const sim::CorpusWorld world(c);
    const sim::SessionRecording job = sim::plan_corpus(c).front();
    const sim::SessionSetup setup = sim::setup_session(c, world, job);
    rec = setup.record(world.subjects[0].distal_radius(), c, c.recording);
    sim::KeypointTrackerConfig tracker;
    tracker.layout = layout;
    tracker.rate_hz = rate_hz;
    tracker.offset_seconds = offset;
    const hand::Kinematics person(world.subjects[0].hand_model());
    if (rate_hz > 0) {
      track = sim::track_keypoints(person, setup.motion, 0.0, rec.timestamps.back(), tracker, seed + 1);
    } else {  // a 60 Hz tracker's latest frame `offset` before each glove row (a recorder that paired them)
      tracker.rate_hz = 60.0;
      tracker.offset_seconds = 0.0;
      const train::KeypointTrack tracked = sim::track_keypoints(person, setup.motion, 0.0, rec.timestamps.back(), tracker, seed + 1);
      std::size_t latest = 0;
      for (double t : rec.timestamps) {
        while (latest + 1 < tracked.times.size() && tracked.times[latest + 1] <= t - offset) ++latest;
        track.times.push_back(t);
        track.points.insert(track.points.end(), tracked.points.begin() + static_cast<std::ptrdiff_t>(latest * count()),
                            tracked.points.begin() + static_cast<std::ptrdiff_t>((latest + 1) * count()));
      }
    }
  }

  std::size_t count() const { return hand::keypoint_count(layout); }
  std::string keypoint_header() const {
    std::string out;
    for (std::size_t k = 0; k < count(); ++k)
      for (const char* axis : {"_x", "_y", "_z"}) out += std::string(",") + hand::keypoint_name(layout, k) + axis;
    return out;
  }
  std::string keypoint_fields(std::size_t f, double unit) const {
    std::string out;
    char number[32];
    for (std::size_t k = 0; k < count(); ++k)
      for (int a = 0; a < 3; ++a) {
        std::snprintf(number, sizeof number, ",%.6f", track.points[f * count() + k][a] / unit);
        out += number;
      }
    return out;
  }
  // The glove's take: timestamp, the 44 cells, and (with_keypoints) a keypoint per glove frame.
  std::string glove_csv(bool with_keypoints, double unit = 1000.0) const {
    std::string out = "timestamp";
    const grid::GloveDescription glove = grid::GloveDescription::glauser2019();
    for (const std::string& name : glove.cell_names()) out += "," + name;
    if (with_keypoints) out += keypoint_header();
    out += "\n";
    char number[32];
    for (std::size_t f = 0; f < rec.timestamps.size(); ++f) {
      std::snprintf(number, sizeof number, "%.6f", rec.timestamps[f]);
      out += number;
      for (std::size_t c = 0; c < 44; ++c) {
        std::snprintf(number, sizeof number, ",%.6g", static_cast<double>(rec.cells[f * 44 + c]));
        out += number;
      }
      if (with_keypoints) out += keypoint_fields(f, unit);
      out += "\n";
    }
    return out;
  }
  std::string keypoint_csv(double unit = 1000.0) const {
    std::string out = "timestamp" + keypoint_header() + "\n";
    char number[32];
    for (std::size_t f = 0; f < track.times.size(); ++f) {
      std::snprintf(number, sizeof number, "%.6f", track.times[f]);
      out += number + keypoint_fields(f, unit) + "\n";
    }
    return out;
  }
  // Mean error (degrees) of the labels of frames not flagged against the truth, and their share.
  std::pair<double, double> error(const io::Dataset& data) const {
    double sum = 0.0;
    std::size_t n = 0, kept = 0;
    for (std::size_t f = 0; f < data.frames(); ++f) {
      if (data.outlier[f]) continue;
      ++kept;
      for (std::size_t d = 0; d < hand::kDofCount; ++d) {
        sum += std::abs(data.angles[f * hand::kDofCount + d] - rec.angles[f * hand::kDofCount + d]);
        ++n;
      }
    }
    return {sum / static_cast<double>(n) * core::kDegreesPerRadian, static_cast<double>(kept) / static_cast<double>(data.frames())};
  }
};

std::string write(const std::string& name, const std::string& text) {
  std::filesystem::create_directories(kTmp);
  const std::string path = (kTmp / name).string();
  std::ofstream(path) << text;
  return path;
}

train::RecordingImporter importer(double scale = 1000.0) {
  train::CsvImportOptions options;
  options.frame_rate = 60.0;
  options.keypoint_scale = scale;
  return train::RecordingImporter(grid::GloveDescription::glauser2019(), options);
}

}  // namespace

TEST_CASE("import: keypoint columns in a take become labels near the truth, on the take's own clock") {
  const Take take(41, hand::KeypointLayout::MediaPipe, 0.0, 0.0);  // the recorder paired each row with the tracker's latest frame
  train::RecordingImporter in = importer();
  std::istringstream csv(take.glove_csv(true));
  in.add(csv, {"take.csv", 0, {}, {}});
  in.finish();
  const io::Dataset& data = in.dataset();
  data.validate();
  CHECK(data.labelled_dofs() == hand::all_dofs());
  REQUIRE(in.keypoint_takes().size() == 1);
  REQUIRE(in.keypoint_subjects().size() == 1);
  const train::KeypointTakeReport& report = in.keypoint_takes()[0];
  const auto [mean, kept] = take.error(data);
  MESSAGE("keypoint columns: " << mean << " deg against the truth, " << kept * 100 << "% labelled, offset " << report.clock.offset
                               << " s, residual median " << report.median_rms_mm << " mm");
  CHECK(mean < 3.5);
  CHECK(kept > 0.95);
  // Keypoints in the take's rows share its clock: no search (a search finds the glove's response
  // lag, tens of ms, and unlabels the first frames).
  CHECK(report.clock.offset == 0.0);
  CHECK(std::isnan(report.clock.correlation));
  CHECK(report.median_rms_mm == doctest::Approx(in.keypoint_subjects()[0].noise_mm * 0.82).epsilon(0.15));
  // A right hand: the keypoints mirrored fit a hand much worse.
  const train::KeypointSubjectReport& hand = in.keypoint_subjects()[0];
  MESSAGE("fit residual as given " << hand.fit_mm << " mm, mirrored " << hand.mirrored_fit_mm << " mm");
  CHECK(hand.fit_mm == doctest::Approx(report.median_rms_mm).epsilon(0.3));
  CHECK(!(hand.mirrored_fit_mm < 1.5 * hand.fit_mm));
  CHECK(in.warnings().empty());

  // The same keypoints mirrored (a left hand's, or a tracker's mirrored frame) are refused, both fits named.
  Take mirrored = take;
  for (Eigen::Vector3d& p : mirrored.track.points) p.x() = -p.x();
  train::RecordingImporter left = importer();
  std::istringstream left_csv(mirrored.glove_csv(true));
  left.add(left_csv, {"left.csv", 0, {}, {}});
  CHECK_THROWS_WITH_AS(left.finish(), doctest::Contains("keypoints of subject 0 ('left.csv') fit a left hand, not a right one: median fit residual "),
                       Error);
  CHECK_THROWS_WITH_AS(left.finish(), doctest::Contains(" mm mirrored; expected a right hand's keypoints"), Error);
}

TEST_CASE("import: a keypoint file on the tracker's clock, the offset given or found") {
  const Take take(42, hand::KeypointLayout::OpenXr, -1.3, 45.0);
  const std::string glove = write("glove.csv", take.glove_csv(false));
  const std::string keypoints = write("glove_keypoints.csv", take.keypoint_csv(10.0));  // centimetres
  double found = 0.0;
  for (const bool given : {false, true}) {
    train::CsvImportOptions options;
    options.frame_rate = 60.0;
    options.keypoint_scale = 10.0;
    if (given) options.keypoint_labels.offset = found;
    train::RecordingImporter in(grid::GloveDescription::glauser2019(), options);
    train::CsvTake csv_take{glove, 3, 1, {}};
    csv_take.keypoints = keypoints;
    in.add(csv_take);
    in.finish();
    const auto [mean, kept] = take.error(in.dataset());
    const train::ClockAlignment& clock = in.keypoint_takes()[0].clock;
    MESSAGE("keypoint file (" << (given ? "offset given" : "offset found") << "): " << mean << " deg, " << kept * 100 << "%, offset "
                              << clock.offset << " s");
    CHECK(mean < 3.5);
    CHECK(kept > 0.95);
    CHECK(clock.offset == doctest::Approx(-1.3 + 0.05).epsilon(0.05));
    CHECK(std::isnan(clock.correlation) == given);
    found = clock.offset;
  }
}

TEST_CASE("import: bad keypoints are refused naming the file, line and column") {
  const Take take(43, hand::KeypointLayout::MediaPipe, 0.0, 0.0);
  const auto refused = [](const std::string& text, const std::string& message, double scale = 1000.0) {
    train::RecordingImporter in = importer(scale);
    std::istringstream csv(text);
    CHECK_THROWS_WITH_AS(
        {
          in.add(csv, {"bad.csv", 0, {}, {}});
          in.finish();
        },
        doctest::Contains(message.c_str()), Error);
  };
  const std::string good = take.glove_csv(true);
  const std::size_t header_end = good.find('\n');
  // A keypoint with two of its three columns.
  std::string two = good;
  two.replace(two.find(",wrist_z"), 8, ",wrist_q");
  refused(two, "keypoint 'wrist' has 2 of its columns, expected wrist_x, _y and _z");
  // A row with a coordinate missing: the line and keypoint named.
  std::string hole = good;
  const std::size_t line3 = hole.find('\n', hole.find('\n', header_end + 1) + 1) + 1;
  const std::size_t last_comma = hole.find('\n', line3) - 1;
  hole.erase(hole.rfind(',', last_comma) + 1, last_comma - hole.rfind(',', last_comma));
  refused(hole, "bad.csv', line 4: keypoint 'pinky_tip' has 2 of its 3 coordinates");
  // Not a number.
  std::string word = good;
  word.replace(word.rfind(',', word.find('\n', header_end + 1)) + 1, 3, "abc");
  refused(word, "line 2, column 'pinky_tip_z'");
  // Keypoints in millimetres read as metres: a hand a thousand times too large, and the unit named.
  refused(take.glove_csv(true, 1.0), "keypoints of subject 0 ('bad.csv'), hand shape:");
  refused(take.glove_csv(true, 1.0), "(keypoint unit: 1000 mm; `glovepose import --keypoint-unit`)");
  // In metres read as millimetres: bones of a few hundredths of a millimetre.
  refused(take.glove_csv(true, 1e6), "mm long, expected 3-150 mm");
  // Angles and keypoints in one take.
  std::string both = good;
  both.insert(header_end, ",index_base_flexion");
  for (std::size_t at = both.find('\n', header_end + 20); at != std::string::npos; at = both.find('\n', at + 5)) both.insert(at, ",0.5");
  refused(both, "DoF columns and keypoints");
  // Two layouts.
  std::string mixed = good;
  mixed.replace(mixed.find("index_finger_tip_x"), 18, "index_tip_x");
  refused(mixed, "keypoint columns of two layouts");
  // A tracker that never saw the hand.
  std::string unseen = good.substr(0, header_end + 1);
  for (std::size_t at = header_end + 1; at < good.size();) {
    const std::size_t end = good.find('\n', at);
    const std::string row = good.substr(at, end - at);
    std::size_t comma = row.size();
    for (std::size_t k = 0; k < 63; ++k) comma = row.rfind(',', comma - 1);
    unseen += row.substr(0, comma);
    for (std::size_t k = 0; k < 63; ++k) unseen += ",nan";
    unseen += "\n";
    at = end + 1;
  }
  refused(unseen, "frames show three or more of the 6 palm keypoints");
  // Keypoints of another session: the clocks cannot be aligned.
  const Take other(44, hand::KeypointLayout::MediaPipe, 0.0, 30.0);
  const std::string glove = write("foreign.csv", take.glove_csv(false));
  const std::string keypoints = write("foreign_keypoints.csv", other.keypoint_csv());
  train::RecordingImporter in = importer();
  train::CsvTake foreign{glove, 0, {}, {}};
  foreign.keypoints = keypoints;
  in.add(foreign);
  CHECK_THROWS_WITH_AS(in.finish(), doctest::Contains("foreign_keypoints.csv'"), Error);
  CHECK_THROWS_WITH_AS(in.finish(), doctest::Contains("clock alignment"), Error);
  // A keypoint file without times.
  std::istringstream no_times("wrist_x,wrist_y,wrist_z\n1,2,3\n");
  CHECK_THROWS_WITH_AS(train::read_keypoint_file(no_times, "k.csv", 1000.0, {}), doctest::Contains("k.csv', line 1: no timestamp"), Error);
}

TEST_CASE("import: timestamps that contradict the frame rate are reported") {
  train::CsvImportOptions options;
  options.frame_rate = 60.0;
  const grid::GloveDescription glove = grid::GloveDescription::glauser2019();
  train::RecordingImporter in(glove, options);
  std::string csv = "timestamp";
  for (const std::string& name : glove.cell_names()) csv += "," + name;
  csv += "\n";
  for (int f = 0; f < 20; ++f) {
    csv += std::to_string(0.1 * f);  // 10 frames per second
    for (int c = 0; c < 44; ++c) csv += "," + std::to_string(1.0 + 0.01 * ((f * 7 + c) % 11));
    csv += "\n";
  }
  std::istringstream ten_hz(csv);
  in.add(ten_hz, {"ten_hz.csv", 0, {}, {}});
  REQUIRE(in.warnings().size() == 1);
  MESSAGE(in.warnings()[0]);
  CHECK(in.warnings()[0].find("ten_hz.csv': its timestamps are 10 frames per second, the dataset's rate is 60") != std::string::npos);
}

#ifdef GLOVEPOSE_CLI
TEST_CASE("glovepose import: keypoints it cannot use leave no dataset file") {
  const Take take(45, hand::KeypointLayout::MediaPipe, 0.0, 0.0);
  const std::string csv = write("mm_as_m.csv", take.glove_csv(true, 1.0));
  const std::string out = (kTmp / "never.safetensors").string();
  std::filesystem::remove(out);
  const std::string command = std::string(GLOVEPOSE_CLI) + " import --rate 60 --subject 0 --out " + out + " " + csv + " 2> " + (kTmp / "err.txt").string();
  CHECK(std::system(command.c_str()) != 0);
  CHECK(!std::filesystem::exists(out));
  std::ifstream err(kTmp / "err.txt");
  const std::string message((std::istreambuf_iterator<char>(err)), std::istreambuf_iterator<char>());
  CHECK(message.find("mm_as_m.csv") != std::string::npos);
  CHECK(message.find("--keypoint-unit") != std::string::npos);
}
#endif
