// Regression tests for what the fuzz targets of fuzz/ found (fuzz/README.md, "Findings"): each
// holds the input that broke an invariant (reduced where the reduction keeps the cause), and fails
// without the fix. The full inputs are kept in fuzz/corpus/<target>/ as well.
#include <doctest/doctest.h>

#include <glovepose/estimator.hpp>
#include <glovepose/io/tensor_file.hpp>
#include <glovepose/model/model_info.hpp>
#include <glovepose/sensor/calibration.hpp>
#include <glovepose/train/keypoint_columns.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <fstream>
#include <iterator>
#include <limits>
#include <sstream>
#include <string>

using namespace glovepose;

namespace {

std::string file_bytes(const std::string& path) {
  std::ifstream file(path, std::ios::binary);
  REQUIRE_MESSAGE(file, "cannot open " << path);
  return std::string(std::istreambuf_iterator<char>(file), std::istreambuf_iterator<char>());
}

// The path of PoseModel::load (and of tensor_file_fuzz) from a model file's bytes.
std::shared_ptr<const PoseModel> model_from_bytes(const std::string& bytes) {
  const nn::WeightFile weights = nn::WeightFile::parse(bytes);
  model::ModelInfo info = model::ModelInfo::from(weights);
  auto network = PoseModel::Network::from_tensors(info, weights.tensors, nn::WeightStorage::F32);
  return std::make_shared<const PoseModel>(std::move(info), std::move(network), PoseModelOptions{});
}

}  // namespace

// csv_import_fuzz, fuzz/corpus/csv_import_fuzz/calibration_range_overflow.txt (reduced to one sensor):
// each limit is finite but max - min overflows to infinity, so normalize() answered Status::Ok with
// NaN for the cell (inf / inf) instead of the range being refused when it is made.
TEST_CASE("fuzz regression: a calibration file whose max - min overflows is refused at load") {
  constexpr char kInput[] = "glovepose-calibration 1\nglove\tglauser2019-44\nsensors\t1\ncell_0\t-1.7e308\t1.7e308\n";
  std::istringstream in(kInput);
  CHECK_THROWS_WITH_AS(sensor::CalibrationRange::load(in, "fuzz input", "glauser2019-44", {"cell_0"}),
                       doctest::Contains("cell_0 has min -1"), Error);
  std::istringstream again(kInput);
  CHECK_THROWS_WITH_AS(sensor::CalibrationRange::load(again, "fuzz input", "glauser2019-44", {"cell_0"}),
                       doctest::Contains("expected a range max - min that is a finite number"), Error);

  // The widest range whose span is finite is still accepted and normalises to finite values.
  const sensor::CalibrationRange wide(Eigen::VectorXd::Constant(1, -8e307), Eigen::VectorXd::Constant(1, 8e307), {"cell_0"});
  Eigen::VectorXd out(1);
  for (const double reading : {-1.7e308, -8e307, 0.0, 8e307, 1.7e308}) {
    CHECK(wide.normalize(Eigen::VectorXd::Constant(1, reading), out) == Status::Ok);
    CHECK(std::isfinite(out[0]));
  }
}

// tensor_file_fuzz, fuzz/corpus/tensor_file_fuzz/joint_limits_overflow.safetensors: the model
// fixture with joint_limits_min[0] = -1.7e308 and joint_limits_max[0] = 1.7e308 (both finite, so
// the metadata check passed) loaded, and every pose it produced had a NaN or infinite
// thumb_base_abduction: denormalize() multiplies by max - min, which overflows.
TEST_CASE("fuzz regression: a model whose joint-limit range overflows is refused at load") {
  nn::WeightFile weights = nn::WeightFile::parse(file_bytes(std::string(GLOVEPOSE_SOURCE_DIR) + "/tests/fixtures/unet_w4.safetensors"));
  std::vector<double> lo = weights.meta_numbers("joint_limits_min"), hi = weights.meta_numbers("joint_limits_max");
  REQUIRE(model_from_bytes(weights.serialize()));  // the unchanged fixture loads
  lo[0] = -1.7e308;
  hi[0] = 1.7e308;
  weights.metadata["joint_limits_min"] = nn::WeightFile::format_numbers(lo);
  weights.metadata["joint_limits_max"] = nn::WeightFile::format_numbers(hi);
  const std::string input = weights.serialize();
  CHECK_THROWS_WITH_AS(model_from_bytes(input), doctest::Contains("JointLimits: DoF thumb_base_abduction"), Error);
  CHECK_THROWS_WITH_AS(model_from_bytes(input), doctest::Contains("a finite range max - min"), Error);

  hand::Angles min = hand::JointLimits().min(), max = hand::JointLimits().max();
  min[3] = -1e308;
  max[3] = 1e308;
  CHECK_THROWS_WITH_AS(hand::JointLimits(min, max), doctest::Contains("DoF thumb_tip_flexion"), Error);
  min[3] = -8e307;
  max[3] = 8e307;
  const hand::JointLimits wide(min, max);
  hand::Angles normalized{};
  normalized.fill(1.0);
  CHECK(std::isfinite(wide.denormalize(normalized)[3]));
  normalized.fill(-1.0);
  CHECK(std::isfinite(wide.denormalize(normalized)[3]));
}

// estimator_stream_fuzz, fuzz/corpus/estimator_stream_fuzz/crash-3077b1cc195e19cfa14aa9bc71ba4a04bf7ae4d1
// (reduced here to its cause): rows reading the largest finite double are accepted (finite, not
// negative), the least-squares residual of such rows overflows, and the frame came out Solved with
// an infinite (or, for inf - inf, NaN) Pose::health.max_residual; a NaN row escapes the outlier count.
TEST_CASE("fuzz regression: readings so large that the residual overflows give no pose, not a non-finite residual") {
  const auto model = PoseModel::load(std::string(GLOVEPOSE_SOURCE_DIR) + "/tests/fixtures/unet_w4.safetensors");
  EstimatorConfig config;
  config.readout.mean_window = 1;
  GlovePoseEstimator estimator(model, config);
  const int cells = model->cell_count();
  estimator.set_calibration(
      sensor::CalibrationRange(Eigen::VectorXd::Constant(cells, 4.0), Eigen::VectorXd::Constant(cells, 12.0), model->glove().cell_names()));
  const Eigen::VectorXd plausible = model->solver()->measurement_matrix() * Eigen::VectorXd::Constant(cells, 7.0);
  const int rows = static_cast<int>(plausible.size());
  double time = 0.0;
  int refused = 0, last_solved_cycle = -1;
  for (int cycle = 0; cycle < 3; ++cycle) {
    for (int row = 0; row < rows; ++row) {
      const double value = cycle == 1 && row % 2 == 0 ? std::numeric_limits<double>::max() : plausible[row];
      const Status status = estimator.push_row(row, value, time += 1.0 / 10800.0);
      if (status == Status::Solved) {
        last_solved_cycle = cycle;
        CHECK(std::isfinite(estimator.pose().health.max_residual));
        for (const double angle : estimator.pose().angles) CHECK(std::isfinite(angle));
      }
      if (status == Status::NonFinite) ++refused;
    }
  }
  CHECK(refused > 0);             // the overflowing frames are reported
  CHECK(last_solved_cycle == 2);  // and poses resume once plausible readings replace the huge ones
}

// keypoint_file_fuzz, fuzz/corpus/keypoint_file_fuzz/duplicate_column (reduced here to its cause): a
// header naming a keypoint coordinate twice (thumb_tip_z twice, no thumb_tip_y) counted three columns
// for the keypoint, so it was read as reported with y never set: a keypoint finite in x and z, NaN in y.
TEST_CASE("fuzz regression: a keypoint coordinate named twice is refused, not read with a hole") {
  std::istringstream file("timestamp,thumb_tip_x,thumb_tip_z,thumb_tip_z\n0,1,2,3\n");
  CHECK_THROWS_WITH_AS(train::read_keypoint_file(file, "k.csv", 1.0, {}),
                       "keypoint file 'k.csv', line 1, column 4 'thumb_tip_z': named like column 3, expected each column once", Error);
}
