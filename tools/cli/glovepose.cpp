// The glovepose command-line tool.
//   glovepose --version
//       the library's version (config.hpp), and the instruction set the networks run (of those the
//       build holds: model/network_variants.hpp).
//   glovepose predict --model FILE [--in CSV] [--weights f32|f16|bf16|fixed16] [--glove FILE] [--no-header]
//       [--raw [--calibration FILE | --calibration-seconds S [--save-calibration FILE]]]
//       rows of calibrated cell values (44 for the built-in glove; comma-separated, in [-1, 1]) in, 25 joint angles in
//       radians out (theta 9..33 of the hand model), one row per input row; with --raw, the glove's own
//       readings ("timestamp,cell,...,cell", as view --stdin reads them, glove_lines.hpp) through the
//       estimator, calibrated by a saved calibration or on the fly, one row per pose.
//   glovepose info FILE | --model FILE
//       what a model file holds: the network, the glove, the weights' dtype on disk, the calibration
//       mode and the provenance (the commands and data that made it).
//   glovepose simulate ...
//       the simulated glove corpus (simulate.cpp).
//   glovepose import ...
//       CSV recordings of any glove with named columns into one dataset file (import.cpp).
//   glovepose train | finetune | eval | fit-guided ...
//       train, fine-tune and evaluate models on dataset files (train.cpp).
//   glovepose demo [--model FILE] [--out DIR] [--seed S] [--minutes M] [--weights f32|f16|bf16|fixed16]
//       a simulated new user calibrates and streams a session through the estimator (demo.cpp).
//   glovepose soak [--minutes M] [--estimators N] [--seed S] [--source-minutes X] [--model FILE]
//       estimators on threads stream hours of simulated rows with random faults; prints the figures (soak.cpp).
//   glovepose bench [--model FILE]... [--poses N] [--json]
//       per-stage latency of one pose on this machine against the paper's 5 ms budget (bench.cpp).
//   glovepose view [--port P] [--model FILE] [--seed S] [--replay FILE | --stdin] [--seconds N]
//       the hand live in the browser, from a simulated, replayed or real glove (view.cpp).
//   glovepose record --in SOURCE --out FILE [--quiet]
//       a glove's wire stream kept in a new file as it arrives (record.cpp).
//   glovepose serve --in SOURCE [--engine PORT] [--osc HOST:PORT] [--profiles DIR --user NAME] [--stats]
//       a glove's poses published to engines and OSC as they come (serve.cpp).
#include <glovepose/calibration/free_motion.hpp>
#include <glovepose/calibration/pose_offset.hpp>
#include <glovepose/estimator.hpp>
#include <glovepose/grid/glove_description.hpp>
#include <glovepose/hand/dofs.hpp>
#include <glovepose/model/model_info.hpp>
#include <glovepose/model/pose_network.hpp>
#include <glovepose/pose_model_options.hpp>
#include <glovepose/sensor/calibration.hpp>
#include <glovepose/sensor/solver.hpp>

#include <algorithm>
#include <array>
#include <cctype>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <iostream>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include "commands.hpp"
#include "glove_frames.hpp"

using namespace glovepose;

namespace {

struct PredictOptions {
  std::string model, input;  // input empty: stdin
  std::string glove;         // --glove: checked against the model's
  nn::WeightStorage storage = nn::WeightStorage::F32;
  bool no_header = false;
  bool raw = false;  // the glove's own readings, calibrated here
  double calibration_seconds = cli::kDefaultCalibrationSeconds;
  bool calibration_seconds_given = false;
  std::string calibration, save_calibration;  // --raw: a saved calibration to use; where to save the one made on the fly
};

void print_angles(const hand::Angles& angles) {
  for (std::size_t d = 0; d < hand::kDofCount; ++d) std::printf("%s%.9g", d ? "," : "", angles[d]);
  std::printf("\n");
}

// --raw: the glove's lines through an estimator, as view --stdin reads them; a row of angles per pose.
void predict_raw(const PredictOptions& o, std::shared_ptr<const PoseModel> model, std::istream& in) {
  GlovePoseEstimator estimator(model);
  const cli::GloveCalibrationChoice calibration =
      cli::choose_glove_calibration(*model, o.calibration_seconds, o.calibration_seconds_given, o.calibration);
  if (!o.calibration.empty()) estimator.load_calibration(o.calibration);
  calibration.apply(estimator);
  std::fprintf(stderr, "glovepose predict: calibration: %s\n", calibration.text.c_str());
  const cli::GloveLineFormat format(*model, false);
  cli::GloveLineCounts counts;
  device::LinkCounts link;
  const std::string source = o.input.empty() ? "stdin" : "'" + o.input + "'";
  cli::read_glove_stream(
      cli::GloveLineSource{in, source, "glovepose predict"}, format, estimator, calibration.on_the_fly,
      counts,
      [&](Status status) {
        if (status == Status::Solved) print_angles(estimator.pose().angles);
      },
      link);
  std::fflush(stdout);
  if (!o.save_calibration.empty()) estimator.save_calibration(o.save_calibration);
  const bool frames = link.bytes > 0;
  std::fprintf(stderr, "glovepose predict: %s: %ld %s, %ld %s, %ld skipped, %ld refused by the estimator; %ld poses\n", source.c_str(),
               counts.lines, frames ? "frames" : "lines", counts.inputs, frames ? "inputs" : "understood", counts.skipped, counts.rejected,
               counts.poses);
  if (frames) std::fprintf(stderr, "glovepose predict: %s: link: %s\n", source.c_str(), cli::link_summary(link).c_str());
}

// One row of `count` numbers; throws Error naming the line and column.
std::vector<double> parse_row(const std::string& line, std::size_t line_no, std::size_t count) {
  std::vector<double> values;
  std::stringstream fields(line);
  std::string cell;
  while (std::getline(fields, cell, ',')) {
    const std::size_t first = cell.find_first_not_of(" \t\r"), last = cell.find_last_not_of(" \t\r");
    const std::string text = first == std::string::npos ? "" : cell.substr(first, last - first + 1);
    double v = 0.0;  // from_chars: independent of the locale
    const auto result = std::from_chars(text.data(), text.data() + text.size(), v);
    if (text.empty() || result.ec != std::errc() || result.ptr != text.data() + text.size() || !std::isfinite(v))
      throw Error("line " + std::to_string(line_no) + ", column " + std::to_string(values.size() + 1) + ": '" + text +
                  "' is not a finite number");
    values.push_back(v);
  }
  if (values.size() != count)
    throw Error("line " + std::to_string(line_no) + ": " + std::to_string(values.size()) + " values, expected " + std::to_string(count) +
                " (one calibrated value per sensor cell)");
  return values;
}

// Whether a line names columns: every field is a word (starts with a letter or '_', not nan or inf).
bool looks_like_header(const std::string& line) {
  std::stringstream fields(line);
  std::string field;
  while (std::getline(fields, field, ',')) {
    const std::size_t first = field.find_first_not_of(" \t");
    if (first == std::string::npos || !(std::isalpha(static_cast<unsigned char>(field[first])) || field[first] == '_')) return false;
    std::string word;
    for (std::size_t i = first; i < field.size() && !std::isspace(static_cast<unsigned char>(field[i])); ++i)
      word += static_cast<char>(std::tolower(static_cast<unsigned char>(field[i])));
    if (word == "nan" || word == "inf" || word == "infinity") return false;
  }
  return true;
}

int predict(const PredictOptions& o) {
  PoseModelOptions options;
  options.storage = o.storage;
  const std::shared_ptr<const PoseModel> model = PoseModel::load(o.model, options);  // the glove: from the file, or built in
  cli::check_glove(o.glove, model->glove(), o.model);
  std::ifstream file;
  if (o.input.empty())
    cli::binary_stdin();  // wire frames as sent (Windows); text lines take a carriage return as blank
  else {
    file.open(o.input, std::ios::binary);
    if (!file) throw Error("cannot open input '" + o.input + "'");
  }
  std::istream& in = o.input.empty() ? std::cin : file;
  if (!o.no_header) {
    for (std::size_t d = 0; d < hand::kDofCount; ++d) std::printf("%s%s", d ? "," : "", hand::kDofs[d].name);
    std::printf("\n");
  }
  if (o.raw) {
    predict_raw(o, model, in);
    return 0;
  }
  const grid::GridMap& map = model->glove().map();
  auto ws = model->network().make_workspace();
  std::string line;
  std::size_t line_no = 0;
  bool first_row = true;
  const auto cells = static_cast<std::size_t>(model->cell_count());
  while (std::getline(in, line)) {
    ++line_no;
    if (line.find_first_not_of(" \t\r") == std::string::npos || line[0] == '#') continue;
    if (first_row && looks_like_header(line))
      throw Error("line " + std::to_string(line_no) + ": '" + line.substr(0, 60) + (line.size() > 60 ? "...'" : "'") +
                  " looks like a header, expected rows of calibrated cell values without one; the glove's own readings "
                  "with a header naming its cells are read by --raw, a recording with named columns is imported with "
                  "glovepose import and evaluated with glovepose eval");
    first_row = false;
    const std::vector<double> values = parse_row(line, line_no, cells);
    hand::Angles normalized{};
    if (model->network().normalized_dofs(map, values.data(), normalized, ws) != Status::Ok)
      throw Error("line " + std::to_string(line_no) + ": the network refused the input (a result beyond float's range)");
    print_angles(model->held_angles(normalized));
  }
  return 0;
}

int info(const std::string& model_path) {
  const std::shared_ptr<const PoseModel> loaded = PoseModel::load(model_path);
  const PoseModel& model = *loaded;
  const auto& net = model.network();
  std::printf("architecture: %s\nwidth: %d\nglove: %s\nparameters: %zu\n", model.info().architecture_name().c_str(), model.info().width,
              model.info().glove.c_str(), net.parameter_count());
  const grid::GloveDescription& glove = model.glove();
  std::string extra;  // the inputs that are not on the stretch maps, by name
  for (int c = 0; c < glove.cell_count(); ++c)
    if (!glove.map().cell_slots()[static_cast<std::size_t>(c)].on_maps())
      extra += (extra.empty() ? "" : ", ") + glove.cell_names()[static_cast<std::size_t>(c)];
  std::printf("inputs: %d (%d stretch cells", glove.cell_count(), glove.cell_count() - glove.map().extra_input_count());
  if (!extra.empty())
    std::printf(", %d extra input%s (%s)", glove.map().extra_input_count(), glove.map().extra_input_count() > 1 ? "s" : "", extra.c_str());
  std::printf(")\n");
  std::printf("weights that can meet an input: %zu\n", net.stored_weight_count());
  if (model.labelled_dofs() != hand::all_dofs())
    std::printf("trained DoFs: %s (the others read the rest pose)\n", hand::dof_set_text(model.labelled_dofs()).c_str());
  std::printf("weights on disk: %s\npacked weight bytes (F32): %zu\nmultiply-adds per frame: %zu\n", cli::stored_dtypes(model_path).c_str(),
              net.weight_bytes(), net.mac_count());
  std::printf("calibration mode: %s\ntraining-set calibration: %s\n", model::to_string(model.info().calibration),
              model.info().calibration_min ? "yes" : "no");
  if (!model.pose_offset()) {
    std::printf("pose-guided calibration: none\n");
  } else {
    const calibration::PoseOffsetModel& offsets = *model.pose_offset();
    std::printf("pose-guided calibration: sequence '%s' (%zu steps, %.1f s), %td features\n", offsets.sequence().id().c_str(),
                offsets.sequence().steps().size(), offsets.sequence().total_seconds(),
                static_cast<std::ptrdiff_t>(offsets.feature_count()));
  }
  if (!model.range_map()) {
    std::printf("continuous calibration: no (no range map)\n");
  } else {
    const calibration::RangeMap& map = *model.range_map();
    std::printf("continuous calibration: range map of %zu stages (from %g to %g frames of free motion)\n", map.stages().size(),
                map.stages().empty() ? 0.0 : map.stages().front().frames, map.stages().empty() ? 0.0 : map.stages().back().frames);
  }
  if (!model.pose_error()) {
    std::printf("confidence: from the trust flags only (no measured errors)\n");
  } else {
    const model::PoseErrorModel& errors = *model.pose_error();
    double guided = 0.0;
    for (double e : errors.guided_deg()) guided += e * e / static_cast<double>(hand::kDofCount);
    std::printf("confidence: the model's own errors, %.2f deg RMS still after a guided calibration, %zu continuous stages, %td cells\n",
                std::sqrt(guided), errors.continuous().size(), static_cast<std::ptrdiff_t>(errors.cells()));
  }
  // Provenance: the file's metadata beyond the model's own fields (those ModelInfo writes), such as
  // training_command, training_data and training_seed; pose_offset is shown above.
  nn::WeightFile fields;
  model.info().to(fields);
  const nn::WeightFile file = nn::WeightFile::read(model_path);
  for (const auto& [key, value] : file.metadata)
    if (!fields.metadata.count(key) && key != "pose_offset") std::printf("%s: %s\n", key.c_str(), value.c_str());
  return 0;
}

cli::Command add_predict(CLI::App& tool) {
  auto o = std::make_shared<PredictOptions>();
  CLI::App* command = tool.add_subcommand(
      "predict",
      "Rows of calibrated cell values (the model's glove's cells in the order of its description, 44 for the built-in glove; "
      "comma-separated, in [-1, 1]) in, 25 joint angles in radians out (theta 9..33 of the hand model), one row per input row. "
      "With --raw, the glove's own readings in, as glovepose view --stdin reads them: one frame per line, "
      "'timestamp,cell,...,cell' (seconds, then the cells in the glove's unit; an optional first line 'timestamp,<cell names>' "
      "or 'timestamp_ms,...'), calibrated by a saved calibration (--calibration) or on the fly from the first "
      "--calibration-seconds of stream time; one row of angles per pose (none for the frames of the on-the-fly calibration), "
      "lines that do not parse counted and skipped, a count on stderr.");
  cli::add_model_file(*command, o->model, "the model file")->required();
  command->add_option("--in", o->input, "the rows, a CSV file without a header (--raw: with one or without) (default: stdin)")
      ->check(cli::existing_file())
      ->type_name("CSV");
  cli::add_weight_storage(*command, o->storage);
  cli::add_glove_file(*command, o->glove, "the glove the rows come from; refused unless the model was trained for it (default: the model's)");
  command->add_flag("--no-header", o->no_header, "leave out the first output line (the DoF names)");
  CLI::Option* raw =
      command->add_flag("--raw", o->raw,
                        "the glove's own readings, uncalibrated: 'timestamp,cell,...,cell' per line (or, for the built-in glove, raw rows "
                        "'row,value,timestamp' of its wiring)");
  cli::add_glove_line_calibration(*command, o->calibration_seconds, o->calibration_seconds_given, o->calibration, raw);
  command->add_option("--save-calibration", o->save_calibration, "--raw: save the calibration made on the fly to FILE (for --calibration)")
      ->type_name("FILE")
      ->needs(raw)
      ->excludes("--calibration");
  return {command, [o] { return predict(*o); }};
}

cli::Command add_info(CLI::App& tool) {
  auto model = std::make_shared<std::string>();
  CLI::App* command = tool.add_subcommand(
      "info", "What a model file holds: the network, the glove, the weights' dtype on disk, the calibration mode and the provenance.");
  CLI::Option* positional = command->add_option("FILE", *model, "the model file")->check(cli::existing_file())->type_name("FILE");
  cli::add_model_file(*command, *model, "the model file (the same as FILE)")->excludes(positional);
  return {command, [model] {
            if (model->empty()) throw CLI::RequiredError("FILE or --model FILE");
            return info(*model);
          }};
}

// A usage error: the command and the problem on stderr, and where its options are described.
std::string usage_error(const CLI::App* tool, const CLI::Error& e) {
  const std::vector<CLI::App*> chosen = tool->get_subcommands();
  const std::string command = chosen.empty() ? "glovepose" : "glovepose " + chosen.front()->get_name();
  return command + ": " + e.what() + "\nRun '" + command + " --help' for the options.\n";
}

}  // namespace

// Exit codes: 0 done (or --help), 1 a runtime failure (or a failed check: soak), 2 a usage error,
// 130 training interrupted by Ctrl-C.
int main(int argc, char** argv) {
  CLI::App tool(
      "The glovepose tool: hand poses from a stretch-sensing glove's readings, and the models, data and "
      "measurements behind them. 'glovepose COMMAND --help' describes a command.",
      "glovepose");
  tool.require_subcommand(0, 1);  // an unknown command is then named as unexpected; none is refused below
  tool.option_defaults()->multi_option_policy(CLI::MultiOptionPolicy::TakeLast);  // an option given twice: the last counts
  tool.failure_message(usage_error);
  const CLI::Option* version = tool.add_flag("--version", "print the version of glovepose (its library's, config.hpp) and the instruction set its networks run, and exit");
  std::vector<cli::Command> commands{add_predict(tool), add_info(tool), cli::add_simulate(tool), cli::add_import(tool)};
  std::string command_line = "glovepose";
  for (int i = 1; i < argc; ++i) command_line += std::string(" ") + argv[i];
  for (cli::Command& command : cli::add_training_commands(tool, command_line)) commands.push_back(std::move(command));
  for (const auto add : {&cli::add_demo, &cli::add_soak, &cli::add_bench, &cli::add_view, &cli::add_record, &cli::add_serve}) commands.push_back(add(tool));
  try {
    tool.parse(argc, argv);
    if (*version) {
      std::string built;
      for (nn::Isa isa : model::built_isas()) built += std::string(built.empty() ? "" : ", ") + nn::isa_word(isa);
      std::printf("glovepose %s\nnetworks: %s (this build holds %s)\n", kVersion, nn::isa_word(model::process_isa()), built.c_str());
      return 0;
    }
    if (tool.get_subcommands().empty()) throw CLI::RequiredError("A command");
    const CLI::App* chosen = tool.get_subcommands().front();
    return std::find_if(commands.begin(), commands.end(), [&](const cli::Command& c) { return c.options == chosen; })->run();
  } catch (const CLI::ParseError& e) {
    if (e.get_exit_code() == 0) return tool.exit(e);  // --help, printed on stdout
    // CLI11 checks the required options before the unknown ones; an unknown one is named first,
    // as it may be the required one misspelt.
    const std::vector<std::string> unknown = tool.remaining(true);
    if (!unknown.empty())
      tool.exit(CLI::ExtrasError({unknown.rbegin(), unknown.rend()}));  // it lists them backwards
    else
      tool.exit(e);
    return 2;
  } catch (const Error& e) {
    const auto chosen = tool.get_subcommands();  // none for --version
    std::cerr << "glovepose" << (chosen.empty() ? std::string() : " " + chosen.front()->get_name()) << ": " << e.what() << "\n";
    return 1;
  }
}
