// glovepose train, finetune, eval and fit-guided: train, fine-tune and evaluate models on dataset
//   files (io/dataset.hpp), on all cores, and fit a model's pose-guided calibration on people it
//   was not trained on (guided_calibration.hpp).
#include <glovepose/train/metrics_report.hpp>
#include <glovepose/estimator.hpp>
#include <glovepose/hand/contact.hpp>
#include <glovepose/io/json.hpp>
#include <glovepose/sim/subject.hpp>
#include <glovepose/train/fingertip_metrics.hpp>
#include <glovepose/train/guided_calibration.hpp>
#include <glovepose/train/lag.hpp>
#include <glovepose/train/replay.hpp>
#include <glovepose/train/linear_fit.hpp>
#include <glovepose/train/metrics.hpp>
#include <glovepose/train/model_file.hpp>

#ifdef _WIN32
#  include <io.h>  // _isatty
#else
#  include <unistd.h>
#endif

#include <atomic>
#include <charconv>
#include <chrono>
#include <memory>
#include <optional>
#include <csignal>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <thread>
#include <tuple>
#include <vector>

#include "commands.hpp"

namespace glovepose::cli {
namespace {

std::atomic<bool> interrupted{false};
extern "C" void on_interrupt(int) { interrupted.store(true); }

// Ids like "0-3,7", or nullopt when `text` is not such a list.
std::optional<std::vector<int>> id_list(const std::string& text) {
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

// A network to train: "unet:W", "fcn[:H]" or "linear" (W default 64, H default 2048).
struct Architecture {
  std::string name;
  int width = 0;
};

std::optional<Architecture> architecture(const std::string& text) {
  const std::size_t colon = text.find(':');
  Architecture a;
  a.name = text.substr(0, colon);
  if (a.name != "unet" && a.name != "fcn" && a.name != "linear") return std::nullopt;
  a.width = a.name == "unet" ? 64 : (a.name == "fcn" ? 2048 : 0);
  if (colon == std::string::npos) return a;
  const std::optional<int> width = number_from_text<int>(text.substr(colon + 1));
  if (a.name == "linear" || !width || *width < 1) return std::nullopt;
  a.width = *width;
  return a;
}

// GAIN,OFFSET,NOISE, or nullopt when `text` is not three numbers.
std::optional<train::Augmentation> augmentation(const std::string& text) {
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
  Architecture architecture;  // train: the network to train (--model)
  bool replay = false;
  int mean_window = 0;      // --replay-rows: the readout's mean window; 0: the estimator's default
  std::string calibration;  // empty: the default of the command
  train::FrameFilter filter;
  std::vector<int> exclude_subjects;
  int stride = 1, threads = 0;
  train::TrainConfig training;
  double validation = 0.1;
  io::DType dtype = io::DType::F32;  // storage of the written model
  bool json = false, quiet = false, batch_set = false, lr_set = false, epochs_set = false;
  bool contact = false;  // eval: the contact stage (hand/contact.hpp) on the predicted poses
};

// Adds option `name` taking one of `choices` (their names are the value's name in the help).
template <typename T>
void add_choice(CLI::App& command, const std::string& name, const std::vector<std::pair<std::string, T>>& choices, T& target,
                const std::string& description) {
  std::string names;
  for (const auto& choice : choices) names += (names.empty() ? "" : "|") + choice.first;
  add_parsed_option<T>(
      command, name, names,
      [choices](const std::string& text) -> std::optional<T> {
        for (const auto& [choice, value] : choices)
          if (text == choice) return value;
        return std::nullopt;
      },
      [&target](T value) { target = value; }, "one of " + names, description);
}

// The options every command has: --data, --threads, the selection (--stride too: `with_stride`).
void add_data_options(CLI::App& command, Options& o, bool with_stride) {
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
void add_training_options(CLI::App& command, const std::shared_ptr<Options>& o, const TrainingDefaults& defaults) {
  command.add_option("--calibration", o->calibration, "how the inputs are calibrated (default onthefly)")
      ->check(CLI::IsMember({"none", "training", "onthefly"}))
      ->type_name("MODE");
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
  add_number(command, "--seed", "S", o->training.seed, "seed of the initial weights, the batches and the augmentation (default 1)");
  add_number_option<double>(
      command, "--max-minutes", "M", [o](double v) { o->training.max_seconds = 60.0 * v; },
      "stop training after M minutes (default: no limit)")
      ->check(at_least(0.0));
  command.add_flag("--quiet", o->quiet, "no progress on stderr");
  add_choice(command, "--dtype", {{"f32", io::DType::F32}, {"f16", io::DType::F16}, {"bf16", io::DType::BF16}}, o->dtype,
             "storage of the written model (default f32)");
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

// Subjects present in the data minus the excluded ones, when --exclude-subjects is given.
void apply_exclusions(Options& o, const io::Dataset& data) {
  if (o.exclude_subjects.empty()) return;
  if (o.filter.subjects.empty())
    for (std::size_t i = 0; i < data.frames(); ++i)
      if (std::find(o.filter.subjects.begin(), o.filter.subjects.end(), data.subject[i]) == o.filter.subjects.end())
        o.filter.subjects.push_back(data.subject[i]);
  std::vector<int> kept;
  for (int s : o.filter.subjects)
    if (std::find(o.exclude_subjects.begin(), o.exclude_subjects.end(), s) == o.exclude_subjects.end()) kept.push_back(s);
  if (kept.empty()) throw Error("--exclude-subjects leaves no subject");
  o.filter.subjects = kept;
}

std::string duration(double seconds) {
  char text[32];
  const long s = static_cast<long>(seconds + 0.5);
  if (s >= 3600)
    std::snprintf(text, sizeof text, "%ldh%02ldm", s / 3600, s / 60 % 60);
  else
    std::snprintf(text, sizeof text, "%ldm%02lds", s / 60, s % 60);
  return text;
}

// A progress bar on stderr: redrawn in place on a terminal, a line per epoch otherwise.
std::function<void(const train::Progress&)> progress_bar(bool quiet) {
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

// Tells which sensors the calibration zeroed (a flat range), per run: a glove maker's lost channel.
// (The samples name cells by id, "cell_<i>"; the glove's names are shown.)
void report_zeroed(const std::string& command, const train::Samples& samples, const grid::GloveDescription& glove) {
  for (const auto& [key, names] : samples.zeroed) {
    std::string list;
    for (const std::string& n : names) {
      std::size_t id = 0;
      const auto r = std::from_chars(n.data() + std::min<std::size_t>(5, n.size()), n.data() + n.size(), id);
      const bool by_id = n.rfind("cell_", 0) == 0 && r.ec == std::errc() && r.ptr == n.data() + n.size() && id < glove.cell_names().size();
      list += (list.empty() ? "" : ", ") + (by_id ? glove.cell_names()[id] : n);
    }
    const std::string run = key < 0 ? "the training range"
                                    : "subject " + std::to_string(key >> 40) + ", glove " + std::to_string((key >> 20) & 0xfffff) +
                                          ", session " + std::to_string(key & 0xfffff);
    std::fprintf(stderr, "%s: calibration of %s: %zu flat sensor%s read 0: %s\n", command.c_str(), run.c_str(), names.size(),
                 names.size() == 1 ? "" : "s", list.c_str());
  }
}

grid::GloveDescription glove_for(const Options& o, const io::Dataset& data) {
  const grid::GloveDescription glove =
      o.glove_file.empty() ? grid::GloveDescription::glauser2019() : grid::GloveDescription::read(o.glove_file);
  if (data.glove_layout() != glove.id())
    throw Error("the dataset was recorded with glove '" + data.glove_layout() + "' but the glove description is '" + glove.id() +
                "'; pass its description with --glove FILE");
  if (static_cast<std::size_t>(glove.cell_count()) != data.cell_count)
    throw Error("the glove description has " + std::to_string(glove.cell_count()) + " cells, the dataset " +
                std::to_string(data.cell_count));
  // The calibration's median window is median_seconds at the data's rate, and the estimator takes
  // frames at the description's rate: the two must agree, and a described glove without a rate
  // gets the data's in the model it trains.
  const double rate = data.frame_rate();
  if (glove.rate_hz() && std::abs(*glove.rate_hz() - rate) > 1e-9 * rate)
    throw Error("the dataset's frame rate is " + std::to_string(rate) + " Hz but the glove description's rate_hz is " +
                std::to_string(*glove.rate_hz()) + ", expected the same rate (import the takes with the description's rate)");
  if (glove.rate_hz() || glove == grid::GloveDescription::glauser2019()) return glove;
  grid::GloveSettings settings = glove.settings();
  settings.rate_hz = rate;
  return grid::GloveDescription(glove.id(), glove.cell_names(), glove.map(), settings);
}

// Trains (or fine-tunes) a network, saving the best model so far at every improvement.
int fit_network(Options o, train::TrainableNetwork& net, const model::ModelInfo& info, const train::Samples& all,
                std::map<std::string, std::string> provenance) {
  const auto [training, validation] = train::split_validation(all, o.validation);
  if (o.command == "train" && (!o.batch_set || !o.epochs_set)) {  // defaults from the data's size
    if (!o.batch_set) o.training.batch = train::default_batch(training.frames());
    if (!o.epochs_set) o.training.epochs = train::default_epochs(training.frames(), o.training.batch);
    if (!o.quiet)
      std::fprintf(stderr,
                   "train: %ld training frames: batch %d, %d epochs (defaults for this data size: at least %ld steps; "
                   "--batch and --epochs override)\n",
                   training.frames(), o.training.batch, o.training.epochs, train::kMinDefaultSteps);
  }
  const hand::JointLimits limits = info.joint_limits();
  core::ThreadPool pool(o.threads);
  train::TrainConfig config = o.training;
  config.stop = &interrupted;
  config.on_progress = progress_bar(o.quiet);
  provenance["training_frames"] = std::to_string(training.frames());
  provenance["validation_frames"] = std::to_string(validation.frames());
  config.on_best = [&](const train::TrainableNetwork& best, const train::EpochRecord& record) {
    provenance["best_epoch"] = std::to_string(record.epoch + 1);  // 1-based, as printed
    provenance["validation_error_deg"] = std::to_string(record.validation_error_deg);
    train::save_model(o.out, info, best.parameters().to_tensors(), provenance, o.dtype);
  };
  std::signal(SIGINT, on_interrupt);
  if (!o.quiet)
    std::fprintf(stderr, "%s %s (%zu parameters): %ld training frames, %ld validation frames, batch %d, %d threads\n", o.command.c_str(),
                 info.architecture.c_str(), net.parameters().trainable_count(), training.frames(), validation.frames(), o.training.batch,
                 o.threads);
  const train::TrainResult result = train::train_network(net, training, validation, limits, config, pool);
  std::signal(SIGINT, SIG_DFL);
  std::printf("%s: %ld steps in %s (%.0f samples/s); kept epoch %d, validation error %.3f deg; wrote %s\n",
              result.stopped ? "stopped" : "done", result.steps, duration(result.seconds).c_str(), result.samples_per_second,
              result.best_epoch + 1, result.best_validation_error_deg, o.out.c_str());
  if (result.best_epoch < 0) throw Error("training stopped before the first epoch ended; no model was written");
  return interrupted.load() ? 130 : 0;
}

int train_command(Options o) {
  const io::Dataset data = read_dataset(o.data);
  apply_exclusions(o, data);
  const grid::GloveDescription glove = glove_for(o, data);
  const model::CalibrationMode mode = model::calibration_mode(o.calibration.empty() ? "onthefly" : o.calibration);
  std::optional<sensor::CalibrationRange> range;
  if (mode == model::CalibrationMode::Training) range = train::training_range(data, o.filter, glove.calibration());
  const hand::JointLimits limits = glove.joint_limits();
  const train::Samples all = train::make_samples(data, o.filter, mode, range ? &*range : nullptr, limits, o.stride, glove.calibration());
  report_zeroed(o.command, all, glove);
  const std::string& architecture = o.architecture.name;
  model::ModelInfo info = train::make_model_info(architecture, o.architecture.width, glove, mode, range ? &*range : nullptr);
  if (all.labelled != hand::all_dofs()) {
    info.labelled_dofs = hand::dof_set_text(all.labelled);
    if (!o.quiet)
      std::fprintf(stderr, "%s: the data labels %zu of the 25 DoFs; the others are not trained and read the rest pose\n", o.command.c_str(),
                   static_cast<std::size_t>(std::count(all.labelled.begin(), all.labelled.end(), true)));
  }
  std::map<std::string, std::string> provenance{
      {"training_command", o.command_line}, {"training_seed", std::to_string(o.training.seed)}, {"training_data", o.data}};
  if (architecture == "linear") {
    if (o.training.augmentation.active())
      throw CLI::ValidationError("--augment trains networks; a linear map is fitted by least squares on the frames as they are");
    const auto [training, validation] = train::split_validation(all, o.validation);
    const nn::LinearMap map =
        train::fit_linear(training.inputs.data(), training.frames(), training.cells, training.targets.data(), train::kTargets).to_map();
    std::vector<float> predicted(static_cast<std::size_t>(validation.frames()) * train::kTargets);
    map.predict(validation.inputs.data(), predicted.data(), validation.frames());
    const double error = train::mean_error_degrees(predicted, validation.angles, limits, validation.labelled);
    provenance["training_frames"] = std::to_string(training.frames());
    provenance["validation_frames"] = std::to_string(validation.frames());
    provenance["validation_error_deg"] = std::to_string(error);
    train::save_model(o.out, info, train::linear_tensors(map), provenance, o.dtype);
    std::printf("done: linear least squares on %ld frames; validation error %.3f deg; wrote %s\n", training.frames(), error, o.out.c_str());
    return 0;
  }
  if (architecture == "fcn" && !o.lr_set && o.training.optimizer.kind == train::OptimizerKind::Sgd)
    o.training.optimizer.learning_rate = 0.01;  // the paper's SGD rate for the FCN
  const std::unique_ptr<train::TrainableNetwork> net = train::make_network(info, glove, o.training.batch);
  if (auto* unet = dynamic_cast<train::TrainableUNet*>(net.get())) unet->initialize(o.training.seed);
  if (auto* fcn = dynamic_cast<train::TrainableFcn*>(net.get())) fcn->initialize(o.training.seed);
  return fit_network(o, *net, info, all, provenance);
}

// The selected frames of --data as a loaded model sees them: its glove, its joint limits, and its
// calibration mode unless --calibration overrides it ("guided" calibrates the inputs on the fly).
std::pair<train::Samples, model::CalibrationMode> samples_for(Options o, const train::TrainedModel& trained, const io::Dataset& data) {
  if (data.glove_layout() != trained.glove.id())
    throw Error("the dataset was recorded with glove '" + data.glove_layout() + "', the model is for '" + trained.glove.id() + "'");
  const std::string requested = o.calibration == "guided" ? "onthefly" : o.calibration;
  const model::CalibrationMode mode = requested.empty() ? trained.info.calibration : model::calibration_mode(requested);
  std::optional<sensor::CalibrationRange> range;
  if (mode == model::CalibrationMode::Training) range = trained.training_range();
  return {train::make_samples(data, o.filter, mode, range ? &*range : nullptr, trained.info.joint_limits(), o.stride,
                              trained.glove.calibration()),
          mode};
}

int finetune_command(Options o) {
  // The paper's fine-tuning (Sec. 5.2, scenario 5): all parameters, lr 1e-6, batch 64.
  if (!o.lr_set) o.training.optimizer.learning_rate = 1e-6;
  if (!o.batch_set) o.training.batch = 64;
  if (!o.epochs_set) o.training.epochs = 5;
  train::TrainedModel model = train::load_model(o.model, o.training.batch);
  if (!model.network)
    throw Error("model '" + o.model + "' is " + model.info.architecture + ", expected a network (unet or fcn) to fine-tune");
  io::Dataset data = read_dataset(o.data);
  apply_exclusions(o, data);
  const train::Samples all = samples_for(o, model, data).first;
  report_zeroed(o.command, all, model.glove);
  std::map<std::string, std::string> provenance = model.metadata;
  provenance["finetune_command"] = o.command_line;
  provenance["finetune_data"] = o.data;
  return fit_network(o, *model.network, model.info, all, provenance);
}

// Whether eval calibrates guided: asked for, or by default when the model carries a pose-guided
// calibration and the dataset's calibrations followed its sequence.
bool eval_guided(const Options& o, const train::TrainedModel& model, const io::Dataset& data) {
  if (o.calibration == "guided") return true;
  if (!o.calibration.empty() || model.info.pose_offset.empty()) return false;
  const auto it = data.metadata.find("calibration_sequence");
  return it != data.metadata.end() &&
         it->second == calibration::PoseOffsetModel::parse(model.info.pose_offset, "metadata 'pose_offset'").sequence().id();
}

// Writes one row per evaluated frame: where it comes from, the true and the predicted angles (radians).
void write_predictions(const std::string& path, const io::Dataset& data, const train::Samples& samples,
                       const std::vector<float>& predicted) {
  std::FILE* file = std::fopen(path.c_str(), "w");
  if (!file) throw Error("--predictions: cannot open '" + path + "' for writing");
  std::fprintf(file, "frame,time,subject,session");
  for (const char* prefix : {"label_", "pred_", "truth_"})
    if (prefix[0] != 't' || data.has_true_angles())
      for (const hand::Dof& d : hand::kDofs) std::fprintf(file, ",%s%s", prefix, d.name);
  std::fprintf(file, "\n");
  for (long f = 0; f < samples.frames(); ++f) {
    const auto i = static_cast<std::size_t>(samples.source[static_cast<std::size_t>(f)]);
    std::fprintf(file, "%zu,%.9g,%d,%d", i, data.timestamps[i], data.subject[i], data.session[i]);
    for (const std::vector<float>* v : {&samples.angles, &predicted})
      for (std::size_t d = 0; d < hand::kDofCount; ++d)
        std::fprintf(file, ",%.9g", static_cast<double>((*v)[static_cast<std::size_t>(f) * hand::kDofCount + d]));
    if (data.has_true_angles())
      for (std::size_t d = 0; d < hand::kDofCount; ++d) std::fprintf(file, ",%.9g", static_cast<double>(data.true_angles[i * hand::kDofCount + d]));
    std::fprintf(file, "\n");
  }
  if (std::fclose(file) != 0) throw Error("--predictions: writing '" + path + "' failed");
}

// The hand of each person in the data, for the fingertip measures: a simulated corpus' people are
// sim::make_subjects of its seed (a hand depends on the seed and the person's id only), accepted when
// their sizes are the ones the corpus recorded ("subject_sizes_mm"); anything else gets the
// reference hand. `description` says which.
struct SubjectHands {
  std::vector<hand::Kinematics> people;  // by subject id; empty: the reference hand for everyone
  std::string description = "the reference hand";
  hand::Kinematics of(int subject) const {
    const auto i = static_cast<std::size_t>(subject);
    return subject >= 0 && i < people.size() ? people[i] : hand::Kinematics();
  }
};

SubjectHands subject_hands(const io::Dataset& data) {
  SubjectHands hands;
  const auto meta = [&](const char* key) {
    const auto it = data.metadata.find(key);
    return it == data.metadata.end() ? std::string() : it->second;
  };
  const std::optional<int> count = number_from_text<int>(meta("subjects"));
  const std::optional<std::uint64_t> seed = number_from_text<std::uint64_t>(meta("seed"));
  if (meta("generator") != "glovepose simulate" || !count || *count < 1 || !seed) return hands;
  const std::vector<sim::Subject> people = sim::make_subjects(*count, *seed);
  io::json::Value recorded;
  try {
    recorded = io::json::parse(meta("subject_sizes_mm"));
  } catch (const Error&) {
    return hands;
  }
  if (!recorded.is_array() || recorded.size() != people.size()) return hands;
  for (const sim::Subject& p : people) {  // written with 6 decimals
    const io::json::Value& r = recorded[static_cast<std::size_t>(p.id)];
    const double size[] = {p.size.length, p.size.width, p.size.height};
    for (std::size_t i = 0; i < 3; ++i)
      if (!r.is_array() || r.size() != 3 || !r[i].is_number() || std::abs(r[i].get<double>() - size[i]) > 1e-5) return hands;
  }
  for (const sim::Subject& p : people) hands.people.emplace_back(p.hand_model());
  hands.description = "each simulated person's own hand";
  return hands;
}

int eval_command(Options o) {
  train::TrainedModel model = train::load_model(o.model, 1024);
  io::Dataset data = read_dataset(o.data);
  apply_exclusions(o, data);
  sensor::ReadoutConfig readout = EstimatorConfig{}.readout;
  if (o.mean_window != 0) readout.mean_window = o.mean_window;
  if (o.replay) train::replay_rows(data, readout);
  const auto [samples, mode] = samples_for(o, model, data);
  report_zeroed(o.command, samples, model.glove);
  const hand::JointLimits limits = model.info.joint_limits();
  core::ThreadPool pool(o.threads);
  const bool guided = eval_guided(o, model, data);
  const std::map<std::int64_t, hand::Angles> offsets =
      guided ? train::guided_offsets(model, data, o.filter, pool) : std::map<std::int64_t, hand::Angles>{};
  const std::vector<float> normalized = model.predict(samples, pool);
  hand::DofSet scored = samples.labelled;  // DoFs with reference angles that the model was trained on
  const hand::DofSet trained = model.info.labelled();
  for (std::size_t d = 0; d < hand::kDofCount; ++d) scored[d] = scored[d] && trained[d];
  if (std::find(scored.begin(), scored.end(), true) == scored.end())
    throw Error("the model was trained on " + hand::dof_set_text(trained) + " and the data labels " + hand::dof_set_text(samples.labelled) +
                ": no DoF to score, expected data labelling a DoF the model was trained on");
  train::AngleErrorAccumulator errors(scored);
  // Simulated data also holds the true angles behind its labels: the same scores against them.
  const bool with_truth = data.has_true_angles();
  train::AngleErrorAccumulator truth_errors(scored);
  std::vector<float> predicted(normalized.size()), truth(with_truth ? normalized.size() : 0);
  // Fingertips and pinches against the true angles when the data has them, else the labels; a new
  // run at every recording (and wherever time does not go forward).
  const SubjectHands hands = subject_hands(data);
  train::FingertipAccumulator tips;
  // --pinch-distances: per frame the true and the predicted thumb-to-fingertip distances and the true
  // pinch flags (hand/pinch.hpp's rule), for sweeping a detector's threshold offline.
  std::unique_ptr<std::FILE, int (*)(std::FILE*)> distances(nullptr, &std::fclose);
  if (!o.pinch_distances_file.empty()) {
    distances.reset(std::fopen(o.pinch_distances_file.c_str(), "w"));
    if (!distances) throw Error("--pinch-distances: cannot open '" + o.pinch_distances_file + "' for writing");
    std::fprintf(distances.get(), "frame,time,subject,session,run_start");
    for (const char* prefix : {"true_mm_", "pred_mm_", "true_on_"})
      for (std::size_t k = 0; k < hand::kPinchPairCount; ++k)
        std::fprintf(distances.get(), ",%s%s", prefix, hand::to_string(static_cast<hand::Finger>(k + 1)));
    std::fprintf(distances.get(), "\n");
  }
  hand::Kinematics run_hand;
  hand::PinchTracker true_pinch;
  // --contact: the stage on each person's own hand (as an estimator configured with the user's
  // hand), its state starting over with every recording; poses adjusted and refused counted.
  std::optional<hand::ContactStage> contact;
  std::size_t contact_adjusted = 0, contact_refused = 0;
  for (long f = 0; f < samples.frames(); ++f) {
    hand::Angles n{};
    for (std::size_t d = 0; d < hand::kDofCount; ++d) n[d] = normalized[static_cast<std::size_t>(f) * hand::kDofCount + d];
    hand::Angles radians = limits.denormalize(n);
    if (guided) radians = calibration::with_offsets(radians, offsets.at(samples.run[static_cast<std::size_t>(f)]), limits);
    double p[hand::kDofCount], t[hand::kDofCount], q[hand::kDofCount];
    const auto source = static_cast<std::size_t>(samples.source[static_cast<std::size_t>(f)]);
    const double time = data.timestamps[source];
    const bool run_start = f == 0 || samples.run[static_cast<std::size_t>(f)] != samples.run[static_cast<std::size_t>(f) - 1] ||
                           !(time > data.timestamps[static_cast<std::size_t>(samples.source[static_cast<std::size_t>(f) - 1])]);
    if (run_start) {
      run_hand = hands.of(data.subject[source]);
      tips.begin_run(run_hand);
      true_pinch.reset();
      if (o.contact) contact.emplace(run_hand, limits);
    }
    const hand::Angles estimate = radians;  // what the contact stage sees
    if (contact) {
      hand::Skeleton skeleton;
      run_hand.pose(radians, skeleton);
      const hand::ContactResult r = contact->apply(radians, skeleton);
      contact_adjusted += r.closed >= 0;
      contact_refused += r.refused;
    }
    for (std::size_t d = 0; d < hand::kDofCount; ++d) {
      const std::size_t i = static_cast<std::size_t>(f) * hand::kDofCount + d;
      p[d] = radians[d];
      t[d] = samples.angles[i];
      predicted[i] = static_cast<float>(p[d]);
      if (with_truth) q[d] = truth[i] = data.true_angles[source * hand::kDofCount + d];
    }
    errors.add(p, t);
    if (with_truth) truth_errors.add(p, q);
    hand::Angles reference{};
    std::copy(with_truth ? q : t, (with_truth ? q : t) + hand::kDofCount, reference.begin());
    tips.add(radians, reference, time);
    if (distances) {
      const hand::PinchDistances truth_mm = hand::pinch_distances(run_hand, reference), pred_mm = hand::pinch_distances(run_hand, estimate);
      const hand::PinchState state = true_pinch.update(truth_mm);
      std::fprintf(distances.get(), "%zu,%.9g,%d,%d,%d", source, time, data.subject[source], data.session[source], run_start ? 1 : 0);
      for (double d : truth_mm) std::fprintf(distances.get(), ",%.4f", d);
      for (double d : pred_mm) std::fprintf(distances.get(), ",%.4f", d);
      for (bool on : state.pinching) std::fprintf(distances.get(), ",%d", on ? 1 : 0);
      std::fprintf(distances.get(), "\n");
    }
  }
  if (distances && std::fclose(distances.release()) != 0) throw Error("--pinch-distances: writing '" + o.pinch_distances_file + "' failed");
  const std::optional<train::FingertipReport> tips_report = tips.empty() ? std::nullopt : std::optional(tips.report());
  const std::string tips_against = with_truth ? "the true angles" : "the labels";
  const train::AngleErrorReport report = errors.report();
  const double frame_ms = 1000.0 / data.frame_rate();
  const double lag_ms = train::lag_frames(predicted, samples.angles, samples.source, samples.run) * frame_ms;
  const std::optional<train::AngleErrorReport> truth_report =
      with_truth ? std::optional(truth_errors.report()) : std::nullopt;
  const double truth_lag_ms = with_truth ? train::lag_frames(predicted, truth, samples.source, samples.run) * frame_ms : 0.0;
  if (!o.predictions_file.empty()) write_predictions(o.predictions_file, data, samples, predicted);
  const std::string calibration = guided ? "guided" : model::to_string(mode);
  const auto window = data.metadata.find("mean_window");
  const std::string mean_window = window == data.metadata.end() ? "null" : window->second;
  const double scored_frames = static_cast<double>(std::max<long>(samples.frames(), 1));
  const std::string contact_json = o.contact ? "{\"adjusted_frames\": " + std::to_string(contact_adjusted) + ", \"refused_frames\": " +
                                                   std::to_string(contact_refused) + "}"
                                             : "null";
  if (o.json) {
    const std::string tips_json = tips_report ? train::to_json(*tips_report, {{"scored_against", with_truth ? "\"truth\"" : "\"labels\""},
                                                                              {"hands", "\"" + hands.description + "\""}})
                                              : "null";
    char lag[32];
    std::snprintf(lag, sizeof lag, "%.3f", lag_ms);
    std::printf("%s\n", train::to_json(report, {{"calibration", "\"" + calibration + "\""},
                                                {"mean_window", mean_window},
                                                {"lag_ms", lag},
                                                {"scored_against", "\"labels\""},
                                                {"vs_labels", train::summary_json(report, lag_ms)},
                                                {"vs_truth", truth_report ? train::summary_json(*truth_report, truth_lag_ms) : "null"},
                                                {"fingertips", tips_json},
                                                {"contact", contact_json}})
                             .c_str());
  } else {
    std::printf("model %s (%s), data %s, calibration %s, readout mean window %s%s\n", o.model.c_str(), model.info.architecture.c_str(),
                o.data.c_str(), calibration.c_str(), mean_window.c_str(), o.replay ? " (rows replayed)" : "");
    std::printf("%s", train::format_table(report).c_str());
    std::printf("Motion lag: %.1f ms (the shift that best aligns the frame-to-frame changes of predicted and reference angles)\n", lag_ms);
    if (truth_report)
      std::printf("Against the true angles behind the labels (simulated data): mean %.2f deg, p95 %.1f deg, %.1f%% under 15 deg, lag %.1f ms\n",
                  truth_report->overall.mean_deg, truth_report->p95_deg, 100.0 * truth_report->share_under_15deg, truth_lag_ms);
    if (o.contact)
      std::printf("Contact stage: %zu poses adjusted (%.1f%%), %zu adjustments refused (collision)\n", contact_adjusted,
                  100.0 * static_cast<double>(contact_adjusted) / scored_frames, contact_refused);
    if (tips_report) std::printf("\n%s", train::format_table(*tips_report, tips_against + ", " + hands.description).c_str());
  }
  return 0;
}

// Fits the model's pose-guided calibration on the selected people and writes the model with it
// (tensors and every other metadata entry unchanged, bit for bit).
int fit_guided_command(Options o) {
  train::TrainedModel model = train::load_model(o.model, 1024);
  io::Dataset data = read_dataset(o.data);
  apply_exclusions(o, data);
  const std::string sequence_file = o.sequence_file.empty() ? shipped_model_path("calibration_glauser2019.json") : o.sequence_file;
  const calibration::Sequence sequence = calibration::Sequence::read(sequence_file);
  core::ThreadPool pool(o.threads);
  const train::PoseOffsetFit fit = train::fit_pose_offset(model, sequence, data, o.filter, pool);
  io::TensorFile file = io::TensorFile::read(o.model, "model file");
  file.metadata["pose_offset"] = fit.model.to_json();
  file.metadata["pose_offset_command"] = o.command_line;
  file.write(o.out, "model file");
  std::printf(
      "fit-guided: %ld people's calibrations; ridge %g; their mean offset %.3f deg, left after the fit %.3f deg (cross-validated); wrote "
      "%s\n",
      fit.runs, fit.ridge, fit.baseline_error_deg, fit.cv_error_deg, o.out.c_str());
  return 0;
}

}  // namespace

std::vector<Command> add_training_commands(CLI::App& tool, const std::string& command_line) {
  const auto add = [&](const char* name, const std::string& description) {
    auto o = std::make_shared<Options>();
    o->command = name;
    o->command_line = command_line;
    return std::pair{tool.add_subcommand(name, description), o};
  };
  std::vector<Command> commands;
  const auto finish = [&](CLI::App* command, const std::shared_ptr<Options>& o, int (*run)(Options)) {
    commands.push_back({command, [o, run] {
                          if (o->threads <= 0) o->threads = static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
                          return run(*o);
                        }});
  };
  {
    auto [command, o] = add("train",
                            "Trains a model on a dataset file on all cores, saving the best so far at every improvement "
                            "(Ctrl-C stops and keeps it).");
    add_parsed_option<Architecture>(
        *command, "--model", "unet:W|fcn[:H]|linear", architecture, [o = o](Architecture a) { o->architecture = std::move(a); },
        "unet:W, fcn[:H] or linear",
        "the network: a U-Net of width W, a fully connected network with H hidden units (default 2048) or a "
        "linear map")
        ->required();
    command->add_option("--out", o->out, "the model file written")->required()->type_name("FILE");
    add_data_options(*command, *o, true);
    add_training_options(
        *command, o,
        {"10, or enough for 2000 steps", "1024 from 102,400 training frames, else about frames/100", "2e-4; 0.01 with sgd for an FCN"});
    command->add_option("--glove", o->glove_file, "the glove description the data was recorded with (default: the built-in glove)")
        ->check(existing_file())
        ->type_name("FILE");
    finish(command, o, train_command);
  }
  {
    auto [command, o] = add("finetune",
                            "Fine-tunes every parameter of a model on a dataset file (the paper's defaults: lr 1e-6, batch 64, "
                            "5 epochs).");
    add_model_file(*command, o->model, "the model to fine-tune")->required();
    command->add_option("--out", o->out, "the model file written")->required()->type_name("FILE");
    add_data_options(*command, *o, true);
    add_training_options(*command, o, {"5", "64", "1e-6"});
    finish(command, o, finetune_command);
  }
  {
    auto [command, o] = add("eval",
                            "Evaluates a model on a dataset file: angle errors per DoF and overall, the motion lag, fingertip "
                            "position errors and pinch detection.");
    add_model_file(*command, o->model, "the model to evaluate")->required();
    add_data_options(*command, *o, true);
    command
        ->add_option("--calibration", o->calibration,
                     "how the inputs are calibrated (default: the model's; guided when the model "
                     "carries a pose-guided calibration and the data followed its sequence)")
        ->check(CLI::IsMember({"none", "training", "onthefly", "guided"}))
        ->type_name("MODE");
    command->add_flag("--json", o->json, "print the report as JSON");
    CLI::Option* replay = command->add_flag("--replay-rows", o->replay, "replay the raw rows through the estimator's readout");
    add_number(*command, "--mean-window", "N", o->mean_window, "the readout's mean window for --replay-rows (default: the estimator's)")
        ->check(at_least(1))
        ->needs(replay);
    command->add_option("--predictions", o->predictions_file, "write every frame's true and predicted angles (CSV)")->type_name("FILE.csv");
    command
        ->add_option("--pinch-distances", o->pinch_distances_file,
                     "write every frame's true and predicted thumb-to-fingertip distances (mm) and true pinch flags (CSV)")
        ->type_name("FILE.csv");
    command->add_flag("--contact", o->contact,
                      "adjust the predicted poses with the contact stage (thumb and finger tips brought together when the pose "
                      "says they touch) before scoring");
    finish(command, o, eval_command);
  }
  {
    auto [command, o] = add("fit-guided",
                            "Fits the model's pose-guided calibration on people it was not trained on and writes the model "
                            "with it.");
    add_model_file(*command, o->model, "the model")->required();
    command->add_option("--out", o->out, "the model file written")->required()->type_name("FILE");
    add_data_options(*command, *o, false);
    command->add_option("--sequence", o->sequence_file, "the calibration sequence (default: the shipped calibration_glauser2019.json)")
        ->check(existing_file())
        ->type_name("FILE");
    finish(command, o, fit_guided_command);
  }
  return commands;
}

}  // namespace glovepose::cli
