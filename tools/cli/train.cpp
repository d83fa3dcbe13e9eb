// glovepose train, finetune, eval and fit-guided: train, fine-tune and evaluate models on dataset
//   files (io/dataset.hpp), on all cores, and fit a model's pose-guided calibration on people it
//   was not trained on (guided_calibration.hpp). The work is the library's (train/evaluate.hpp,
//   train/training_setup.hpp, train/trainer.hpp); the options are train_options.hpp's.
#include <glovepose/estimator_config.hpp>
#include <glovepose/model/model_file.hpp>
#include <glovepose/model/pose_network.hpp>
#include <glovepose/pose_model.hpp>
#include <glovepose/pose_model_options.hpp>
#include <glovepose/sim/subject_hands.hpp>
#include <glovepose/train/checkpoint.hpp>
#include <glovepose/train/evaluate.hpp>
#include <glovepose/train/guided_calibration.hpp>
#include <glovepose/train/model_file.hpp>
#include <glovepose/train/range_map_fit.hpp>
#include <glovepose/train/training_setup.hpp>

#include <algorithm>
#include <atomic>
#include <csignal>
#include <cstdio>
#include <filesystem>
#include <map>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "commands.hpp"
#include "pose_error_fit.hpp"
#include "train_options.hpp"

namespace glovepose::cli {
namespace {

using training::Options;

std::atomic<bool> interrupted{false};
extern "C" void on_interrupt(int) { interrupted.store(true); }

// Tells which sensors each calibration zeroed (a flat range): a glove maker's lost channel.
void report_zeroed(const std::string& command, const train::Samples& samples, const grid::GloveDescription& glove) {
  for (const train::ZeroedSensors& z : train::zeroed_sensors(samples, glove)) std::fprintf(stderr, "%s: %s\n", command.c_str(), z.text().c_str());
}

// Trains (or fine-tunes) a network, with a checkpoint beside --out at every epoch's end (and every
// --checkpoint-minutes within one) that --resume goes on from; --out is written when training
// ends, and the checkpoint then removed (kept when a signal or the time limit stopped it).
int fit_network(Options o, train::TrainableNetwork& net, const model::ModelInfo& info, const train::Samples& all,
                std::map<std::string, std::string> provenance) {
  const train::ValidationParts parts = train::split_validation(all, o.validation, o.validation_split);
  const train::Samples& training = parts.training;
  const train::Samples& validation = parts.validation;
  if (!o.quiet) std::fprintf(stderr, "%s: validation on %s\n", o.command.c_str(), parts.description.c_str());
  if (o.command == "train" && (!o.batch_set || !o.epochs_set)) {  // defaults from the data's size
    if (!o.batch_set) o.training.batch = train::default_batch(training.frames());
    if (!o.epochs_set) o.training.epochs = train::default_epochs(training.frames(), o.training.batch);
    if (!o.quiet)
      std::fprintf(stderr,
                   "train: %ld training frames: batch %d, %d epochs (defaults for this data size: at least %ld steps; "
                   "--batch and --epochs override)\n",
                   training.frames(), o.training.batch, o.training.epochs, train::kMinDefaultSteps);
  }
  core::ThreadPool pool(o.threads);
  train::TrainConfig config = o.training;
  config.stop = &interrupted;
  config.on_progress = training::progress_bar(o.quiet);
  provenance["training_frames"] = std::to_string(training.frames());
  provenance["validation_frames"] = std::to_string(validation.frames());
  const std::string checkpoint = o.out + ".checkpoint";
  train::TrainingState resumed;
  if (std::filesystem::exists(checkpoint)) {
    if (!o.resume)
      throw Error(o.command + ": '" + checkpoint + "' holds a run that was stopped; --resume goes on from it (or delete it to start again)");
    resumed = train::read_checkpoint(checkpoint);
    config.resume = &resumed;
    if (!o.quiet)
      std::fprintf(stderr, "%s: going on from '%s': epoch %d, step %ld\n", o.command.c_str(), checkpoint.c_str(), resumed.epoch + 1,
                   resumed.step);
  }
  config.on_checkpoint = [&](const train::TrainingState& state) { train::write_checkpoint(checkpoint, state); };
  std::signal(SIGINT, on_interrupt);
  if (!o.quiet)
    std::fprintf(stderr, "%s %s (%zu parameters): %ld training frames, %ld validation frames, batch %d, %d threads\n", o.command.c_str(),
                 info.architecture_name().c_str(), net.parameters().trainable_count(), training.frames(), validation.frames(), o.training.batch,
                 o.threads);
  const train::TrainResult result = train::train_network(net, training, validation, info.joint_limits(), config, pool);
  std::signal(SIGINT, SIG_DFL);
  if (result.best_epoch < 0) throw Error("training stopped before the first epoch ended; no model was written");
  provenance["best_epoch"] = std::to_string(result.best_epoch + 1);  // 1-based, as printed
  provenance["validation_error_deg"] = io::number_text(result.best_validation_error_deg);
  provenance["validation"] = parts.description;
  std::string history;  // every epoch's validation error: how the run went
  for (const train::EpochRecord& r : result.epochs) history += (history.empty() ? "" : ",") + io::number_text(r.validation_error_deg);
  provenance["validation_history_deg"] = history;
  train::save_model(o.out, info, result.best, provenance, o.dtype);
  if (!result.stopped) std::filesystem::remove(checkpoint);
  std::printf("%s: %ld steps in %s (%.0f samples/s); kept epoch %d, validation error %.3f deg; wrote %s%s\n",
              result.stopped ? "stopped" : "done", result.steps, training::duration(result.seconds).c_str(), result.samples_per_second,
              result.best_epoch + 1, result.best_validation_error_deg, o.out.c_str(),
              result.stopped ? ("; --resume goes on from " + checkpoint).c_str() : "");
  return interrupted.load() ? 130 : 0;
}

// Trains one model of `glove` (its conditioning included) on `data` into o.out.
int train_with(Options o, const io::Dataset& data, const grid::GloveDescription& glove, model::CalibrationMode mode) {
  const std::string& architecture = o.architecture.name;
  const train::TrainingSetup setup = train::prepare_training(data, o.filter, o.stride, architecture, o.architecture.width, glove, mode);
  report_zeroed(o.command, setup.samples, glove);
  if (setup.samples.labelled != hand::all_dofs() && !o.quiet)
    std::fprintf(stderr, "%s: the data labels %zu of the 25 DoFs; the others are not trained and read the rest pose\n", o.command.c_str(),
                 static_cast<std::size_t>(std::count(setup.samples.labelled.begin(), setup.samples.labelled.end(), true)));
  std::map<std::string, std::string> provenance{
      {"training_command", o.command_line}, {"training_seed", std::to_string(o.training.seed)}, {"training_data", o.data}};
  if (o.architecture.kind == model::Architecture::Linear) {
    if (o.training.augmentation.active())
      throw CLI::ValidationError("--augment trains networks; a linear map is fitted by least squares on the frames as they are");
    const train::LinearModelFit fit = train::fit_linear_model(setup.samples, o.validation, setup.info.joint_limits(), o.validation_split);
    if (!o.quiet) std::fprintf(stderr, "%s: validation on %s\n", o.command.c_str(), fit.validation.c_str());
    provenance["training_frames"] = std::to_string(fit.training_frames);
    provenance["validation_frames"] = std::to_string(fit.validation_frames);
    provenance["validation_error_deg"] = io::number_text(fit.validation_error_deg);
    provenance["validation"] = fit.validation;
    train::save_model(o.out, setup.info, train::linear_tensors(fit.map), provenance, o.dtype);
    std::printf("done: linear least squares on %ld frames; validation error %.3f deg; wrote %s\n", fit.training_frames,
                fit.validation_error_deg, o.out.c_str());
    return 0;
  }
  if (o.architecture.kind == model::Architecture::Fcn && !o.lr_set && o.training.optimizer.kind == train::OptimizerKind::Sgd)
    o.training.optimizer.learning_rate = 0.01;  // the paper's SGD rate for the FCN
  const std::unique_ptr<train::TrainableNetwork> net = train::make_network(setup.info, glove, o.training.batch);
  net->initialize(o.training.seed);
  return fit_network(o, *net, setup.info, setup.samples, provenance);
}

// `glove` with every input demeaned over `seconds` (0: every input as read), at the data's rate when it states none.
grid::GloveDescription with_demean(const grid::GloveDescription& glove, double seconds, double rate) {
  grid::GloveSettings settings = glove.settings();
  settings.demean_seconds.assign(seconds > 0.0 ? static_cast<std::size_t>(glove.cell_count()) : 0, seconds);
  if (!settings.rate_hz) settings.rate_hz = rate;
  return grid::GloveDescription(glove.id(), glove.cell_names(), glove.map(), settings);
}

int train_command(Options o) {
  if (o.architecture.name.empty()) throw CLI::RequiredError("--architecture");
  const io::Dataset data = read_dataset(o.data);
  o.filter = train::exclude_subjects(o.filter, data, o.exclude_subjects);
  const grid::GloveDescription glove = train::glove_for_data(
      data, o.glove_file.empty() ? grid::GloveDescription::glauser2019() : grid::GloveDescription::read(o.glove_file));
  const model::CalibrationMode mode = model::calibration_mode(o.calibration.empty() ? "onthefly" : o.calibration);
  if (o.demean_seconds.empty()) return train_with(o, data, glove, mode);
  // --demean-seconds: a model per window, trained alike; the one with the least validation error
  // (on held-out runs when there are two or more) is kept.
  struct Candidate {
    double seconds;
    std::string path;
    double error;
  };
  std::vector<Candidate> candidates;
  for (const double seconds : o.demean_seconds) {
    if (!(seconds >= 0.0)) throw CLI::ValidationError("--demean-seconds", io::number_text(seconds) + ", expected seconds >= 0 (0: as read)");
    Options one = o;
    one.out = o.out + ".demean-" + io::number_text(seconds) + ".safetensors";
    if (!o.quiet) std::fprintf(stderr, "%s: inputs demeaned over %s s (0: as read) ...\n", o.command.c_str(), io::number_text(seconds).c_str());
    if (const int status = train_with(one, data, with_demean(glove, seconds, data.frame_rate()), mode); status != 0) return status;
    candidates.push_back({seconds, one.out, std::stod(nn::WeightFile::read(one.out).metadata.at("validation_error_deg"))});
  }
  const auto best = std::min_element(candidates.begin(), candidates.end(), [](const Candidate& a, const Candidate& b) { return a.error < b.error; });
  for (const Candidate& c : candidates) {
    std::printf("demean %s s: validation error %.3f deg%s\n", io::number_text(c.seconds).c_str(), c.error, &c == &*best ? " (kept)" : "");
    if (&c != &*best) std::filesystem::remove(c.path);
  }
  std::filesystem::rename(best->path, o.out);
  std::printf("wrote %s: inputs demeaned over %s s (the glove description it carries says so)\n", o.out.c_str(),
              io::number_text(best->seconds).c_str());
  return 0;
}

int finetune_command(Options o) {
  // The paper's fine-tuning (Sec. 5.2, scenario 5): all parameters, lr 1e-6, batch 64.
  if (!o.lr_set) o.training.optimizer.learning_rate = 1e-6;
  if (!o.batch_set) o.training.batch = 64;
  if (!o.epochs_set) o.training.epochs = 5;
  train::TrainedModel model = train::load_model(o.model, o.training.batch);
  if (!model.network)
    throw Error("model '" + o.model + "' is " + model.info.architecture_name() + ", expected a network (unet or fcn) to fine-tune");
  check_glove(o.glove_file, model.glove, o.model);
  const io::Dataset data = read_dataset(o.data);
  o.filter = train::exclude_subjects(o.filter, data, o.exclude_subjects);
  const train::Samples all = train::samples_for_model(model, data, o.filter, o.stride, o.calibration).first;
  report_zeroed(o.command, all, model.glove);
  std::map<std::string, std::string> provenance = model.metadata;
  provenance["finetune_command"] = o.command_line;
  provenance["finetune_data"] = o.data;
  return fit_network(o, *model.network, model.info, all, provenance);
}

int eval_command(Options o) {
  train::TrainedModel model = train::load_model(o.model, 1024);
  check_glove(o.glove_file, model.glove, o.model);
  const io::Dataset data = read_dataset(o.data);
  train::EvaluationOptions options;
  options.weights = o.storage;
  options.filter = train::exclude_subjects(o.filter, data, o.exclude_subjects);
  options.stride = o.stride;
  options.calibration = o.calibration;
  if (o.replay) {
    options.replay = EstimatorConfig{}.readout;
    if (o.mean_window != 0) options.replay->mean_window = o.mean_window;
  }
  options.contact = o.contact;
  options.pinch_distances = !o.pinch_distances_file.empty();
  options.hands = sim::subject_hands(data);
  options.threads = o.threads;
  const train::EvaluationResult result = train::evaluate(model, data, options);
  for (const train::ZeroedSensors& z : result.zeroed) std::fprintf(stderr, "%s: %s\n", o.command.c_str(), z.text().c_str());
  if (!o.pinch_distances_file.empty()) train::write_pinch_distances(o.pinch_distances_file, data, result, "--pinch-distances");
  if (!o.predictions_file.empty()) train::write_predictions(o.predictions_file, data, result, "--predictions");
  if (o.json) {
    std::printf("%s\n", train::to_json(result).c_str());
  } else {
    std::printf("model %s (%s, %s weights), data %s, calibration %s, readout mean window %s%s\n", o.model.c_str(),
                model.info.architecture_name().c_str(), nn::storage_name(result.weights), o.data.c_str(), result.calibration.c_str(),
                result.mean_window.value_or("null").c_str(), result.rows_replayed ? " (rows replayed)" : "");
    std::printf("%s", train::format_text(result).c_str());
  }
  return 0;
}

// Fits the model's pose-guided calibration on the selected people and writes the model with it
// (tensors and every other metadata entry unchanged, bit for bit).
int fit_guided_command(Options o) {
  train::TrainedModel model = train::load_model(o.model, 1024);
  const io::Dataset data = read_dataset(o.data);
  o.filter = train::exclude_subjects(o.filter, data, o.exclude_subjects);
  const std::string sequence_file = o.sequence_file.empty() ? shipped_model_path("calibration_glauser2019.json") : o.sequence_file;
  const calibration::Sequence sequence = calibration::Sequence::read(sequence_file);
  core::ThreadPool pool(o.threads);
  const train::PoseOffsetFit fit = train::fit_pose_offset(model, sequence, data, o.filter, pool);
  std::optional<io::Dataset> conditioned;
  std::optional<train::RangeMapFit> ranges;
  try {
    ranges = train::fit_range_map(train::conditioned_for(data, model.glove, conditioned), o.filter, model.glove.calibration());
  } catch (const Error& e) {  // the pose offsets stand on their own: written without a range map, and said so
    std::fprintf(stderr, "fit-guided: no range map (the continuous calibration): %s\n", e.what());
  }
  io::TensorFile file = io::TensorFile::read(o.model, "model file");
  file.metadata["pose_offset"] = fit.model.to_json();
  if (ranges)
    file.metadata["range_map"] = ranges->map.to_json();
  else
    file.metadata.erase("range_map");
  file.metadata.erase("pose_error");
  // The model's own errors, measured through the estimator with the calibrations just fitted.
  std::optional<cli::PoseErrorFit> errors;
  try {
    nn::WeightFile weights = nn::WeightFile::read(o.model);
    weights.metadata = file.metadata;
    model::ModelFile parts = model::ModelFile::from(std::move(weights));
    PoseModel::Network network = PoseModel::Network::from_tensors(parts.info, parts.tensors, nn::WeightStorage::F32);
    const auto runtime = std::make_shared<const PoseModel>(std::move(parts.info), std::move(network), PoseModelOptions{});
    errors = cli::fit_pose_error(runtime, data, o.filter, pool);
    file.metadata["pose_error"] = errors->model.to_json();
  } catch (const Error& e) {  // the calibrations stand on their own: written without, and said so
    std::fprintf(stderr, "fit-guided: no pose error (the per-joint confidence): %s\n", e.what());
  }
  file.metadata["pose_offset_command"] = o.command_line;
  file.write(o.out, "model file");
  std::printf(
      "fit-guided: %ld people's calibrations; ridge %g; their mean offset %.3f deg, left after the fit %.3f deg (cross-validated)\n",
      fit.runs, fit.ridge, fit.baseline_error_deg, fit.cv_error_deg);
  if (ranges) {
    std::printf("fit-guided: range map from free motion, %ld runs; mean limit error in prior ranges (cross-validated), map / prior:",
                ranges->runs);
    for (const train::RangeMapFit::StageFigures& s : ranges->stages) std::printf(" %g frames %.3f/%.3f", s.frames, s.map_error, s.prior_error);
    std::printf("\n");
  }
  if (errors)
    std::printf(
        "fit-guided: the model's own errors through the estimator, %ld runs: still %.2f deg RMS (guided), speed %.0f%% of the error "
        "variance, a cell stood in for %.2f deg RMS\n",
        errors->runs, errors->guided_rms_deg, 100.0 * errors->speed_share, errors->masked_rms_deg);
  std::printf("fit-guided: wrote %s\n", o.out.c_str());
  return 0;
}

}  // namespace

std::vector<Command> add_training_commands(CLI::App& tool, const std::string& command_line) {
  // A command reading --model FILE (`model_help`, unless null) and writing --out FILE (`writes`).
  const auto add = [&](const char* name, const std::string& description, const char* model_help, bool writes) {
    auto o = std::make_shared<Options>();
    o->command = name;
    o->command_line = command_line;
    CLI::App* command = tool.add_subcommand(name, description);
    if (model_help) add_model_file(*command, o->model, model_help)->required();
    if (writes) command->add_option("--out", o->out, "the model file written")->required()->type_name("FILE");
    return std::pair{command, o};
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
                            "Trains a model on a dataset file on all cores, with a checkpoint at every epoch's end that --resume "
                            "goes on from (Ctrl-C stops and writes the best model so far).",
                            nullptr, true);
    const auto store = [o = o](training::Architecture a) { o->architecture = std::move(a); };
    CLI::Option* architecture = add_parsed_option<training::Architecture>(
        *command, "--architecture", "unet:W|fcn[:H]|linear", training::architecture, store, "unet:W, fcn[:H] or linear",
        "the network: a U-Net of width W (default 64), a fully connected network with H hidden units (default 2048) or a linear map");
    // --model is a model file everywhere else; here it was the architecture: kept, and says so.
    training::add_alias(*command, "--model", "--architecture", "unet:W|fcn[:H]|linear",
                        [store](const std::string& text) {
                          const std::optional<training::Architecture> a = training::architecture(text);
                          if (!a) throw CLI::ValidationError("--model", "'" + text + "', expected unet:W, fcn[:H] or linear");
                          store(*a);
                        })
        ->excludes(architecture);
    training::add_data_options(*command, *o, true);
    training::add_training_options(
        *command, o,
        {"10, or enough for 2000 steps", "1024 from 102,400 training frames, else about frames/100", "2e-4; 0.01 with sgd for an FCN"});
    add_glove_file(*command, o->glove_file, "the glove description the data was recorded with (default: the built-in glove)");
    command->add_option("--demean-seconds", o->demean_seconds,
                        "S[,S...]: take off each input's rolling mean over its last S seconds (a drift-removing high-pass; 0: as read), "
                        "as the glove description's demean_seconds; several: a model each, the one with the least validation error "
                        "kept and the comparison printed")
        ->delimiter(',')
        ->type_name("S[,S...]");
    finish(command, o, train_command);
  }
  {
    auto [command, o] = add("finetune",
                            "Fine-tunes every parameter of a model on a dataset file (the paper's defaults: lr 1e-6, batch 64, "
                            "5 epochs).",
                            "the model to fine-tune", true);
    training::add_data_options(*command, *o, true);
    training::add_training_options(*command, o, {"5", "64", "1e-6"});
    add_glove_file(*command, o->glove_file, "the glove description the data was recorded with: refused unless it is the model's");
    finish(command, o, finetune_command);
  }
  {
    auto [command, o] = add("eval",
                            "Evaluates a model on a dataset file: angle errors per DoF and overall, the motion lag, fingertip "
                            "position errors and pinch detection.",
                            "the model to evaluate", false);
    training::add_data_options(*command, *o, true);
    training::add_eval_options(*command, *o);
    finish(command, o, eval_command);
  }
  {
    auto [command, o] = add("fit-guided",
                            "Fits the model's pose-guided calibration and its range map (calibration without a calibration "
                            "step) on people it was not trained on and writes the model with them.",
                            "the model", true);
    training::add_data_options(*command, *o, false);
    command->add_option("--sequence", o->sequence_file, "the calibration sequence (default: the shipped calibration_glauser2019.json)")
        ->check(existing_file())
        ->type_name("FILE");
    finish(command, o, fit_guided_command);
  }
  return commands;
}

}  // namespace glovepose::cli
