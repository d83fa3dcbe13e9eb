// The options of the commands that run a model on a simulated user's session (glovepose demo,
// glovepose view), and the shipped models they and bench default to: written once so that the
// commands spell, default and load them alike.
#pragma once

#include <glovepose/pose_model.hpp>
#include <glovepose/pose_model_options.hpp>

#include <cstdint>
#include <memory>
#include <string>

#include "commands.hpp"

namespace glovepose::cli {

/// The shipped models (models/): the FCN is the default model of every command that runs one.
inline constexpr const char* kShippedModel = "glovepose_fcn512.safetensors";
inline constexpr const char* kShippedUNet = "glovepose_unet64.safetensors";

/// --model FILE, --weights STORAGE and --seed S: the model, how it holds its weights in memory, and
/// the simulation seed of the person it runs on.
struct SessionOptions {
  std::string model;  // empty: the shipped model
  nn::WeightStorage storage = nn::WeightStorage::F32;
  std::uint64_t seed = 2026;

  /// Adds the three options to `command`; `seed_help` describes --seed for this command.
  void add_to(CLI::App& command, const std::string& seed_help) {
    add_model_file(command, model, std::string("weights (default: models/") + kShippedModel + ", shipped with glovepose)");
    add_weight_storage(command, storage);
    add_number(command, "--seed", "S", seed, seed_help);
  }

  /// The model file: --model, else the shipped model (throws glovepose::Error when it is not found).
  std::string model_path() const { return model.empty() ? shipped_model_path(kShippedModel) : model; }

  /// The model of model_path(), its weights held as --weights says.
  std::shared_ptr<const PoseModel> load_model() const {
    PoseModelOptions options;
    options.storage = storage;
    return PoseModel::load(model_path(), options);
  }
};

}  // namespace glovepose::cli
