// Inputs that are not stretch cells (an IMU angle, a bend sensor): a glove description marks them
// "extra": true; they have no slot on the stretch maps, the FCN and the linear map read them beside
// the cells, and the U-Net reads each as one more input plane of constant value. The accuracy case checks
// the library's linear fit against a least-squares solve written here (Eigen QR) on simulated people.
#include <glovepose/estimator.hpp>
#include <glovepose/grid/glove_description.hpp>
#include <glovepose/sim/corpus_dataset.hpp>
#include <glovepose/train/linear_fit.hpp>
#include <glovepose/train/model_file.hpp>
#include <glovepose/train/samples.hpp>
#include <glovepose/train/trainable_fcn.hpp>
#include <glovepose/train/trainable_unet.hpp>

#include <doctest/doctest.h>

#include <Eigen/Dense>

#include <cmath>
#include <cstdio>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include "alloc_counter.hpp"

using namespace glovepose;

namespace {


// The built-in glove's 44 cells and one extra input after them.
grid::GloveDescription glove_with_extra(const std::string& extra_name) {
  const grid::GloveDescription paper = grid::GloveDescription::glauser2019();
  std::vector<grid::Slot> slots = paper.map().cell_slots();
  slots.push_back(grid::kOffMaps);
  std::vector<std::string> names = paper.cell_names();
  names.push_back(extra_name);
  return grid::GloveDescription("glauser2019-44-bend", names, grid::GridMap(slots, paper.map().dof_slots()));
}

std::string replaced(std::string text, const std::string& from, const std::string& to) {
  const std::size_t at = text.find(from);
  REQUIRE(at != std::string::npos);
  return text.replace(at, from.size(), to);
}

// Mean absolute error in degrees per DoF of normalised predictions (frames x 25) against the samples' angles.
std::vector<double> dof_errors_deg(const std::vector<float>& predicted, const train::Samples& s, const hand::JointLimits& limits) {
  std::vector<double> sum(hand::kDofCount, 0.0);
  for (long f = 0; f < s.frames(); ++f) {
    hand::Angles n{};
    for (std::size_t d = 0; d < hand::kDofCount; ++d) n[d] = predicted[static_cast<std::size_t>(f) * hand::kDofCount + d];
    const hand::Angles a = limits.denormalize(n);
    for (std::size_t d = 0; d < hand::kDofCount; ++d)
      sum[d] += std::abs(a[d] - static_cast<double>(s.angles[static_cast<std::size_t>(f) * hand::kDofCount + d])) * core::kDegreesPerRadian;
  }
  for (double& v : sum) v /= static_cast<double>(s.frames());
  return sum;
}

double mean_of(const std::vector<double>& v) {
  double sum = 0.0;
  for (double x : v) sum += x;
  return sum / static_cast<double>(v.size());
}

// W x + b for every frame of `s`, from a fit (outputs x inputs, outputs).
std::vector<float> apply(const Eigen::MatrixXd& weight, const Eigen::VectorXd& bias, const train::Samples& s) {
  std::vector<float> out(static_cast<std::size_t>(s.frames()) * hand::kDofCount);
  for (long f = 0; f < s.frames(); ++f) {
    const Eigen::Map<const Eigen::VectorXf> x(s.inputs.data() + f * s.cells, s.cells);
    const Eigen::VectorXd y = weight * x.cast<double>() + bias;
    for (std::size_t d = 0; d < hand::kDofCount; ++d)
      out[static_cast<std::size_t>(f) * hand::kDofCount + d] = static_cast<float>(y(static_cast<Eigen::Index>(d)));
  }
  return out;
}

}  // namespace

TEST_CASE("extra inputs: a description lists them beside the stretch cells: read, written, and off the maps") {
  const grid::GloveDescription glove = glove_with_extra("thumb_bend");
  CHECK(glove.cell_count() == 45);
  CHECK(glove.map().extra_input_count() == 1);
  CHECK(grid::GloveDescription::glauser2019().map().extra_input_count() == 0);
  const std::string text = glove.to_json();
  CHECK(text.find("{\"name\": \"thumb_bend\", \"extra\": true}") != std::string::npos);
  CHECK(grid::GloveDescription::from_json(text) == glove);
  CHECK(glove.cell_index("thumb_bend") == 44);

  // The stretch maps hold the 44 cells exactly as the built-in glove's; the extra input is not on them.
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  std::vector<double> cells(45);
  for (double& c : cells) c = u(rng);
  std::array<float, grid::kStretchValues> with_extra{}, builtin{};
  REQUIRE(glove.map().to_stretch_maps(cells.data(), with_extra) == Status::Ok);
  REQUIRE(grid::GridMap::glauser2019().to_stretch_maps(cells.data(), builtin) == Status::Ok);
  CHECK(with_extra == builtin);
  cells[44] = NAN;  // still an input: a non-finite extra is refused like a cell
  CHECK(glove.map().to_stretch_maps(cells.data(), with_extra) == Status::NonFinite);

  // Malformed extra entries name the entry and what was expected.
  const std::string entry = "{\"name\": \"thumb_bend\", \"extra\": true}";
  CHECK_THROWS_WITH_AS(grid::GloveDescription::from_json(replaced(text, entry, "{\"name\": \"thumb_bend\", \"extra\": false}")),
                       "glove description: cells[44] ('thumb_bend'): 'extra' is false, expected true (an input that is not on the "
                       "stretch maps) or no 'extra'",
                       Error);
  CHECK_THROWS_WITH_AS(grid::GloveDescription::from_json(replaced(text, entry, "{\"name\": \"thumb_bend\", \"extra\": true, \"row\": 1}")),
                       "glove description: cells[44] ('thumb_bend') has 'extra' and 'row', expected either a slot (channel, row, col) "
                       "or \"extra\": true",
                       Error);
  CHECK_THROWS_WITH_AS(grid::GloveDescription::from_json(replaced(text, entry, "{\"name\": \"thumb_bend\"}")),
                       doctest::Contains("cells[44] ('thumb_bend')"), Error);
  std::string many;
  for (int i = 0; i < grid::kMaxGloveInputs - 44; ++i) many += ", {\"name\": \"imu_" + std::to_string(i) + "\", \"extra\": true}";
  CHECK_THROWS_WITH_AS(grid::GloveDescription::from_json(replaced(text, entry, entry + many)),
                       doctest::Contains("'cells' lists 257 inputs, expected at most 256"), Error);
  CHECK_NOTHROW(grid::GloveDescription::from_json(replaced(text, entry, entry + many.substr(0, many.rfind(", {")))));
}

TEST_CASE("extra inputs: a U-Net file whose enc1 reads another number of extra planes than the glove has does not load") {
  const grid::GloveDescription glove = glove_with_extra("thumb_bend");
  nn::WeightFile file = nn::WeightFile::read(std::string(GLOVEPOSE_SOURCE_DIR) + "/tests/fixtures/unet_w4.safetensors");  // 2 planes
  file.metadata["inputs"] = "45";
  file.metadata["glove"] = glove.id();
  file.metadata["glove_description"] = glove.to_metadata();
  const std::string path = std::string(GLOVEPOSE_TEST_TMP_DIR) + "/unet_w4_extra.safetensors";
  file.write(path);
  CHECK_THROWS_WITH_AS(PoseModel::load(path), doctest::Contains("the U-Net reads 0 extra input planes (enc1.weight), expected 1"), Error);
  std::remove(path.c_str());
}

TEST_CASE("extra inputs: the FCN and the U-Net read them in the estimator, with the trainer's angles and no allocation") {
  const grid::GloveDescription glove = glove_with_extra("wrist_imu");
  const int frames = 12, n = glove.cell_count();
  for (const model::Architecture architecture : {model::Architecture::Fcn, model::Architecture::UNet}) {
    const std::string name = model::to_string(architecture);
    CAPTURE(name);
    // The FCN reads the inputs as a vector; the U-Net reads the extra one as a third input plane.
    const int width = architecture == model::Architecture::Fcn ? 32 : 8;
    const model::ModelInfo info = train::make_model_info(architecture, width, glove, model::CalibrationMode::OnTheFly, nullptr);
    const std::unique_ptr<train::TrainableNetwork> trainer = train::make_network(info, glove, frames);
    if (auto* unet = dynamic_cast<train::TrainableUNet*>(trainer.get()))
      unet->initialize(21);
    else
      dynamic_cast<train::TrainableFcn&>(*trainer).initialize(21);
    const std::string path = std::string(GLOVEPOSE_TEST_TMP_DIR) + "/" + name + "_extra.safetensors";
    train::save_model(path, info, trainer->parameters().to_tensors());
    const auto model = PoseModel::load(path);
    std::remove(path.c_str());
    REQUIRE(model->glove() == glove);
    if (architecture == model::Architecture::UNet) CHECK(model->network().extra_inputs() == 1);

    // Every input calibrated over 0..10: normalised x = 2 c / 10 - 1.
    const sensor::CalibrationRange range(Eigen::VectorXd::Zero(n), Eigen::VectorXd::Constant(n, 10.0), glove.cell_names());
    std::mt19937 rng(2);
    std::uniform_real_distribution<double> u(0.0, 10.0);
    std::vector<float> normalized(static_cast<std::size_t>(frames * n));
    std::vector<double> raw(normalized.size());
    for (std::size_t i = 0; i < raw.size(); ++i) {
      raw[i] = u(rng);
      normalized[i] = static_cast<float>(2.0 * raw[i] / 10.0 - 1.0);
    }
    core::ThreadPool pool(1);
    trainer->forward(normalized.data(), frames, false, pool);
    GlovePoseEstimator estimator(model);
    estimator.set_calibration(range);
    for (int f = 0; f < frames; ++f) {
      REQUIRE(estimator.push_cells(raw.data() + f * n, n, 0.01 * f) == Status::Solved);
      hand::Angles expected_normalized{};
      for (std::size_t d = 0; d < hand::kDofCount; ++d)
        expected_normalized[d] = trainer->output()[static_cast<std::size_t>(f) * hand::kDofCount + d];
      const hand::Angles expected = model->joint_limits().denormalize(expected_normalized);
      for (std::size_t d = 0; d < hand::kDofCount; ++d)
        CHECK(estimator.pose().raw_angles[d] * core::kDegreesPerRadian == doctest::Approx(expected[d] * core::kDegreesPerRadian).epsilon(1e-4));
    }
    // The extra input moves the pose: the same cells with another extra value give other angles.
    std::vector<double> frame(raw.begin(), raw.begin() + n);
    REQUIRE(estimator.push_cells(frame.data(), n, 1.0) == Status::Solved);
    const hand::Angles before = estimator.pose().raw_angles;
    frame[static_cast<std::size_t>(n - 1)] = 10.0 - frame[static_cast<std::size_t>(n - 1)];
    REQUIRE(estimator.push_cells(frame.data(), n, 1.01) == Status::Solved);
    CHECK(estimator.pose().raw_angles != before);
    CHECK(test::allocations_during([&] { (void)estimator.push_cells(frame.data(), n, 1.02); }) == 0);
    // A frame without its extra input is refused.
    CHECK(estimator.push_cells(frame.data(), n - 1, 1.03) == Status::SizeMismatch);
  }
}

namespace {

// Four simulated people (seed 808, one minute each).
io::Dataset four_people() {
  sim::CorpusConfig config;
  config.seed = 808;
  config.subjects = 4;
  config.sessions = 1;
  config.gloves = 1;
  config.minutes = 1.0;
  config.calibration_seconds = 10.0;
  return sim::to_dataset(sim::simulate_corpus(config), config);
}

// The recording with a bend sensor over `joint` as a 45th input: a resistive sensor, 120 ohm + 40
// ohm per radian, 0.4 ohm noise (0.6 deg).
io::Dataset with_bend_sensor(const io::Dataset& plain, std::size_t joint) {
  io::Dataset data = plain;
  data.cell_count = 45;
  data.cells.clear();
  std::mt19937 rng(3);
  std::normal_distribution<double> noise(0.0, 0.4);
  for (std::size_t i = 0; i < plain.frames(); ++i) {
    data.cells.insert(data.cells.end(), plain.cells.begin() + static_cast<long>(i * 44),
                      plain.cells.begin() + static_cast<long>((i + 1) * 44));
    data.cells.push_back(static_cast<float>(120.0 + 40.0 * plain.angles[i * hand::kDofCount + joint] + noise(rng)));
  }
  data.validate();
  return data;
}

}  // namespace

TEST_CASE("extra inputs: on people held out, a bend sensor beside the 44 cells makes the linear map better (least squares written here)") {
  const io::Dataset plain = four_people();
  const hand::JointLimits limits;
  train::FrameFilter training, held_out;
  training.subjects = {0, 1, 2};
  held_out.subjects = {3};
  // Calibrated by the training people's min and max (the sensor's range over a short calibration
  // take would clamp the joint's wider range in the recording).
  const auto samples = [&](const io::Dataset& data, const train::FrameFilter& filter) {
    const sensor::CalibrationRange range = train::training_range(data, training);
    return train::make_samples(data, filter, model::CalibrationMode::Training, &range, limits);
  };
  const auto fit = [](const train::Samples& s) {
    return train::fit_linear(s.inputs.data(), s.frames(), s.cells, s.targets.data(), train::kTargets);
  };

  // The DoF the 44 cells predict worst on the held-out person.
  const train::Samples plain_train = samples(plain, training), plain_test = samples(plain, held_out);
  const train::LinearFit plain_fit = fit(plain_train);
  const std::vector<double> plain_errors = dof_errors_deg(apply(plain_fit.weight, plain_fit.bias, plain_test), plain_test, limits);
  const std::size_t worst = static_cast<std::size_t>(std::max_element(plain_errors.begin(), plain_errors.end()) - plain_errors.begin());
  MESSAGE("44 cells: mean " << mean_of(plain_errors) << " deg, worst DoF " << std::string(hand::kDofs[worst].name) << " "
                            << plain_errors[worst] << " deg");

  // A resistive bend sensor over that joint.
  const io::Dataset data = with_bend_sensor(plain, worst);
  const train::Samples train_set = samples(data, training), test_set = samples(data, held_out);
  REQUIRE(train_set.cells == 45);
  const train::LinearFit library = fit(train_set);

  // Least squares written here: [X 1] B = T by column-pivoting QR, in double.
  Eigen::MatrixXd x(train_set.frames(), 46), t(train_set.frames(), 25);
  for (long f = 0; f < train_set.frames(); ++f) {
    for (int c = 0; c < 45; ++c) x(f, c) = train_set.inputs[static_cast<std::size_t>(f * 45 + c)];
    x(f, 45) = 1.0;
    for (int d = 0; d < 25; ++d) t(f, d) = train_set.targets[static_cast<std::size_t>(f * 25 + d)];
  }
  const Eigen::MatrixXd b = x.colPivHouseholderQr().solve(t);
  const Eigen::MatrixXd weight = b.topRows(45).transpose();
  const Eigen::VectorXd bias = b.row(45).transpose();

  const std::vector<double> errors = dof_errors_deg(apply(library.weight, library.bias, test_set), test_set, limits);
  const std::vector<double> reference = dof_errors_deg(apply(weight, bias, test_set), test_set, limits);
  MESSAGE("45 inputs: mean " << mean_of(errors) << " deg (least squares here " << mean_of(reference) << "), "
                             << std::string(hand::kDofs[worst].name) << " " << errors[worst] << " deg (here " << reference[worst] << ")");
  CHECK(mean_of(errors) == doctest::Approx(mean_of(reference)).epsilon(0.01));
  CHECK(errors[worst] == doctest::Approx(reference[worst]).epsilon(0.01));
  // The sensor reads the joint to 0.6 deg: the map leans on it, and the mean over all DoFs improves.
  CHECK(errors[worst] < 0.5 * plain_errors[worst]);
  CHECK(mean_of(errors) < mean_of(plain_errors));
  CHECK(std::abs(library.weight(static_cast<Eigen::Index>(worst), 44)) > 0.1);
}

TEST_CASE("extra inputs: on people held out, the U-Net reads a bend sensor as an input plane and predicts its joint better") {
  // The same people and sensor as the linear case (over middle_base_flexion, the joint the 44
  // cells predict worst there); a width-8 U-Net trained from the same seed with and without it.
  const io::Dataset plain = four_people();
  const std::size_t joint = hand::dof_from_name("middle_base_flexion");
  const io::Dataset data = with_bend_sensor(plain, joint);
  const hand::JointLimits limits;
  train::FrameFilter training, held_out;
  training.subjects = {0, 1, 2};
  held_out.subjects = {3};
  core::ThreadPool pool(2);
  const auto held_out_errors = [&](const io::Dataset& d, const grid::GridMap& map) {
    const sensor::CalibrationRange range = train::training_range(d, training);
    const train::Samples fit = train::make_samples(d, training, model::CalibrationMode::Training, &range, limits);
    const train::Samples test = train::make_samples(d, held_out, model::CalibrationMode::Training, &range, limits);
    train::TrainableUNet net(8, map, 256);
    net.initialize(5);
    train::TrainConfig config;
    config.epochs = 12;
    config.batch = 256;
    config.seed = 9;
    const train::TrainResult result = train::train_network(net, fit, train::Samples{}, limits, config, pool);
    MESSAGE(map.cell_count() << " inputs: " << result.steps << " steps in " << result.seconds << " s");
    return dof_errors_deg(train::predict(net, test, pool), test, limits);
  };
  const std::vector<double> without = held_out_errors(plain, grid::GridMap::glauser2019());
  const std::vector<double> with = held_out_errors(data, glove_with_extra("middle_bend").map());
  MESSAGE("U-Net w8, held-out person: middle_base_flexion " << without[joint] << " -> " << with[joint] << " deg, mean " << mean_of(without)
                                                            << " -> " << mean_of(with) << " deg");
  CHECK(with[joint] < 0.6 * without[joint]);  // 20.4 -> 9.6 deg when written (12 epochs of a width-8 network)
  CHECK(mean_of(with) < mean_of(without));
}
