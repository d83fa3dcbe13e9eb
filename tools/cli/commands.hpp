// The glovepose tool's commands other than predict/info, each in its own file, and the
// command-line set-up they share (CLI11).
#pragma once

#include <glovepose/config.hpp>
#include <glovepose/io/number_text.hpp>
#include <glovepose/nn/weight_storage.hpp>
#include <glovepose/io/dataset.hpp>
#include <glovepose/grid/glove_description.hpp>
#include <glovepose/io/tensor_file.hpp>

#include <CLI/CLI.hpp>

#include <algorithm>
#include <charconv>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <functional>
#include <limits>
#include <optional>
#include <string>
#include <system_error>
#include <utility>
#include <vector>

#ifdef _WIN32
#  include <windows.h>  // GetModuleFileNameW
#endif

namespace glovepose::cli {

/// A command of the tool: its options (a subcommand of the tool's CLI::App) and what runs it once
/// they are parsed, returning the exit code. A glovepose::Error it throws is a runtime failure
/// (exit code 1), a CLI::ParseError a usage error (exit code 2), as one from parsing.
struct Command {
  CLI::App* options = nullptr;
  std::function<int()> run;
};

/// `glovepose simulate` (simulate.cpp).
Command add_simulate(CLI::App& tool);
/// `glovepose train`, `finetune`, `eval` and `fit-guided` (train.cpp); `command_line` is recorded
/// in the models they write.
std::vector<Command> add_training_commands(CLI::App& tool, const std::string& command_line);
/// `glovepose import` (import.cpp).
Command add_import(CLI::App& tool);
/// `glovepose demo` (demo.cpp).
Command add_demo(CLI::App& tool);
/// `glovepose soak` (soak.cpp).
Command add_soak(CLI::App& tool);
/// `glovepose bench` (bench.cpp).
Command add_bench(CLI::App& tool);
/// `glovepose view` (view.cpp).
Command add_view(CLI::App& tool);
/// `glovepose record` (record.cpp).
Command add_record(CLI::App& tool);
/// `glovepose serve` (serve.cpp).
Command add_serve(CLI::App& tool);

/// A file shipped in models/ (a model, the calibration sequence): where `cmake --install` puts them
/// relative to the executable (GLOVEPOSE_MODELS_FROM_BIN, ../share/glovepose/models by default);
/// the build tree has the same layout (build/share/glovepose/models links to the source's
/// models/). Throws glovepose::Error naming the place tried.
inline std::string shipped_model_path(const std::string& name) {
  namespace fs = std::filesystem;
  std::error_code error;
#ifdef _WIN32
  std::wstring buffer(32768, L'\0');  // the longest path Windows has
  const DWORD length = GetModuleFileNameW(nullptr, buffer.data(), static_cast<DWORD>(buffer.size()));
  if (length == 0 || length >= buffer.size()) throw Error("cannot find this executable (GetModuleFileNameW), expected --model FILE");
  const fs::path executable(buffer.substr(0, length));
#else
  const fs::path executable = fs::read_symlink("/proc/self/exe", error);
  if (error) throw Error("cannot find this executable (/proc/self/exe: " + error.message() + "), expected --model FILE");
#endif
  const fs::path candidate = (executable.parent_path() / GLOVEPOSE_MODELS_FROM_BIN / name).lexically_normal();
  if (!fs::is_regular_file(candidate, error))
    throw Error("the shipped file '" + candidate.string() +
                "' is missing (install glovepose with cmake --install), expected it or --model FILE");
  return candidate.string();
}

/// A dataset file (io::Dataset::read); a CSV file given instead is refused with the command
/// that imports it.
inline io::Dataset read_dataset(const std::string& path) {
  try {
    return io::Dataset::read(path);
  } catch (const Error& e) {
    std::ifstream file(path, std::ios::binary);
    std::string start(256, '\0');
    file.read(start.data(), static_cast<std::streamsize>(start.size()));
    start.resize(static_cast<std::size_t>(file.gcount()));
    const bool text = !start.empty() && std::all_of(start.begin(), start.end(), [](char c) {
      return c == '\n' || c == '\r' || c == '\t' || (static_cast<unsigned char>(c) >= 0x20 && c != 0x7f);
    });
    if (!text || start.find(',') == std::string::npos) throw;
    throw Error(std::string(e.what()) +
                "; the file is CSV text, not a dataset file: import it first with "
                "glovepose import --rate HZ [--glove FILE] --out DATA.safetensors " +
                path + " (see glovepose import --help)");
  }
}

/// `text` as a number of type T when it is one: decimal (no 0x or octal prefix, no sign on an
/// unsigned type), the same in every locale, nothing before or after it. CLI11 2.1's own conversion
/// (strtoull, strtold with base 0) would read "010" as 8 and "-1" as the largest unsigned.
template <typename T>
std::optional<T> number_from_text(const std::string& text) {
  T value{};
  const auto result = std::from_chars(text.data(), text.data() + text.size(), value);
  if (text.empty() || result.ec != std::errc() || result.ptr != text.data() + text.size()) return std::nullopt;
  return value;
}

/// Adds option `name` (its value shown as `value_name`) whose text `parse` turns into a T for
/// `store`; text it refuses (nullopt) is a usage error naming the option and what was `expected`.
/// Validators added to the option afterwards (CLI::Range) see only text `parse` took.
template <typename T>
CLI::Option* add_parsed_option(CLI::App& command, const std::string& name, const std::string& value_name,
                               std::function<std::optional<T>(const std::string&)> parse, std::function<void(T)> store,
                               const std::string& expected, const std::string& description) {
  const CLI::Validator parses(
      [parse, expected](std::string& text) { return parse(text) ? std::string() : "'" + text + "', expected " + expected; }, "", "");
  return command
      .add_option_function<std::string>(
          name, [parse, store](const std::string& text) { store(*parse(text)); }, description)
      ->check(parses)
      ->type_name(value_name);
}

/// Adds option `name` reading a number of type T (number_from_text) for `store`.
template <typename T>
CLI::Option* add_number_option(CLI::App& command, const std::string& name, const std::string& value_name, std::function<void(T)> store,
                               const std::string& description) {
  return add_parsed_option<T>(command, name, value_name, number_from_text<T>, std::move(store), "a number such as 2026 or 1.5",
                              description);
}

/// Adds option `name` reading a number into `target` (a T or a std::optional<T>).
template <typename T>
CLI::Option* add_number(CLI::App& command, const std::string& name, const std::string& value_name, T& target,
                        const std::string& description) {
  return add_number_option<T>(
      command, name, value_name, [&target](T value) { target = value; }, description);
}
template <typename T>
CLI::Option* add_number(CLI::App& command, const std::string& name, const std::string& value_name, std::optional<T>& target,
                        const std::string& description) {
  return add_number_option<T>(
      command, name, value_name, [&target](T value) { target = value; }, description);
}

/// Accepts finite numbers in [least, most], or (least, most] when `least_excluded`, for bounds
/// CLI::Range cannot express: it includes both ends and its message would print an open one
/// (DBL_MAX) in full.
inline CLI::Validator bounded(double least, bool least_excluded, double most = std::numeric_limits<double>::infinity()) {
  const std::string bounds = std::isinf(most) ? (least_excluded ? "> " : ">= ") + io::number_text(least)
                                              : (least_excluded ? "(" : "[") + io::number_text(least) + ", " + io::number_text(most) + "]";
  return CLI::Validator(
      [=](std::string& text) {
        const std::optional<double> value = number_from_text<double>(text);
        const bool inside = value && std::isfinite(*value) && (least_excluded ? *value > least : *value >= least) && *value <= most;
        return inside ? std::string() : "'" + text + "', expected a number " + (std::isinf(most) ? bounds : "in " + bounds);
      },
      bounds, "bounded");
}
/// Accepts finite numbers >= `least`.
inline CLI::Validator at_least(double least) { return bounded(least, false); }
/// Accepts finite numbers > `least` (and <= `most`).
inline CLI::Validator above(double least, double most = std::numeric_limits<double>::infinity()) { return bounded(least, true, most); }

/// CLI::ExistingFile without its description, which would repeat FILE after the value's name. A
/// function, not a variable: a namespace-scope copy may be initialised before CLI11's own
/// ExistingFile (the order is unspecified; with clang it was, and the check did nothing).
inline CLI::Validator existing_file() { return CLI::ExistingFile.description(""); }

/// Adds `--model FILE`: a model file that must exist (`path` a string, or a vector when repeatable).
template <typename Target>
CLI::Option* add_model_file(CLI::App& command, Target& path, const std::string& description) {
  return command.add_option("--model", path, description)->check(existing_file())->type_name("FILE");
}

/// Adds `--weights f32|f16|bf16|fixed16`, the tool's one spelling of how a loaded model keeps its
/// weights in memory (default F32; train's --weights is the same words for the file it writes), and,
/// where a command had them (`old_spellings`), the older flags `--fixed16`, `--f16`, `--bf16` as
/// aliases; any two of them exclude each other.
inline void add_weight_storage(CLI::App& command, nn::WeightStorage& storage, bool old_spellings = true) {
  std::string words;
  for (int s = 0; s < nn::kWeightStorageCount; ++s)
    words += (words.empty() ? "" : "|") + std::string(nn::storage_word(static_cast<nn::WeightStorage>(s)));
  std::vector<CLI::Option*> added{add_parsed_option<nn::WeightStorage>(
      command, "--weights", words,
      [](const std::string& text) { return nn::storage_of_word(text); },
      [&storage](nn::WeightStorage chosen) { storage = chosen; }, "one of " + words,
      "how the weights are kept in memory: f32 (default), f16, bf16 (the fastest) or fixed16 (16-bit, within 0.005 "
      "degree of F32 on the shipped model)")};
  for (int s = 1; old_spellings && s < nn::kWeightStorageCount; ++s) {  // every storage but F32
    const auto chosen = static_cast<nn::WeightStorage>(s);
    added.push_back(command
                        .add_flag_callback(
                            std::string("--") + nn::storage_word(chosen), [&storage, chosen] { storage = chosen; },
                            std::string("the same as --weights ") + nn::storage_word(chosen))
                        ->group("Old spellings"));
  }
  for (CLI::Option* option : added)
    for (CLI::Option* other : added)
      if (option != other) option->excludes(other);
}

/// What a model file stores its weights as on disk ("F16", or "F16 and F32" when mixed), read from
/// the file's header: the memory storage (--weights) can differ.
inline std::string stored_dtypes(const std::string& model_path) {
  std::vector<io::DType> seen;
  for (const auto& [name, tensor] : io::TensorFile::read(model_path, "model file").tensors)
    if (std::find(seen.begin(), seen.end(), tensor.dtype) == seen.end()) seen.push_back(tensor.dtype);
  std::sort(seen.begin(), seen.end());
  std::string text;
  for (std::size_t i = 0; i < seen.size(); ++i) text += (i == 0 ? "" : (i + 1 == seen.size() ? " and " : ", ")) + std::string(io::dtype_name(seen[i]));
  return text;
}

/// Adds `--glove FILE`, the tool's one spelling of a glove description (JSON, docs/own_glove.md):
/// where data is made or imported it says which glove recorded it; where a model meets the glove's
/// readings (check_glove) it must be the glove the model was trained for.
inline CLI::Option* add_glove_file(CLI::App& command, std::string& path, const std::string& description) {
  return command.add_option("--glove", path, description)->check(existing_file())->type_name("FILE");
}

/// The glove of `path` (--glove) against the glove the model reads: a model trained for another
/// glove would read the cells in the wrong places, so a difference is refused. Nothing when empty.
inline void check_glove(const std::string& path, const grid::GloveDescription& model_glove, const std::string& model_path) {
  if (path.empty()) return;
  const grid::GloveDescription glove = grid::GloveDescription::read(path);
  if (glove != model_glove)
    throw Error("the glove of '" + path + "' ('" + glove.id() + "', " + std::to_string(glove.cell_count()) +
                " cells) is not the one the model '" + model_path + "' was trained for ('" + model_glove.id() + "', " +
                std::to_string(model_glove.cell_count()) + " cells; glovepose info shows it), expected the same description");
}

/// Default of --calibration-seconds: stream time the user moves through extreme poses.
inline constexpr double kDefaultCalibrationSeconds = 30.0;

/// Adds how a glove's stream is calibrated: `--calibration-seconds S` (on the fly, `seconds`) or
/// `--calibration FILE` (a saved one, `file`), one or the other, both needing `needs` when given.
inline void add_glove_line_calibration(CLI::App& command, double& seconds, bool& seconds_given, std::string& file, CLI::Option* needs) {
  CLI::Option* on_the_fly =
      add_number(command, "--calibration-seconds", "S", seconds,
                 "the first S seconds of stream time calibrate on the fly while the user moves through extreme poses (default 30; "
                 "without it, a model trained with --calibration-mode training uses its training-set range); 0: no calibration step, "
                 "poses from the first frame, calibrated from the wearer's free motion (a model with a range map: glovepose fit-guided)")
          ->check(at_least(0.0))
          ->each([&seconds_given](const std::string&) { seconds_given = true; });
  CLI::Option* saved = command
                           .add_option("--calibration", file,
                                       "a saved calibration of this user and glove (glovepose predict --save-calibration, or the "
                                       "estimator's save_calibration()) instead of calibrating on the fly")
                           ->check(existing_file())
                           ->type_name("FILE")
                           ->excludes(on_the_fly);
  if (needs != nullptr) {
    on_the_fly->needs(needs);
    saved->needs(needs);
  }
}

}  // namespace glovepose::cli
