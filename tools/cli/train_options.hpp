// The command lines of glovepose train, finetune, eval and fit-guided (train.cpp runs them): the
// options each takes, parsed into one Options, and the training progress bar on stderr.
#pragma once

#include <glovepose/io/tensor_file.hpp>
#include <glovepose/train/augmentation.hpp>
#include <glovepose/train/samples.hpp>
#include <glovepose/train/trainer.hpp>

#ifdef _WIN32
#  include <io.h>  // _isatty
#else
#  include <unistd.h>
#endif

#include <chrono>
#include <cmath>
#include <cstdio>
#include <memory>
#include <optional>
#include <string>
#include <tuple>
#include <utility>
#include <vector>

#include "commands.hpp"

namespace glovepose::cli::training {

// Ids like "0-3,7", or nullopt when `text` is not such a list.
inline std::optional<std::vector<int>> id_list(const std::string& text) {
  std::vector<int> ids;
  std::size_t start = 0;
  while (start <= text.size()) {
    const std::size_t comma = std::min(text.find(',', start), text.size());
    const std::string item = text.substr(start, comma - start);
    const std::size_t dash = item.find('-');
    const std::optional<int> lo = number_from_text<int>(dash == std::string::npos ? item : item.substr(0, dash));
    const std::optional<int> hi = dash == std::string::npos ? lo : number_from_text<int>(item.substr(dash + 1));
    if (!lo || !hi || *lo < 0 || *hi < *lo || *hi - *lo > 100000) return std::nullopt;
    for (int v = *lo; v <= *hi; ++v) ids.push_back(v);
    start = comma + 1;
  }
  return ids;
}

// Session seconds "A-B" (A <= B) or "A-" (to the end), or nullopt when `text` is not such a window.
inline std::optional<std::pair<double, double>> seconds_window(const std::string& text) {
  const std::size_t dash = text.find('-');
  if (dash == std::string::npos) return std::nullopt;
  const std::optional<double> from = number_from_text<double>(text.substr(0, dash));
  const std::string rest = text.substr(dash + 1);
  const std::optional<double> to = rest.empty() ? std::optional<double>(std::numeric_limits<double>::infinity()) : number_from_text<double>(rest);
  if (!from || !to || !(*from >= 0.0) || !std::isfinite(*from) || !(*to > *from)) return std::nullopt;
  return std::pair<double, double>{*from, *to};
}

// A network to train: "unet:W", "fcn[:H]" or "linear" (W default 64, H default 2048).
struct Architecture {
  std::string name;  // as model files spell `kind`
  model::Architecture kind = model::Architecture::UNet;
  int width = 0;
};

inline std::optional<Architecture> architecture(const std::string& text) {
  const std::size_t colon = text.find(':');
  Architecture a;
  a.name = text.substr(0, colon);
  const std::optional<model::Architecture> kind = model::parse_architecture(a.name);
  if (!kind) return std::nullopt;
  a.kind = *kind;
  a.width = a.kind == model::Architecture::UNet ? 64 : (a.kind == model::Architecture::Fcn ? 2048 : 0);
  if (colon == std::string::npos) return a;
  const std::optional<int> width = number_from_text<int>(text.substr(colon + 1));
  if (a.kind == model::Architecture::Linear || !width || *width < 1) return std::nullopt;
  a.width = *width;
  return a;
}

// GAIN,OFFSET,NOISE, or nullopt when `text` is not three numbers.
inline std::optional<train::Augmentation> augmentation(const std::string& text) {
  const std::size_t c1 = text.find(','), c2 = c1 == std::string::npos ? c1 : text.find(',', c1 + 1);
  if (c2 == std::string::npos) return std::nullopt;
  const std::optional<double> gain = number_from_text<double>(text.substr(0, c1)),
                              offset = number_from_text<double>(text.substr(c1 + 1, c2 - c1 - 1)),
                              noise = number_from_text<double>(text.substr(c2 + 1));
  if (!gain || !offset || !noise) return std::nullopt;
  train::Augmentation a;
  a.gain = *gain;
  a.offset = *offset;
  a.noise = *noise;
  return a;
}

struct Options {
  std::string command, command_line, data, model, out, glove_file, sequence_file, predictions_file, pinch_distances_file;
  Architecture architecture;  // train: the network to train (--architecture)
  bool replay = false;
  int mean_window = 0;      // --replay-rows: the readout's mean window; 0: the estimator's default
  std::string calibration;  // --calibration-mode; empty: the default of the command
  train::FrameFilter filter;
  std::vector<int> exclude_subjects;
  int stride = 1, threads = 0;
  train::TrainConfig training;
  double validation = 0.1;
  train::ValidationSplit validation_split = train::ValidationSplit::Auto;
  std::vector<double> demean_seconds;  // train: input conditioning windows to compare (--demean-seconds)
  io::DType dtype = io::DType::F32;  // storage of the written model
  nn::WeightStorage storage = nn::WeightStorage::F32;  // eval: how the network holds the weights (--weights)
  bool json = false, quiet = false, batch_set = false, lr_set = false, epochs_set = false;
  bool contact = false;  // eval: the contact stage (hand/contact.hpp) on the predicted poses
  bool resume = false;   // train, finetune: go on from the checkpoint beside --out
};

// Adds option `name` taking one of `choices` (their names are the value's name in the help).
template <typename T>
CLI::Option* add_choice(CLI::App& command, const std::string& name, const std::vector<std::pair<std::string, T>>& choices, T& target,
                        const std::string& description) {
  std::string names;
  for (const auto& choice : choices) names += (names.empty() ? "" : "|") + choice.first;
  return add_parsed_option<T>(
      command, name, names,
      [choices](const std::string& text) -> std::optional<T> {
        for (const auto& [choice, value] : choices)
          if (text == choice) return value;
        return std::nullopt;
      },
      [&target](T value) { target = value; }, "one of " + names, description);
}

// Adds the old spelling `old_name` of option `now` (same value), which says on stderr that it is now `now`.
inline CLI::Option* add_alias(CLI::App& command, const std::string& old_name, const std::string& now, const std::string& value_name,
                              std::function<void(const std::string&)> store) {
  return command
      .add_option_function<std::string>(
          old_name,
          [command = command.get_name(), old_name, now, store](const std::string& text) {
            std::fprintf(stderr, "%s: %s is now %s (the old spelling still works)\n", command.c_str(), old_name.c_str(), now.c_str());
            store(text);
          },
          "the old spelling of " + now)
      ->type_name(value_name)
      ->group("Old spellings");
}

// --calibration-mode MODE among `modes` (and its old spelling --calibration MODE).
inline void add_calibration_mode(CLI::App& command, Options& o, const std::vector<std::string>& modes, const std::string& description) {
  CLI::Option* mode = command.add_option("--calibration-mode", o.calibration, description)->check(CLI::IsMember(modes))->type_name("MODE");
  add_alias(command, "--calibration", "--calibration-mode", "MODE", [&o](const std::string& v) { o.calibration = v; })
      ->check(CLI::IsMember(modes))
      ->excludes(mode);
}

// The options every command has: --data, --threads, the selection (--stride too: `with_stride`).
inline void add_data_options(CLI::App& command, Options& o, bool with_stride) {
  command.add_option("--data", o.data, "the dataset file (glovepose simulate or import)")
      ->required()
      ->check(existing_file())
      ->type_name("FILE");
  add_number(command, "--threads", "T", o.threads, "threads (default 0: all cores)");
  const std::tuple<const char*, std::vector<int>*, const char*> lists[] = {
      {"--subjects", &o.filter.subjects, "only these subjects (default: all)"},
      {"--exclude-subjects", &o.exclude_subjects, "leave these subjects out (default: none)"},
      {"--sessions", &o.filter.sessions, "only these sessions (default: all)"},
      {"--gloves", &o.filter.gloves, "only these gloves (default: all)"}};
  for (const auto& [name, target, description] : lists)
    add_parsed_option<std::vector<int>>(
        command, name, "LIST", id_list, [target = target](std::vector<int> ids) { *target = std::move(ids); }, "ids like 0-3,7",
        std::string(description) + "; LIST: ids like 0-3,7")
        ->group("Selection");
  if (with_stride)
    add_number(command, "--stride", "K", o.stride, "every K-th frame of the selection (default 1)")->check(at_least(1))->group("Selection");
}

// The defaults train and finetune give the training options, as the help tells them.
struct TrainingDefaults {
  std::string epochs, batch, lr;
};

// The training options of train and finetune.
inline void add_training_options(CLI::App& command, const std::shared_ptr<Options>& o, const TrainingDefaults& defaults) {
  add_calibration_mode(command, *o, {"none", "training", "onthefly"}, "how the inputs are calibrated (default onthefly)");
  add_number_option<int>(
      command, "--epochs", "N", [o](int v) { o->training.epochs = v, o->epochs_set = true; },
      "passes over the training frames (default " + defaults.epochs + ")")
      ->check(at_least(1));
  add_number_option<int>(
      command, "--batch", "N", [o](int v) { o->training.batch = v, o->batch_set = true; },
      "frames per step (default " + defaults.batch + ")")
      ->check(at_least(1));
  add_number_option<double>(
      command, "--lr", "X", [o](double v) { o->training.optimizer.learning_rate = v, o->lr_set = true; },
      "learning rate (default " + defaults.lr + ")")
      ->check(above(0.0));
  add_choice(command, "--optimizer", {{"adam", train::OptimizerKind::Adam}, {"sgd", train::OptimizerKind::Sgd}}, o->training.optimizer.kind,
             "the optimizer (default adam)");
  add_number(command, "--validation", "FRACTION", o->validation, "of the selected frames held out to pick the best epoch (default 0.1)");
  add_choice(command, "--validation-split",
             {{"auto", train::ValidationSplit::Auto}, {"runs", train::ValidationSplit::Runs}, {"frames", train::ValidationSplit::Frames}},
             o->validation_split,
             "which frames validate: runs (whole sessions never trained on, the last in the data), frames (the last part of every "
             "session) or auto (default: runs when there are two or more)");
  add_number(command, "--seed", "S", o->training.seed, "seed of the initial weights, the batches and the augmentation (default 1)");
  add_number_option<double>(
      command, "--max-minutes", "M", [o](double v) { o->training.max_seconds = 60.0 * v; },
      "stop training after M minutes (default: no limit)")
      ->check(at_least(0.0));
  command.add_flag("--quiet", o->quiet, "no progress on stderr");
  command.add_flag("--resume", o->resume,
                   "go on from the checkpoint beside --out (FILE.checkpoint) of a run that was stopped or killed, to the weights the "
                   "whole run gives; without one, start");
  add_number_option<double>(
      command, "--checkpoint-minutes", "M", [o](double v) { o->training.checkpoint_seconds = 60.0 * v; },
      "within an epoch, minutes between two checkpoints (default 10; one is written at every epoch's end)")
      ->check(above(0.0));
  // --weights is the spelling of weight storage across the tool; --dtype the older one here.
  const std::vector<std::pair<std::string, io::DType>> dtypes{{"f32", io::DType::F32}, {"f16", io::DType::F16}, {"bf16", io::DType::BF16}};
  CLI::Option* weights = add_choice(command, "--weights", dtypes, o->dtype, "storage of the written model's weights (default f32)");
  add_choice(command, "--dtype", dtypes, o->dtype, "the same as --weights")->excludes(weights);
  add_parsed_option<train::Augmentation>(
      command, "--augment", "GAIN,OFFSET,NOISE", augmentation,
      [o](train::Augmentation a) {
        try {
          a.validate();
        } catch (const Error& e) {
          throw CLI::ValidationError("--augment", e.what());
        }
        o->training.augmentation = a;
      },
      "GAIN,OFFSET,NOISE", "deviations of each training frame's cell perturbation, normalised units: (1 + g) x + o + n (default none)");
}

// The options of eval beyond the data's.
inline void add_eval_options(CLI::App& command, Options& o) {
  add_calibration_mode(command, o, {"none", "training", "onthefly", "guided", "continuous"},
                       "how the inputs are calibrated (default: the model's; guided when the model carries a pose-guided "
                       "calibration and the data followed its sequence; continuous: no calibration step, the range kept from "
                       "each session's free motion by the model's range map)");
  add_parsed_option<std::pair<double, double>>(
      command, "--seconds", "A-B", seconds_window,
      [&o](std::pair<double, double> w) { o.filter.from_seconds = w.first, o.filter.to_seconds = w.second; }, "seconds like 60-120 or 60-",
      "score only the frames this many seconds into each session (since its first recording frame): from A up to B (default: all)")
      ->group("Selection");
  add_weight_storage(command, o.storage, false);
  add_glove_file(command, o.glove_file, "the glove description the data was recorded with: refused unless it is the model's");
  command.add_flag("--json", o.json, "print the report as JSON");
  CLI::Option* replay = command.add_flag("--replay-rows", o.replay, "replay the raw rows through the estimator's readout");
  add_number(command, "--mean-window", "N", o.mean_window, "the readout's mean window for --replay-rows (default: the estimator's)")
      ->check(at_least(1))
      ->needs(replay);
  command.add_option("--predictions", o.predictions_file, "write every frame's true and predicted angles (CSV)")->type_name("FILE.csv");
  command
      .add_option("--pinch-distances", o.pinch_distances_file,
                  "write every frame's true and predicted thumb-to-fingertip distances (mm) and true pinch flags (CSV)")
      ->type_name("FILE.csv");
  command.add_flag("--contact", o.contact,
                   "adjust the predicted poses with the contact stage (thumb and finger tips brought together when the pose "
                   "says they touch) before scoring");
}

inline std::string duration(double seconds) {
  char text[32];
  const long s = static_cast<long>(seconds + 0.5);
  if (s >= 3600)
    std::snprintf(text, sizeof text, "%ldh%02ldm", s / 3600, s / 60 % 60);
  else
    std::snprintf(text, sizeof text, "%ldm%02lds", s / 60, s % 60);
  return text;
}

// A progress bar on stderr: redrawn in place on a terminal, a line per epoch otherwise.
inline std::function<void(const train::Progress&)> progress_bar(bool quiet) {
  if (quiet) return {};
#ifdef _WIN32
  const bool terminal = _isatty(2) != 0;
#else
  const bool terminal = isatty(2) != 0;
#endif
  auto last = std::make_shared<std::chrono::steady_clock::time_point>();
  return [terminal, last](const train::Progress& p) {
    const bool epoch_end = p.step == p.steps_per_epoch;
    const auto now = std::chrono::steady_clock::now();
    if (!epoch_end && (!terminal || now - *last < std::chrono::milliseconds(250))) return;
    *last = now;
    const double done = (p.epoch + static_cast<double>(p.step) / static_cast<double>(p.steps_per_epoch)) / p.epochs;
    char bar[21];
    for (int i = 0; i < 20; ++i) bar[i] = i < static_cast<int>(done * 20.0) ? '#' : '-';
    bar[20] = 0;
    char best[32] = "-";
    if (std::isfinite(p.best_validation_deg)) std::snprintf(best, sizeof best, "%.2f deg", p.best_validation_deg);
    std::fprintf(stderr, "%sepoch %d/%d [%s] %3.0f%%  %.0f samples/s  loss %.5f  best val %s  ETA %s%s", terminal ? "\r" : "", p.epoch + 1,
                 p.epochs, bar, 100.0 * done, p.samples_per_second, p.loss, best, duration(p.eta_seconds).c_str(), terminal ? "   " : "\n");
    if (terminal && epoch_end) std::fprintf(stderr, "\n");
  };
}

}  // namespace glovepose::cli::training
