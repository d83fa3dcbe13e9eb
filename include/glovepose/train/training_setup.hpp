/// @file training_setup.hpp
/// @brief What `glovepose train` decides before the trainer runs, for any caller: which glove the
/// data was recorded with and at what rate (glove_for_data), which people are left out
/// (exclude_subjects), the new model's metadata and samples (prepare_training), and the linear
/// map's least-squares fit (fit_linear_model).
#pragma once

#include <algorithm>
#include <cmath>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "../config.hpp"
#include "../grid/glove_description.hpp"
#include "../io/dataset.hpp"
#include "linear_fit.hpp"
#include "metrics.hpp"
#include "model_file.hpp"
#include "samples.hpp"

namespace glovepose::train {

/// @brief `glove` checked against the data it is to read, and given the data's frame rate when it
/// states none: the calibration's median window is median_seconds at the data's rate and the
/// estimator takes frames at the description's rate, so the two must agree. Throws
/// glovepose::Error when the glove id, the cell count or the rate differ.
inline grid::GloveDescription glove_for_data(const io::Dataset& data, const grid::GloveDescription& glove) {
  if (data.glove_layout() != glove.id())
    throw Error("the dataset was recorded with glove '" + data.glove_layout() + "' but the glove description is '" + glove.id() +
                "'; pass its description with --glove FILE");
  if (static_cast<std::size_t>(glove.cell_count()) != data.cell_count)
    throw Error("the glove description has " + std::to_string(glove.cell_count()) + " cells, the dataset " +
                std::to_string(data.cell_count));
  const double rate = data.frame_rate();
  if (glove.rate_hz() && std::abs(*glove.rate_hz() - rate) > 1e-9 * rate)
    throw Error("the dataset's frame rate is " + std::to_string(rate) + " Hz but the glove description's rate_hz is " +
                std::to_string(*glove.rate_hz()) + ", expected the same rate (import the takes with the description's rate)");
  if (glove.rate_hz() || glove == grid::GloveDescription::glauser2019()) return glove;
  grid::GloveSettings settings = glove.settings();
  settings.rate_hz = rate;
  return grid::GloveDescription(glove.id(), glove.cell_names(), glove.map(), settings);
}

/// @brief `filter` with `excluded` people left out: its subjects (all in `data` when it lists
/// none) minus those. Throws glovepose::Error when none is left.
inline FrameFilter exclude_subjects(FrameFilter filter, const io::Dataset& data, const std::vector<int>& excluded) {
  if (excluded.empty()) return filter;
  if (filter.subjects.empty())
    for (std::size_t i = 0; i < data.frames(); ++i)
      if (std::find(filter.subjects.begin(), filter.subjects.end(), data.subject[i]) == filter.subjects.end())
        filter.subjects.push_back(data.subject[i]);
  std::vector<int> kept;
  for (int s : filter.subjects)
    if (std::find(excluded.begin(), excluded.end(), s) == excluded.end()) kept.push_back(s);
  if (kept.empty()) throw Error("excluding subjects leaves no subject, expected at least one to train or evaluate on");
  filter.subjects = kept;
  return filter;
}

/// @brief A new model's metadata and the samples it trains on.
struct TrainingSetup {
  model::ModelInfo info;  ///< Architecture, glove, calibration (with the training range), labelled DoFs.
  Samples samples;        ///< The selected frames, calibrated and normalised.
};

/// @brief The metadata and samples of a new `architecture` model of `width` (make_model_info) on
/// the frames of `data` that `filter` and `stride` select, calibrated by `mode` (Training: the range
/// of those frames, stored in the metadata), for `glove` (glove_for_data).
inline TrainingSetup prepare_training(const io::Dataset& recorded, const FrameFilter& filter, int stride, const std::string& architecture,
                                      int width, const grid::GloveDescription& glove, model::CalibrationMode mode) {
  std::optional<io::Dataset> storage;
  const io::Dataset& data = conditioned_for(recorded, glove, storage);  // as the estimator conditions its inputs
  std::optional<sensor::CalibrationRange> range;
  if (mode == model::CalibrationMode::Training) range = training_range(data, filter, glove.calibration());
  TrainingSetup s;
  s.samples = make_samples(data, filter, mode, range ? &*range : nullptr, glove.joint_limits(), stride, glove.calibration());
  s.info = make_model_info(architecture, width, glove, mode, range ? &*range : nullptr);
  s.info.labelled_dofs = s.samples.labelled;
  return s;
}

/// @brief A linear map fitted by least squares on the training part of samples, scored on the rest.
struct LinearModelFit {
  nn::LinearMap map;
  long training_frames = 0, validation_frames = 0;
  double validation_error_deg = 0.0;  ///< Mean angle error on the validation frames.
  std::string validation;             ///< Which frames validated (ValidationParts::description).
};

/// @brief Fits a linear map on `all` less the `validation` fraction that `split` sets aside
/// (split_validation) and scores it there in degrees within `limits`, as eval scores it.
inline LinearModelFit fit_linear_model(const Samples& all, double validation, const hand::JointLimits& limits,
                                       ValidationSplit split = ValidationSplit::Auto) {
  const ValidationParts parts = split_validation(all, validation, split);
  const Samples& training = parts.training;
  const Samples& held = parts.validation;
  LinearModelFit fit{fit_linear(training.inputs.data(), training.frames(), training.cells, training.targets.data(), kTargets).to_map(),
                     training.frames(), held.frames(), 0.0, parts.description};
  std::vector<float> predicted(static_cast<std::size_t>(held.frames()) * kTargets);
  fit.map.predict(held.inputs.data(), predicted.data(), held.frames());
  outside_limits(predicted.data(), predicted.size());  // held as TrainedModel::predict holds it, so eval agrees
  fit.validation_error_deg = mean_error_degrees(predicted, held.angles, limits, held.labelled);
  return fit;
}

}  // namespace glovepose::train
