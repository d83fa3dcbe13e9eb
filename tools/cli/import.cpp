// glovepose import: recordings of any glove as CSV files with named columns (train/recording_import.hpp), or
//   as wire recordings (glovepose record; wire_take.hpp), into one dataset file for train, eval and finetune.
#include <glovepose/io/atomic_file.hpp>
#include <glovepose/train/recording_import.hpp>
#include <glovepose/train/samples.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "commands.hpp"
#include "wire_take.hpp"

namespace glovepose::cli {
namespace {

struct ImportOptions {
  std::vector<std::string> recordings, calibrations;  // FILE... and --calibration FILE
  std::string out, glove, takes_list, keypoint_report;
  std::optional<std::int32_t> subject, session;
  std::string keypoint_unit = "m";
  std::optional<double> keypoint_offset;
  train::CsvImportOptions import;
  const CLI::App* command = nullptr;
  const CLI::Option* recordings_option = nullptr;
  const CLI::Option* calibrations_option = nullptr;

  // The takes named on the command line, recordings and calibrations in the order given.
  std::vector<train::CsvTake> command_line_takes() const {
    std::vector<train::CsvTake> takes;
    std::size_t next_recording = 0, next_calibration = 0;
    for (const CLI::Option* given : command->parse_order()) {
      if (given == recordings_option)
        takes.push_back({recordings[next_recording++], subject, session, io::kKindRecording});
      else if (given == calibrations_option)
        takes.push_back({calibrations[next_calibration++], subject, session, io::kKindCalibration});
    }
    return takes;
  }
};

// The takes of a list file: header file,subject[,session][,kind][,keypoints], one take per line.
std::vector<train::CsvTake> read_takes_list(const std::string& path) {
  const std::string at = "takes list '" + path + "'";
  std::ifstream in(path);
  if (!in) throw Error(at + ": cannot open, expected a readable file");
  std::string line;
  if (!std::getline(in, line) || io::blank_csv_line(line)) throw Error(at + ", line 1: no header, expected file,subject,session,kind");
  const std::vector<std::string> header = io::split_csv_line(line);
  const std::vector<std::string> known{"file", "subject", "session", "kind", "keypoints"};
  std::vector<int> column(known.size(), -1);
  for (std::size_t k = 0; k < header.size(); ++k) {
    const auto it = std::find(known.begin(), known.end(), header[k]);
    if (it == known.end() || column[static_cast<std::size_t>(it - known.begin())] >= 0)
      throw Error(at + ", line 1, column " + std::to_string(k + 1) + " '" + header[k] + "': " +
                  (it == known.end() ? "unknown column" : "a second time") +
                  ", expected file, subject, session, kind and keypoints once each");
    column[static_cast<std::size_t>(it - known.begin())] = static_cast<int>(k);
  }
  if (column[0] < 0 || column[1] < 0) throw Error(at + ", line 1: expected at least the columns file and subject");
  const std::filesystem::path folder = std::filesystem::path(path).parent_path();
  std::vector<train::CsvTake> takes;
  for (std::size_t line_no = 2; std::getline(in, line); ++line_no) {
    if (io::blank_csv_line(line)) continue;
    const std::vector<std::string> fields = io::split_csv_line(line);
    const std::string at_line = at + ", line " + std::to_string(line_no);
    if (fields.size() != header.size())
      throw Error(at_line + ": " + std::to_string(fields.size()) + " fields, expected " + std::to_string(header.size()));
    const auto field = [&](std::size_t which) { return fields[static_cast<std::size_t>(column[which])]; };
    const auto where = [&](std::size_t which) { return at_line + ", column '" + known[which] + "': '" + field(which) + "'"; };
    train::CsvTake take;
    const std::filesystem::path file = field(0);
    if (field(0).empty()) throw Error(at_line + ", column 'file': empty, expected a CSV file");
    take.path = (file.is_absolute() ? file : folder / file).string();
    take.subject = io::parse_csv_id(field(1), where(1));
    if (column[2] >= 0) take.session = io::parse_csv_id(field(2), where(2));
    take.kind = io::kKindRecording;
    if (column[3] >= 0 && field(3) == "calibration")
      take.kind = io::kKindCalibration;
    else if (column[3] >= 0 && field(3) != "recording")
      throw Error(where(3) + " is not a kind, expected recording or calibration");
    if (column[4] >= 0 && !field(4).empty()) {
      const std::filesystem::path keypoints = field(4);
      take.keypoints = (keypoints.is_absolute() ? keypoints : folder / keypoints).string();
    }
    takes.push_back(take);
  }
  if (takes.empty()) throw Error(at + ": no takes after the header, expected one line per CSV file");
  return takes;
}

std::string angles_text(const io::Dataset& data) {
  if (!data.has_angles()) return "without angles";
  const hand::DofSet labelled = data.labelled_dofs();
  const auto count = std::count(labelled.begin(), labelled.end(), true);
  return count == static_cast<long>(hand::kDofCount) ? "with the 25 DoF angles"
                                                     : "with angles for " + std::to_string(count) + " of the 25 DoFs";
}

int import_recordings(const ImportOptions& o) {
  std::vector<train::CsvTake> takes = o.command_line_takes();
  if (takes.empty() && o.takes_list.empty()) throw CLI::ValidationError("no takes, expected CSV files or --takes LIST");
  if (!o.takes_list.empty())
    for (train::CsvTake& take : read_takes_list(o.takes_list)) takes.push_back(std::move(take));
  grid::GloveDescription glove = o.glove.empty() ? grid::GloveDescription::glauser2019() : grid::GloveDescription::read(o.glove);
  train::CsvImportOptions options = o.import;
  options.keypoint_scale = o.keypoint_unit == "m" ? 1000.0 : o.keypoint_unit == "cm" ? 10.0 : 1.0;
  options.keypoint_labels.offset = o.keypoint_offset;
  train::RecordingImporter importer(glove, options);
  for (const train::CsvTake& take : takes) {
    if (const std::optional<std::string> csv = wire_take_as_csv(take.path, glove)) {  // a wire recording (glovepose record)
      std::istringstream in(*csv);
      importer.add(in, take);
    } else {
      importer.add(take);
    }
  }
  importer.finish();
  const io::Dataset& data = importer.dataset();
  data.write(o.out);

  std::set<std::int32_t> subjects(data.subject.begin(), data.subject.end());
  std::set<std::pair<std::int32_t, std::int32_t>> sessions;
  std::size_t calibration = 0;
  for (std::size_t i = 0; i < data.frames(); ++i) {
    sessions.insert({data.subject[i], data.session[i]});
    calibration += data.kind[i] == io::kKindCalibration;
  }
  std::printf("imported %zu takes: %zu frames (%zu calibration) of %zu subjects, %zu sessions, glove '%s', %zu cells, %s\n", takes.size(),
              data.frames(), calibration, subjects.size(), sessions.size(), data.glove_layout().c_str(), data.cell_count,
              angles_text(data).c_str());
  // What calibration each session carries: on-the-fly calibration (train's default) needs one.
  std::map<std::int64_t, std::pair<std::size_t, std::size_t>> runs;  // recording and calibration frames per run
  for (std::size_t i = 0; i < data.frames(); ++i) {
    auto& [recorded, calibrating] = runs[train::run_key(data, i)];
    ++(data.kind[i] == io::kKindCalibration ? calibrating : recorded);
  }
  std::string without;
  std::size_t missing = 0, recorded_runs = 0;
  for (const auto& [key, count] : runs) {
    if (count.first == 0) continue;
    ++recorded_runs;
    if (count.second > 0) continue;
    if (missing++ < 4) without += std::string(without.empty() ? "" : "; ") + train::RunId::of(key).text();
  }
  if (missing > 4) without += "; ...";
  if (missing == 0)
    std::printf("calibration: every session has its calibration take, as on-the-fly calibration (train's default) needs\n");
  else
    std::printf("calibration: %zu of %zu sessions have no calibration take (%s): train and eval them with --calibration-mode training "
                "(the training frames' range) or none, or import each with its calibration take (--calibration FILE, the same "
                "subject and session)\n",
                missing, recorded_runs, without.c_str());
  for (const train::FlatSensor& flat : importer.flat_sensors())
    std::printf("flat sensor kept: '%s' in calibration lines %zu-%zu of '%s' (%.9g to %.9g); calibrated, it reads 0\n", flat.cell.c_str(),
                flat.first_line, flat.last_line, flat.path.c_str(), flat.min, flat.max);
  for (const train::KeypointSubjectReport& hand : importer.keypoint_subjects())
    std::printf("subject %d's hand from keypoints: %.0f mm from wrist to middle fingertip, keypoint noise %.1f mm (3D RMS); a right hand "
                "(median fit residual %.1f mm, %.1f mm as a left one)\n",
                hand.subject, hand.hand_length_mm, hand.noise_mm, hand.fit_mm, hand.mirrored_fit_mm);
  for (const train::KeypointTakeReport& take : importer.keypoint_takes()) {
    const std::string clock = std::isfinite(take.clock.correlation)
                                  ? "found by motion (correlation " + io::number_text(std::round(take.clock.correlation * 100) / 100) + ")"
                              : take.keypoint_file.empty() && !o.keypoint_offset ? "(the keypoints share the take's rows and clock)"
                                                                                 : "given";
    const std::string source = take.keypoint_file.empty() ? take.path : take.path + " with '" + take.keypoint_file + "'";
    std::size_t pinned = 0;  // the DoF most often at a joint limit
    for (std::size_t d = 1; d < hand::kDofCount; ++d)
      if (take.at_limit[d] > take.at_limit[pinned] || std::isnan(take.at_limit[pinned])) pinned = d;
    std::printf("labels of %s (%s): %zu of %zu frames (%.1f%%), fit residual median %.1f mm, 95th %.1f mm, tracker clock offset %+.3f s %s; "
                "most at a joint limit: %s, %.0f%% of the frames\n",
                source.c_str(), hand::to_string(take.layout), take.labelled, take.frames, 100.0 * take.labelled / take.frames,
                take.median_rms_mm, take.p95_rms_mm, take.clock.offset, clock.c_str(), hand::kDofs[pinned].name,
                100.0 * take.at_limit[pinned]);
  }
  if (!o.keypoint_report.empty()) {
    io::AtomicFile file(o.keypoint_report, "--keypoint-report");
    std::ostream& report = file.stream();
    report << "take,subject,session,timestamp,residual_mm,labelled\n";
    for (const train::KeypointTakeReport& take : importer.keypoint_takes())
      for (std::size_t i = 0; i < take.frames; ++i) {
        const std::size_t f = take.first_frame + i;
        report << take.path << "," << data.subject[f] << "," << data.session[f] << "," << io::number_text(data.timestamps[f]) << ","
               << (std::isnan(take.frame_rms_mm[i]) ? std::string("nan") : io::number_text(std::round(take.frame_rms_mm[i] * 1000) / 1000))
               << "," << (data.outlier[f] ? 0 : 1) << "\n";
      }
    file.commit();
    std::printf("wrote %s: the fit residual behind every keypoint label\n", o.keypoint_report.c_str());
  }
  for (const std::string& warning : importer.warnings()) std::fprintf(stderr, "warning: %s\n", warning.c_str());
  std::printf("wrote %s\n", o.out.c_str());
  return 0;
}

}  // namespace

Command add_import(CLI::App& tool) {
  auto o = std::make_shared<ImportOptions>();
  CLI::App* command = tool.add_subcommand(
      "import", "Recordings of any glove as CSV files with named columns into one dataset file for train, eval and finetune.");
  o->command = command;
  o->recordings_option =
      command
          ->add_option("CSV", o->recordings,
                       "recording takes: CSV files whose first line names the columns: every cell of the glove, "
                       "optionally the 25 DoFs (radians) or a hand tracker's keypoints (<keypoint>_x,_y,_z of MediaPipe's or "
                       "OpenXR's names), subject, session, glove, kind, timestamp (seconds) or timestamp_ms")
          ->check(existing_file())
          ->type_name("CSV");
  o->calibrations_option =
      command->add_option("--calibration", o->calibrations, "a calibration take (its rows are calibration frames); repeatable")
          ->check(existing_file())
          ->type_name("FILE")
          ->allow_extra_args(false);
  command
      ->add_option("--takes", o->takes_list,
                   "a CSV list of takes with the header file,subject,session,kind,keypoints (kind: recording or "
                   "calibration; keypoints: the take's hand-tracker keypoint file with its own timestamps; session, kind "
                   "and keypoints may be left out); files relative to the list")
      ->check(existing_file())
      ->type_name("LIST");
  add_number(*command, "--subject", "N", o->subject, "subject id of the CSV and --calibration takes whose columns do not have one")
      ->check(at_least(0));
  add_number(*command, "--session", "N", o->session, "session id of the CSV and --calibration takes whose columns do not have one")
      ->check(at_least(0));
  add_number(*command, "--rate", "HZ", o->import.frame_rate,
             "the glove's frames per second (frames are 1/HZ apart in takes without "
             "timestamps); required unless the glove description gives rate_hz")
      ->check(above(0.0));
  command->add_option("--glove", o->glove, "the glove description (JSON) (default: the built-in 44-cell glove)")
      ->check(existing_file())
      ->type_name("FILE");
  command->add_flag("--degrees", o->import.degrees, "angle columns are in degrees");
  command
      ->add_option("--ignore", o->import.ignored_columns, "columns to skip, comma-separated names or patterns with * and ? (e.g. --ignore Scenario,Time,Acc*); "
                   "repeatable; a pattern never skips a cell or DoF column")
      ->type_name("COLUMN[,PATTERN...]")
      ->delimiter(',')
      ->allow_extra_args(false);
  command->add_flag("--allow-flat", o->import.allow_flat, "keep calibration takes where a sensor does not move (it then reads 0); listed");
  command
      ->add_option("--keypoint-unit", o->keypoint_unit,
                   "unit of a hand tracker's keypoint columns: m (default; MediaPipe world landmarks, OpenXR), cm or mm")
      ->check(CLI::IsMember({"m", "cm", "mm"}))
      ->type_name("UNIT");
  add_number(*command, "--keypoint-offset", "S", o->keypoint_offset,
             "the tracker's clock offset, glove time = tracker time + S (default: found from the motion both record)");
  add_number(*command, "--glove-delay", "S", o->import.keypoint_labels.glove_delay_seconds,
             "the glove's response delay (how long after a motion its cells show it), taken off the offset found (default 0)")
      ->check(at_least(0.0));
  command
      ->add_option("--keypoint-report", o->keypoint_report,
                   "also write a CSV of every keypoint-labelled frame: take, subject, session, timestamp, the fit residual (mm) "
                   "behind its label and whether it is labelled (trusted)")
      ->type_name("FILE");
  add_number(*command, "--keypoint-smoothing", "S", o->import.keypoint_labels.smoothing_seconds,
             "SD of the lag-free smoothing of the keypoint labels in time (default 0.08; 0: none)")
      ->check(at_least(0.0));
  command->add_option("--out", o->out, "the dataset file written")->required()->type_name("FILE");
  return {command, [o] { return import_recordings(*o); }};
}

}  // namespace glovepose::cli
