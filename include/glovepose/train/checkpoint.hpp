/// @file checkpoint.hpp
/// @brief A training run's state (TrainingState) as a file, so that a run that was killed continues
/// where it was and ends with the same weights, bit for bit, as one that never stopped. The file is
/// the container of weights_format.md ("glovepose-training-checkpoint", written whole or not at
/// all): every tensor of the network in its own memory order ("value.<index>"), the optimizer's
/// moments ("adam_mean.<index>", "adam_square.<index>"), the kept model ("best.<name>", PyTorch
/// layout), the counters (I64) and figures (F64) of where the run is, the finished epochs' records
/// ("history", F64 rows of epoch, training loss, validation error, seconds) and, as metadata, what
/// the run trains ("run.<key>", run_identity()). Set-up code: errors name the file and what was
/// expected.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "../config.hpp"
#include "../io/tensor_file.hpp"
#include "trainer.hpp"

namespace glovepose::train {

/// @brief The checkpoint file's format name (metadata "format").
inline constexpr const char* kCheckpointFormat = "glovepose-training-checkpoint";

namespace detail {

inline std::string checkpoint_index(std::size_t k) {
  std::string digits = std::to_string(k);
  return std::string(digits.size() < 4 ? 4 - digits.size() : 0, '0') + digits;
}

}  // namespace detail

/// @brief `state` as the checkpoint's container (what write_checkpoint() writes).
inline io::TensorFile checkpoint_file(const TrainingState& state) {
  io::TensorFile file;
  file.metadata["format"] = kCheckpointFormat;
  file.metadata["version"] = "1";
  for (const auto& [key, value] : state.run) file.metadata["run." + key] = value;
  const auto flat = [](const std::vector<float>& v) { return io::RawTensor::from({static_cast<std::int64_t>(v.size())}, v); };
  for (std::size_t k = 0; k < state.values.size(); ++k) file.tensors["value." + detail::checkpoint_index(k)] = flat(state.values[k]);
  for (std::size_t k = 0; k < state.optimizer.mean.size(); ++k) {
    if (state.optimizer.mean[k].empty()) continue;
    file.tensors["adam_mean." + detail::checkpoint_index(k)] = flat(state.optimizer.mean[k]);
    file.tensors["adam_square." + detail::checkpoint_index(k)] = flat(state.optimizer.square[k]);
  }
  for (const auto& [name, t] : state.best) file.tensors["best." + name] = io::RawTensor::from(t.shape, t.values);
  const std::vector<std::int64_t> counters{state.epoch,
                                           state.step,
                                           state.steps,
                                           state.trained_frames,
                                           state.best_epoch,
                                           state.optimizer.steps,
                                           static_cast<std::int64_t>(state.values.size())};
  file.tensors["counters"] = io::RawTensor::from({static_cast<std::int64_t>(counters.size())}, counters);
  const std::vector<double> figures{state.loss_sum, state.seconds, state.train_seconds, state.best_validation_error_deg};
  file.tensors["figures"] = io::RawTensor::from({static_cast<std::int64_t>(figures.size())}, figures);
  if (!state.epochs.empty()) {
    std::vector<double> rows;
    for (const EpochRecord& r : state.epochs)
      rows.insert(rows.end(), {static_cast<double>(r.epoch), r.train_loss, r.validation_error_deg, r.seconds});
    file.tensors["history"] = io::RawTensor::from({static_cast<std::int64_t>(state.epochs.size()), 4}, rows);
  }
  return file;
}

/// @brief Writes `state` to `path`, whole or not at all. Throws glovepose::Error naming the file.
inline void write_checkpoint(const std::string& path, const TrainingState& state) {
  checkpoint_file(state).write(path, "training checkpoint");
}

/// @brief The state a checkpoint's container holds. Throws glovepose::Error naming what was expected
/// (a checkpoint's format and tensors); whether it fits a run is train_network()'s check
/// (TrainConfig::resume).
inline TrainingState checkpoint_state(const io::TensorFile& file) {
  const auto format = file.metadata.find("format");
  if (format == file.metadata.end() || format->second != kCheckpointFormat)
    throw Error(std::string("not a training checkpoint, expected metadata format '") + kCheckpointFormat + "'");
  const auto tensor = [&](const std::string& name) -> const io::RawTensor& {
    const auto it = file.tensors.find(name);
    if (it == file.tensors.end()) throw Error("no tensor '" + name + "', expected a whole checkpoint");
    return it->second;
  };
  const std::vector<std::int64_t> counters = tensor("counters").to<std::int64_t>();
  const std::vector<double> figures = tensor("figures").to<double>();
  if (counters.size() != 7 || figures.size() != 4) throw Error("counters or figures of another size, expected 7 and 4");
  for (std::int64_t c : counters)
    if (c < -1 || c > (std::int64_t{1} << 40)) throw Error("a counter of " + std::to_string(c) + ", expected a count");
  TrainingState s;
  s.epoch = static_cast<int>(counters[0]);
  s.step = counters[1];
  s.steps = counters[2];
  s.trained_frames = counters[3];
  s.best_epoch = static_cast<int>(counters[4]);
  s.optimizer.steps = counters[5];
  if (counters[6] < 0 || counters[6] > 100000) throw Error("a tensor count of " + std::to_string(counters[6]) + ", expected a network's");
  const auto count = static_cast<std::size_t>(counters[6]);
  s.loss_sum = figures[0];
  s.seconds = figures[1];
  s.train_seconds = figures[2];
  s.best_validation_error_deg = figures[3];
  s.values.resize(count);
  s.optimizer.mean.resize(count);
  s.optimizer.square.resize(count);
  for (std::size_t k = 0; k < count; ++k) {
    const std::string index = detail::checkpoint_index(k);
    s.values[k] = tensor("value." + index).to<float>();
    if (file.tensors.count("adam_mean." + index)) {
      s.optimizer.mean[k] = tensor("adam_mean." + index).to<float>();
      s.optimizer.square[k] = tensor("adam_square." + index).to<float>();
    }
  }
  for (const auto& [name, t] : file.tensors)
    if (name.compare(0, 5, "best.") == 0) s.best[name.substr(5)] = nn::Tensor{t.shape, t.to<float>()};
  if (const auto history = file.tensors.find("history"); history != file.tensors.end()) {
    const std::vector<double> rows = history->second.to<double>();
    if (history->second.shape.size() != 2 || history->second.shape[1] != 4) throw Error("history of another shape, expected [epochs, 4]");
    for (std::size_t i = 0; i + 3 < rows.size(); i += 4) {
      if (!(rows[i] >= 0.0 && rows[i] < 1e9))
        throw Error("history row " + std::to_string(i / 4) + ": epoch " + io::number_text(rows[i]) + ", expected a count");
      s.epochs.push_back({static_cast<int>(rows[i]), rows[i + 1], rows[i + 2], rows[i + 3]});
    }
  }
  for (const auto& [key, value] : file.metadata)
    if (key.compare(0, 4, "run.") == 0) s.run[key.substr(4)] = value;
  return s;
}

/// @brief Reads a file written by write_checkpoint() (checkpoint_state()); errors name the file.
inline TrainingState read_checkpoint(const std::string& path) {
  return io::TensorFile::read_as(path, "training checkpoint", [](const io::TensorFile& file) { return checkpoint_state(file); });
}

}  // namespace glovepose::train
