/// @file tensor_file_fuzz.cpp
/// @brief Fuzz target: the bytes as a weight or dataset file (weights_format.md). The container
/// reader (io::TensorFile::parse), then everything that reads a container: nn::WeightFile,
/// model::ModelInfo::from, the network (U-Net or FCN) from_tensors, the PoseModel built from them (glove description
/// in the metadata, joint limits, training range) and io::Dataset::from_tensor_file.
///
/// Invariants: set-up code refuses bad input with glovepose::Error only (any other exception
/// escapes and is reported); an accepted container serialises to bytes that parse to the same
/// tensors and metadata; an accepted dataset round-trips through its container; a model that loads
/// answers a plausible frame with a finite pose within its joint limits.
#include <array>
#include <cstdint>
#include <string>

#include <glovepose/estimator.hpp>
#include <glovepose/io/tensor_file.hpp>
#include <glovepose/model/model_info.hpp>
#include <glovepose/nn/weights.hpp>
#include <glovepose/io/dataset.hpp>

#include "fuzz_check.hpp"

namespace {

// The model path of PoseModel::load, from bytes: weights, metadata, network, model. Returns null
// when set-up refuses the file.
std::shared_ptr<const glovepose::PoseModel> load_model(const glovepose::io::TensorFile& file) {
  try {
    const glovepose::nn::WeightFile weights = glovepose::nn::WeightFile::from(file);
    glovepose::model::ModelInfo info = glovepose::model::ModelInfo::from(weights);
    GLOVEPOSE_FUZZ_REQUIRE(info.joint_limits_min.size() == glovepose::hand::kDofCount);
    if (info.architecture == glovepose::model::Architecture::Linear) return nullptr;
    auto network = glovepose::PoseModel::Network::from_tensors(info, weights.tensors, glovepose::nn::WeightStorage::F32);
    return std::make_shared<const glovepose::PoseModel>(std::move(info), std::move(network), glovepose::PoseModelOptions{});
  } catch (const glovepose::Error&) {
    return nullptr;
  }
}

// A model that loaded must answer a plausible frame with a finite pose within its limits.
void check_model(const glovepose::PoseModel& model) {
  const int cells = model.cell_count();
  const Eigen::VectorXd lo = Eigen::VectorXd::Constant(cells, 4.0), hi = Eigen::VectorXd::Constant(cells, 12.0);
  glovepose::GlovePoseEstimator estimator(std::shared_ptr<const glovepose::PoseModel>(&model, [](const auto*) {}));
  estimator.set_calibration(glovepose::sensor::CalibrationRange(lo, hi, model.glove().cell_names()));
  std::vector<double> frame(static_cast<std::size_t>(cells));
  for (int c = 0; c < cells; ++c) frame[static_cast<std::size_t>(c)] = 4.0 + 8.0 * c / cells;
  const glovepose::Status status = estimator.push_cells(frame.data(), cells, 0.0);
  // NonFinite: the weights overflow inside the network, reported as documented (no pose).
  GLOVEPOSE_FUZZ_REQUIRE(status == glovepose::Status::Solved || status == glovepose::Status::NonFinite);
  if (status != glovepose::Status::Solved) return;
  const glovepose::Pose& pose = estimator.pose();
  GLOVEPOSE_FUZZ_REQUIRE(glovepose::fuzz::all_finite(pose.angles));
  const auto& limits = model.joint_limits();
  for (std::size_t d = 0; d < glovepose::hand::kDofCount; ++d) {
    const double slack = 1e-9 * (limits.max()[d] - limits.min()[d]);  // rounding of the de-normalisation
    GLOVEPOSE_FUZZ_REQUIRE(pose.angles[d] >= limits.min()[d] - slack && pose.angles[d] <= limits.max()[d] + slack);
  }
}

void check_dataset(const glovepose::io::TensorFile& file) {
  glovepose::io::Dataset dataset;
  try {
    dataset = glovepose::io::Dataset::from_tensor_file(file);
  } catch (const glovepose::Error&) {
    return;
  }
  const glovepose::io::Dataset again = glovepose::io::Dataset::from_tensor_file(dataset.to_tensor_file());
  GLOVEPOSE_FUZZ_REQUIRE(again.to_tensor_file().tensors == dataset.to_tensor_file().tensors);
  GLOVEPOSE_FUZZ_REQUIRE(again.metadata == dataset.metadata);
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string bytes(reinterpret_cast<const char*>(data), size);
  glovepose::io::TensorFile file;
  try {
    file = glovepose::io::TensorFile::parse(bytes);
  } catch (const glovepose::Error&) {
    return 0;
  }
  const glovepose::io::TensorFile again = glovepose::io::TensorFile::parse(file.serialize());
  GLOVEPOSE_FUZZ_REQUIRE(again.tensors == file.tensors);
  GLOVEPOSE_FUZZ_REQUIRE(again.metadata == file.metadata);

  if (const auto model = load_model(file)) check_model(*model);
  check_dataset(file);
  return 0;
}
