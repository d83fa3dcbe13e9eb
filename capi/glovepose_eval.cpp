// glovepose_eval.h: offline evaluation (train::evaluate) for C and Python, apart from glovepose_c so
// that the engines' library holds no training or simulator code. Errors go through capi/'s
// last-error helpers into this library's own buffer (glovepose_eval_last_error).
#define GLOVEPOSE_EVAL_BUILDING
#include "glovepose_eval.h"

#include "last_error.hpp"

#include <glovepose/estimator_config.hpp>
#include <glovepose/io/json.hpp>
#include <glovepose/sim/subject_hands.hpp>
#include <glovepose/train/evaluate.hpp>
#include <glovepose/train/training_setup.hpp>

#include <algorithm>
#include <optional>
#include <string>
#include <vector>

using glovepose::capi::fail;
using glovepose::capi::fail_from_exception;

namespace {

// The options of glovepose_evaluate (glovepose_eval.h names them; the same as `glovepose eval`'s) for
// `model`. Throws glovepose::Error naming a key that is unknown or of the wrong type, and a glove
// description other than the model's (as eval --glove refuses it).
glovepose::train::EvaluationOptions evaluation_options(const char* text, const glovepose::io::Dataset& data,
                                                       const glovepose::train::TrainedModel& model) {
  using glovepose::Error;
  namespace json = glovepose::io::json;
  glovepose::train::EvaluationOptions o;
  const json::Value root = json::parse(text == nullptr || *text == '\0' ? "{}" : text);
  if (!root.is_object()) throw Error("options_json is " + json::describe(root) + ", expected a JSON object");
  const auto whole = [](const json::Value& v, const std::string& key, long least) {
    if (!v.is_number_integer() || v.get<long>() < least)
      throw Error("options_json: \"" + key + "\" is " + json::describe(v) + ", expected a whole number >= " + std::to_string(least));
    return v.get<long>();
  };
  const auto flag = [](const json::Value& v, const std::string& key) {
    if (!v.is_boolean()) throw Error("options_json: \"" + key + "\" is " + json::describe(v) + ", expected true or false");
    return v.get<bool>();
  };
  std::vector<int> excluded;
  std::optional<long> mean_window;
  bool replay = false;
  for (const auto& [key, v] : root.items()) {
    if (key == "subjects" || key == "exclude_subjects" || key == "sessions" || key == "gloves") {
      if (!v.is_array()) throw Error("options_json: \"" + key + "\" is " + json::describe(v) + ", expected an array of ids");
      std::vector<int>& ids = key == "subjects" ? o.filter.subjects
                              : key == "sessions" ? o.filter.sessions
                              : key == "gloves"   ? o.filter.gloves
                                                  : excluded;
      for (const json::Value& id : v) ids.push_back(static_cast<int>(whole(id, key, 0)));
    } else if (key == "stride") {
      o.stride = static_cast<int>(std::min(whole(v, key, 1), 1L << 30));
    } else if (key == "threads") {
      o.threads = static_cast<int>(std::min(whole(v, key, 0), 4096L));
    } else if (key == "calibration_mode") {
      if (!v.is_string()) throw Error("options_json: \"calibration_mode\" is " + json::describe(v) + ", expected a string");
      o.calibration = v.get<std::string>();
    } else if (key == "replay_rows") {
      replay = flag(v, key);
    } else if (key == "mean_window") {
      mean_window = std::min(whole(v, key, 1), 1L << 20);
    } else if (key == "contact") {
      o.contact = flag(v, key);
    } else if (key == "weights") {
      const auto named = v.is_string() ? glovepose::nn::storage_of_word(v.get<std::string>()) : std::nullopt;
      if (!named)
        throw Error("options_json: \"weights\" is " + json::describe(v) + ", expected \"f32\", \"f16\", \"bf16\" or \"fixed16\"");
      o.weights = *named;
    } else if (key == "glove") {
      if (!v.is_string()) throw Error("options_json: \"glove\" is " + json::describe(v) + ", expected a glove description file's path");
      const glovepose::grid::GloveDescription glove = glovepose::grid::GloveDescription::read(v.get<std::string>());
      if (glove != model.glove)
        throw Error("options_json: the glove of '" + v.get<std::string>() + "' ('" + glove.id() + "', " + std::to_string(glove.cell_count()) +
                    " cells) is not the one the model was trained for ('" + model.glove.id() + "', " +
                    std::to_string(model.glove.cell_count()) + " cells), expected the same description");
    } else {
      throw Error("options_json: unknown key \"" + key +
                  "\", expected subjects, exclude_subjects, sessions, gloves, stride, calibration_mode, replay_rows, mean_window, "
                  "contact, threads, weights or glove");
    }
  }
  if (mean_window && !replay) throw Error("options_json: \"mean_window\" needs \"replay_rows\": true");
  if (replay) {
    o.replay = glovepose::EstimatorConfig{}.readout;
    if (mean_window) o.replay->mean_window = static_cast<int>(*mean_window);
  }
  o.filter = glovepose::train::exclude_subjects(o.filter, data, excluded);
  return o;
}

thread_local std::string evaluation_json;  // what glovepose_evaluate returned last on this thread

}  // namespace

extern "C" {

glovepose_result glovepose_evaluate(const char* model_path, const char* dataset_path, const char* options_json,
                                    const char** out_json) noexcept {
  if (out_json == nullptr) return fail(GLOVEPOSE_ERROR_INVALID_ARGUMENT, "glovepose_evaluate: out_json is NULL");
  *out_json = nullptr;
  if (model_path == nullptr || dataset_path == nullptr)
    return fail(GLOVEPOSE_ERROR_INVALID_ARGUMENT, "glovepose_evaluate: model_path or dataset_path is NULL");
  std::optional<glovepose::train::TrainedModel> model;
  std::optional<glovepose::io::Dataset> data;
  const char* reading = model_path;
  try {
    model.emplace(glovepose::train::load_model(model_path, 1024));
    reading = dataset_path;
    data.emplace(glovepose::io::Dataset::read(dataset_path));
  } catch (...) {
    return fail_from_exception(reading, GLOVEPOSE_ERROR_INVALID_FILE);
  }
  glovepose::train::EvaluationOptions options;
  try {
    options = evaluation_options(options_json, *data, *model);
  } catch (...) {
    return fail_from_exception(nullptr, GLOVEPOSE_ERROR_INVALID_ARGUMENT);
  }
  try {
    options.hands = glovepose::sim::subject_hands(*data);
    evaluation_json = glovepose::train::to_json(glovepose::train::evaluate(*model, *data, options));
    *out_json = evaluation_json.c_str();
    return GLOVEPOSE_OK;
  } catch (...) {
    return fail_from_exception(nullptr, GLOVEPOSE_ERROR_INVALID_FILE);
  }
}

const char* glovepose_eval_last_error(void) noexcept { return glovepose::capi::last_error_text; }

}  // extern "C"
