// The C++ side of tests/python/test_capi.py: streams a simulated session's raw rows through
// glovepose::GlovePoseEstimator (the C++ API, no C ABI) and prints every pose with %.17g, so that
// the Python test can compare what the C ABI returns for the same rows, number for number.
//
//   capi_cpp_reference session MODEL DATASET     one line per pose (format below)
//   capi_cpp_reference write-fixtures DIR MODEL  the files test_capi.c loads: DIR/glauser2019-44.json
//                                                (the built-in glove), DIR/another-glove.json (same
//                                                map, another id), DIR/training_range.safetensors
//                                                (MODEL with a training-set range: 10..30 pF per cell)
//
// The session protocol (repeated exactly by test_capi.py): settings as in session_config(); the
// dataset's leading calibration frames (kind 1) are streamed between start_calibration() and
// finish_calibration(), then the remaining frames; row r of frame f is read at
// the dataset's row clock (io::RowClock; glovepose_row_time in the C ABI).
//
// Output line per pose (push_row returned Solved): "pose" frame row sequence timestamp oldest_age
// flags rejected, 25 angles, 25 raw angles, 21 x (3 position + 4 rotation) joint floats; then a
// last line "end" poses calibration_source.
#include <glovepose/estimator.hpp>
#include <glovepose/grid/glove_description.hpp>
#include <glovepose/io/dataset.hpp>
#include <glovepose/nn/weights.hpp>

#include <cstdio>
#include <exception>
#include <string>
#include <vector>

using namespace glovepose;

namespace {

EstimatorConfig session_config() {
  EstimatorConfig config;  // the paper's readout: mean of 5, a solve every 16 rows
  config.smoothing = filter::OneEuroConfig{60.0, 1.0, 0.5, 1.0};
  config.joint_transforms = true;
  return config;
}

void print_pose(std::size_t frame, int row, const GlovePoseEstimator& estimator) {
  const Pose& p = estimator.pose();
  std::printf("pose %zu %d %llu %.17g %.17g %u %u", frame, row, static_cast<unsigned long long>(p.sequence), p.timestamp, p.oldest_age,
              static_cast<unsigned>(p.flags), static_cast<unsigned>(p.rejected));
  for (double a : p.angles) std::printf(" %.17g", a);
  for (double a : p.raw_angles) std::printf(" %.17g", a);
  for (const hand::JointTransform& j : estimator.joints()) {
    for (float v : j.position) std::printf(" %.17g", static_cast<double>(v));
    for (float v : j.rotation) std::printf(" %.17g", static_cast<double>(v));
  }
  std::printf("\n");
}

int session(const std::string& model_path, const std::string& dataset_path) {
  const io::Dataset d = io::Dataset::read(dataset_path);
  if (d.row_count == 0) throw Error("dataset '" + dataset_path + "' has no raw rows, expected one simulated with --raw-rows");
  GlovePoseEstimator estimator(PoseModel::load(model_path), session_config());
  const std::size_t calibration_end = d.first_session_frame();
  if (calibration_end > 0) estimator.start_calibration();
  long poses = 0;
  const io::RowClock clock = d.row_clock();
  for (std::size_t f = 0; f < d.frames(); ++f) {
    if (f == calibration_end && calibration_end > 0) estimator.finish_calibration();
    for (std::size_t r = 0; r < d.row_count; ++r) {
      const double value = d.raw_rows[f * d.row_count + r];
      const double timestamp = clock.time(d.timestamps[f], r);
      if (estimator.push_row(static_cast<int>(r), value, timestamp) == Status::Solved) {
        print_pose(f, static_cast<int>(r), estimator);
        ++poses;
      }
    }
  }
  std::printf("end %ld %d\n", poses, static_cast<int>(estimator.calibration_source()));
  return 0;
}

int write_fixtures(const std::string& dir, const std::string& model_path) {
  const grid::GloveDescription builtin = grid::GloveDescription::glauser2019();
  builtin.write(dir + "/" + builtin.id() + ".json");
  grid::GloveDescription("another-glove", builtin.cell_names(), builtin.map()).write(dir + "/another-glove.json");
  nn::WeightFile file = nn::WeightFile::read(model_path);
  file.metadata["calibration_min"] = nn::WeightFile::format_numbers(std::vector<double>(builtin.cell_names().size(), 10.0));
  file.metadata["calibration_max"] = nn::WeightFile::format_numbers(std::vector<double>(builtin.cell_names().size(), 30.0));
  file.metadata.erase("range_map");  // a model with a training range and no range map
  file.write(dir + "/training_range.safetensors");
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  try {
    const std::string mode = argc > 1 ? argv[1] : "";
    if (mode == "session" && argc == 4) return session(argv[2], argv[3]);
    if (mode == "write-fixtures" && argc == 4) return write_fixtures(argv[2], argv[3]);
    std::fprintf(stderr, "usage: %s session MODEL DATASET | write-fixtures DIR MODEL\n", argv[0]);
    return 2;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "capi_cpp_reference: %s\n", e.what());
    return 1;
  }
}
