// The model's own errors (model/pose_error.hpp) and the per-joint confidence the estimator gives
// from them: the normal model's probabilities against tabulated values of the normal distribution,
// the calibration in use, the speed and stood-in cells each raising the error, untrusted poses at
// 0, and the OpenXR joints' tracked bits following their digit's confidences.
#include <glovepose/estimator.hpp>
#include <glovepose/hand/xr_hand.hpp>
#include <glovepose/model/pose_error.hpp>
#include <glovepose/pose_prediction.hpp>
#include <glovepose/sensor/calibration.hpp>
#include <glovepose/sensor/layout.hpp>
#include <glovepose/sensor/solver.hpp>
#include <glovepose/train/confidence_metrics.hpp>
#include <glovepose/train/model_file.hpp>

#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <string>
#include <vector>

#include "alloc_counter.hpp"
#include "test_files.hpp"
#include "unet_reference.hpp"

using namespace glovepose;
using model::ErrorCondition;
using model::PoseErrorModel;

namespace {

constexpr double kDeg = 3.14159265358979323846 / 180.0;

hand::Angles constant(double v) {
  hand::Angles a{};
  a.fill(v);
  return a;
}

// A model of still errors 5 deg (guided), 7 (min-max), 12 (training), continuous 9 then 6 from 100
// frames; no speed term; cell 3 stood in for adds 5 deg to DoF 0 only.
PoseErrorModel example(int cells, double speed_seconds = 0.0) {
  Eigen::MatrixXd masked = Eigen::MatrixXd::Zero(cells, 25);
  masked(3, 0) = 5.0;
  return PoseErrorModel(constant(5.0), constant(7.0), constant(12.0), {{0.0, constant(9.0)}, {100.0, constant(6.0)}}, constant(speed_seconds),
                        masked);
}

}  // namespace

TEST_CASE("pose error: the confidence is the normal probability of an error within the tolerance") {
  const PoseErrorModel errors = example(44);
  hand::Angles c{};
  // Within 2 sigma of a normal: 0.9545 (tabulated); 1 sigma: 0.6827; 3 sigma: 0.9973.
  REQUIRE(errors.confidence(ErrorCondition::Guided, 0.0, nullptr, nullptr, 0, 10.0 * kDeg, c));
  CHECK(c[5] == doctest::Approx(0.9545).epsilon(1e-3));
  REQUIRE(errors.confidence(ErrorCondition::Guided, 0.0, nullptr, nullptr, 0, 5.0 * kDeg, c));
  CHECK(c[5] == doctest::Approx(0.6827).epsilon(1e-3));
  REQUIRE(errors.confidence(ErrorCondition::Training, 0.0, nullptr, nullptr, 0, 36.0 * kDeg, c));
  CHECK(c[5] == doctest::Approx(0.9973).epsilon(1e-3));
  // Continuous: the stage reached by the effective frames.
  REQUIRE(errors.confidence(ErrorCondition::Continuous, 99.0, nullptr, nullptr, 0, 9.0 * kDeg, c));
  CHECK(c[0] == doctest::Approx(0.6827).epsilon(1e-3));
  REQUIRE(errors.confidence(ErrorCondition::Continuous, 100.0, nullptr, nullptr, 0, 12.0 * kDeg, c));
  CHECK(c[0] == doctest::Approx(0.9545).epsilon(1e-3));
  // A stood-in cell adds its variance to the DoFs it moves: sqrt(5^2 + 5^2) for DoF 0, others unchanged.
  const int masked[] = {3};
  REQUIRE(errors.confidence(ErrorCondition::Guided, 0.0, nullptr, masked, 1, std::sqrt(50.0) * kDeg, c));
  CHECK(c[0] == doctest::Approx(0.6827).epsilon(1e-3));
  CHECK(c[1] == doctest::Approx(std::erf(std::sqrt(50.0) / (5.0 * std::sqrt(2.0)))).epsilon(1e-9));
  // Speed: 0.1 s per unit of speed at 0.4 rad/s is 0.04 rad of error, added in variance.
  const PoseErrorModel moving = example(44, 0.1);
  hand::Angles rate = constant(0.0);
  rate[2] = 0.4;
  REQUIRE(moving.confidence(ErrorCondition::Guided, 0.0, &rate, nullptr, 0, 10.0 * kDeg, c));
  const double sigma = std::hypot(5.0, 0.04 / kDeg);
  CHECK(c[2] == doctest::Approx(std::erf(10.0 / (sigma * std::sqrt(2.0)))).epsilon(1e-9));
  CHECK(c[3] == doctest::Approx(0.9545).epsilon(1e-3));
  // A model without a training measurement says so.
  const PoseErrorModel no_training(constant(5.0), constant(7.0), std::nullopt, {}, constant(0.0), Eigen::MatrixXd::Zero(2, 25));
  CHECK_FALSE(no_training.confidence(ErrorCondition::Training, 0.0, nullptr, nullptr, 0, 0.1, c));
  CHECK_FALSE(no_training.confidence(ErrorCondition::Continuous, 10.0, nullptr, nullptr, 0, 0.1, c));
}

TEST_CASE("pose error: its JSON keeps every number, and a malformed one is refused by name") {
  const PoseErrorModel errors = example(44, 0.02);
  const PoseErrorModel back = PoseErrorModel::parse(errors.to_json(), "test");
  CHECK(back.guided_deg() == errors.guided_deg());
  CHECK(back.min_max_deg() == errors.min_max_deg());
  REQUIRE(back.training_deg());
  CHECK(*back.training_deg() == *errors.training_deg());
  REQUIRE(back.continuous().size() == 2);
  CHECK(back.continuous()[1].frames == 100.0);
  CHECK(back.speed_seconds() == errors.speed_seconds());
  CHECK(back.masked_deg() == errors.masked_deg());
  std::string text = errors.to_json();
  text.replace(text.find("\"guided_deg\":[5.0,"), 18, "\"guided_deg\":[-5.0,");
  CHECK_THROWS_WITH_AS(PoseErrorModel::parse(text, "test"), doctest::Contains("'guided' holds -5"), Error);
  CHECK_THROWS_WITH_AS(PoseErrorModel::parse("{\"format\": \"glovepose-pose-error\", \"version\": 1}", "test"),
                       doctest::Contains("lacks the key 'guided_deg'"), Error);
  CHECK_THROWS_AS(PoseErrorModel(constant(1), constant(1), std::nullopt, {{5.0, constant(1)}}, constant(0), Eigen::MatrixXd::Zero(1, 25)),
                  Error);  // stages must start at 0 frames
}

TEST_CASE("estimator: a pose's confidence follows the calibration in use, and the OpenXR joints' tracked bits follow it") {
  const grid::GloveDescription glove = grid::GloveDescription::glauser2019();
  const int cells = glove.cell_count();
  model::ModelInfo info = train::make_model_info(model::Architecture::UNet, 4, glove, model::CalibrationMode::OnTheFly, nullptr);
  const std::string plain_path = test::temp_path("no_pose_error_model.safetensors");
  const nn::TensorMap tensors = test::random_tensors(nn::UNet<>::expected_tensors(4), 12);
  train::save_model(plain_path, info, tensors, {});
  // Still errors of 3 deg after a calibration, 25 deg with the training range (whose DoF-by-DoF
  // confidence at 10 deg is erf(10 / (25 sqrt 2)) = 0.311).
  Eigen::MatrixXd masked = Eigen::MatrixXd::Zero(cells, 25);
  info.pose_error.emplace(constant(3.0), constant(3.0), constant(25.0), std::vector<PoseErrorModel::Stage>{}, constant(0.0), masked);
  info.calibration_min = std::vector<double>(static_cast<std::size_t>(cells), 1.0);
  info.calibration_max = std::vector<double>(static_cast<std::size_t>(cells), 3.0);
  const std::string path = test::temp_path("pose_error_model.safetensors");
  train::save_model(path, info, tensors, {});
  const auto model = PoseModel::load(path);
  REQUIRE(model->pose_error());

  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(1.5, 2.5);
  std::vector<std::vector<double>> frames(120, std::vector<double>(static_cast<std::size_t>(cells)));
  for (auto& f : frames)
    for (double& v : f) v = u(rng);
  const sensor::CalibrationRange own(Eigen::VectorXd::Constant(cells, 1.4), Eigen::VectorXd::Constant(cells, 2.6), glove.cell_names());

  EstimatorConfig config;
  config.smoothing.reset();
  GlovePoseEstimator estimator(model, config);
  estimator.use_training_calibration();
  std::vector<Status> statuses(frames.size());
  const std::size_t allocations = test::allocations_during([&] {
    for (std::size_t f = 0; f < 60; ++f) statuses[f] = estimator.push_cells(frames[f].data(), cells, static_cast<double>(f) / 60.0);
  });
  CHECK(allocations == 0);
  CHECK(statuses[59] == Status::Solved);
  REQUIRE(estimator.pose().trusted());
  // The rate raises nothing here (no speed term): every DoF reads the training range's confidence.
  for (double c : estimator.pose().confidence) CHECK(c == doctest::Approx(std::erf(10.0 / (25.0 * std::sqrt(2.0)))).epsilon(1e-9));
  hand::XrHandJoints joints;
  REQUIRE(estimator.joints_at(estimator.pose().timestamp, joints) == Status::Ok);
  CHECK(joints.data_source == hand::kXrDataSourceUnobstructed);
  // Palm and wrist: no angle places them, tracked; every digit joint past a DoF: 0.311 or less, not tracked.
  CHECK((joints.locations[0].location_flags & hand::kXrPositionTracked) != 0);
  CHECK((joints.locations[1].location_flags & hand::kXrPositionTracked) != 0);
  CHECK((joints.locations[25].location_flags & hand::kXrPositionTracked) == 0);
  CHECK((joints.locations[25].location_flags & hand::kXrPositionValid) != 0);

  estimator.set_calibration(own);
  for (std::size_t f = 60; f < 120; ++f) (void)estimator.push_cells(frames[f].data(), cells, static_cast<double>(f) / 60.0);
  for (double c : estimator.pose().confidence) CHECK(c == doctest::Approx(std::erf(10.0 / (3.0 * std::sqrt(2.0)))).epsilon(1e-9));
  REQUIRE(estimator.joints_at(estimator.pose().timestamp, joints) == Status::Ok);
  for (const auto& joint : joints.locations) CHECK((joint.location_flags & hand::kXrPositionTracked) != 0);
  // The joint confidence is the product along the digit: the pinky tip's is its DoFs' product.
  std::array<double, hand::kXrJointCount> by_joint{};
  estimator.locator().joint_confidence(estimator.pose().confidence, by_joint);
  const hand::Angles& dof = estimator.pose().confidence;
  int pinky_dofs = 0;
  for (const hand::Dof& d : hand::kDofs) pinky_dofs += d.finger == hand::Finger::Pinky;
  CHECK(by_joint[25] == doctest::Approx(std::pow(dof[24], pinky_dofs)).epsilon(1e-9));

  // A frame with a fault flag (a spiked row: an outlier of the solve): every DoF 0, every joint untracked.
  REQUIRE(model->solver());
  const Eigen::MatrixXd m = model->solver()->layout().measurement_matrix();
  Eigen::VectorXd rows = m * Eigen::Map<const Eigen::VectorXd>(frames[0].data(), cells);
  CHECK(estimator.push_measurements(rows.data(), static_cast<int>(rows.size()), 3.0) == Status::Solved);
  CHECK(estimator.pose().trusted());
  rows(7) += 40.0;
  CHECK(estimator.push_measurements(rows.data(), static_cast<int>(rows.size()), 3.1) == Status::Solved);
  CHECK((estimator.pose().flags & kPoseOutlierRows) != 0);
  for (double c : estimator.pose().confidence) CHECK(c == 0.0);

  // A model without measured errors: a trusted pose's confidence is 1 (the flag alone).
  GlovePoseEstimator plain(PoseModel::load(plain_path), config);
  plain.set_calibration(own);
  REQUIRE(plain.push_cells(frames[0].data(), cells, 0.0) == Status::Solved);
  for (double c : plain.pose().confidence) CHECK(c == 1.0);
}

TEST_CASE("confidence metrics: the quarter ratio and the calibration, against sums computed here") {
  // Two DoFs, 40 joint-frames each: DoF 0's error falls with its confidence, DoF 1's does not.
  train::ConfidenceAccumulator acc(10.0);
  std::vector<std::pair<double, double>> all;  // (confidence, error)
  std::vector<double> dof1;
  for (int i = 0; i < 40; ++i) {
    const double c = (i + 0.5) / 40.0;
    acc.add(0, -(20.0 - 15.0 * c), c);  // the sign of an error does not count
    all.push_back({c, 20.0 - 15.0 * c});
    const double c1 = 0.5 + 0.01 * i;
    const double e1 = (i % 2) ? 4.0 : 12.0;
    acc.add(1, e1, c1);
    all.push_back({c1, e1});
  }
  std::stable_sort(all.begin(), all.end(), [](auto a, auto b) { return a.first < b.first; });
  double low = 0.0, high = 0.0, within = 0.0, mean_c = 0.0;
  for (std::size_t i = 0; i < 20; ++i) {
    low += all[i].second;
    high += all[all.size() - 1 - i].second;
  }
  for (const auto& [c, e] : all) {
    within += e <= 10.0;
    mean_c += c;
  }
  const train::ConfidenceReport r = acc.report();
  CHECK(r.joint_frames == 80);
  CHECK(r.quarter_error_ratio == doctest::Approx(low / high));
  CHECK(r.share_within == doctest::Approx(within / 80.0));
  CHECK(r.mean_confidence == doctest::Approx(mean_c / 80.0));
  // Within DoF 0: the lowest 10 confidences' errors over the highest 10's; DoF 1 alternates: 1.
  double low0 = 0.0, high0 = 0.0;
  for (int i = 0; i < 10; ++i) {
    low0 += 20.0 - 15.0 * (i + 0.5) / 40.0;
    high0 += 20.0 - 15.0 * (39 - i + 0.5) / 40.0;
  }
  CHECK(r.within_dof_ratio == doctest::Approx(0.5 * (low0 / high0 + 1.0)));  // the median of two
  CHECK(train::confidence_json(r).find("\"quarter_error_ratio\": ") != std::string::npos);
}
