// GlovePoseEstimator: the streaming path equals the batch path, every input form agrees, the
// calibration state machine, smoothing and joint transforms, zero allocations per frame, one model
// shared by estimators on threads, and the statuses of bad input.
#include <doctest/doctest.h>

#include "test_files.hpp"

#include <glovepose/nn/unet_diagnostics.hpp>
#include <glovepose/estimator.hpp>
#include <glovepose/model/unet_model.hpp>
#include <glovepose/sim/corpus_dataset.hpp>
#include <glovepose/train/samples.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <thread>
#include <vector>

#include "alloc_counter.hpp"

using namespace glovepose;

namespace {

using glovepose::test::kShippedModel;
// The paper's architecture, shipped beside the default: for what only a U-Net has.
const std::string kUNetModel = std::string(GLOVEPOSE_SOURCE_DIR) + "/models/glovepose_unet64.safetensors";

// One simulated subject: a 3 s calibration sequence, then a 6 s session, with the raw rows, solved
// once per readout cycle (so the recorded C_c frames are the ones a row stream solves at cycle ends).
// No dropped rows: the readout counts accepted readings, so a drop would move the solves off the
// cycle ends, in the stream and in the recorder at different places (fault handling has its own tests).
struct Session {
  io::Dataset data;
  std::size_t first_session_frame = 0;
};

Session simulate_session(hand::Handedness side) {
  sim::CorpusConfig config = sim::CorpusConfig::one_session(41, 6.0, 3.0);
  config.handedness = side;
  config.recording.raw_rows = true;
  config.recording.readout.solve_every = sim::kRows;
  config.recording.noise.drop_probability = 0.0;
  Session out;
  out.data = sim::to_dataset(sim::simulate_corpus(config), config);
  out.first_session_frame = out.data.first_session_frame();
  return out;
}

const Session& session() {
  static const Session s = simulate_session(hand::Handedness::Right);
  return s;
}

// The recorder's readout: its mean window (the paper's 5), a solve at every cycle end.
EstimatorConfig cycle_config() {
  EstimatorConfig config;
  config.readout.mean_window = sim::RecordingConfig{}.readout.mean_window;
  config.readout.solve_every = sim::kRows;
  return config;
}

// Streams frames [begin, end) of `d` row by row; calls on_pose(frame) whenever a frame's rows produced a pose.
template <typename Estimator, typename OnPose>
void stream_rows(Estimator& estimator, std::size_t begin, std::size_t end, OnPose on_pose, const io::Dataset& d = session().data) {
  for (std::size_t f = begin; f < end; ++f) {
    bool solved = false;
    for (int r = 0; r < static_cast<int>(d.row_count); ++r)
      solved |= estimator.push_row(r, d.raw_rows[f * d.row_count + static_cast<std::size_t>(r)], d.row_time(f, static_cast<std::size_t>(r))) == Status::Solved;
    if (solved) on_pose(f);
  }
}

// An estimator calibrated on the session's calibration sequence (streamed row by row).
GlovePoseEstimator calibrated(const std::shared_ptr<const PoseModel>& model, EstimatorConfig config = cycle_config(),
                              const Session& on = session()) {
  GlovePoseEstimator estimator(model, std::move(config));
  estimator.clear_calibration();  // no pose before the calibration ends (the shipped model's continuous one cleared)
  estimator.start_calibration();
  stream_rows(
      estimator, 0, on.first_session_frame, [](std::size_t) {}, on.data);
  estimator.finish_calibration();
  return estimator;
}

std::shared_ptr<const PoseModel> shipped() {
  static const auto model = PoseModel::load(kShippedModel);
  return model;
}

std::shared_ptr<const PoseModel> shipped_unet() {
  static const auto model = PoseModel::load(kUNetModel);
  return model;
}

double max_difference(const hand::Angles& a, const hand::Angles& b) {
  double worst = 0.0;
  for (std::size_t d = 0; d < hand::kDofCount; ++d) worst = std::max(worst, std::abs(a[d] - b[d]));
  return worst;
}

}  // namespace

TEST_CASE("estimator: a session streamed row by row gives the poses of the batch path") {
  const auto model = shipped();
  const io::Dataset& d = session().data;
  const std::size_t begin = session().first_session_frame, end = d.frames();
  // Calibrate on the calibration sequence, from its 6th cycle on: the recorder's readout had run
  // warm-up cycles before it, the stream's ring needs its first mean_window (5) cycles to fill.
  constexpr std::size_t kFill = 5;
  GlovePoseEstimator estimator(model, cycle_config());
  stream_rows(estimator, 0, kFill, [](std::size_t) {});
  estimator.start_calibration();
  stream_rows(estimator, kFill, begin, [](std::size_t) {});
  estimator.finish_calibration();
  REQUIRE(estimator.calibration_source() == CalibrationSource::OnTheFly);

  // The on-the-fly range equals the training pipeline's (train::onthefly_ranges over the recorded
  // frames): the same 20-frame median over the same 60 Hz frames, from C_c solved in double here
  // and stored as float there.
  io::Dataset recorded = d;
  std::fill(recorded.kind.begin(), recorded.kind.begin() + kFill, io::kKindRecording);
  const auto ranges = train::onthefly_ranges(recorded);
  REQUIRE(ranges.size() == 1);
  const sensor::CalibrationRange& offline = ranges.begin()->second;
  const sensor::CalibrationRange& online = *estimator.calibration();
  const double range_difference =
      std::max((offline.min() - online.min()).cwiseAbs().maxCoeff(), (offline.max() - online.max()).cwiseAbs().maxCoeff());
  MESSAGE("on-the-fly range, stream vs recorded frames: largest difference " << range_difference << " pF");
  CHECK(range_difference < 1e-4);

  std::vector<hand::Angles> streamed(end - begin);
  std::vector<double> times(end - begin, -1.0);
  stream_rows(estimator, begin, end, [&](std::size_t f) {
    streamed[f - begin] = estimator.pose().raw_angles;
    times[f - begin] = estimator.pose().timestamp;
  });
  const std::vector<hand::Angles> batch = model->predict(d.cells.data() + begin * d.cell_count, static_cast<long>(end - begin), online, 2);

  // The recorder's readout ran 5 warm-up cycles of the session's own pose; the stream's ring still
  // holds the calibration's rows for the first mean_window cycles (10 leaves room for dropped rows).
  constexpr std::size_t kSettle = 10;
  double worst = 0.0, worst_time = 0.0;
  for (std::size_t i = kSettle; i < streamed.size(); ++i) {
    worst = std::max(worst, max_difference(streamed[i], batch[i]));
    worst_time = std::max(worst_time, std::abs(times[i] - d.timestamps[begin + i]));
  }
  MESSAGE("stream vs batch over " << streamed.size() - kSettle << " frames: largest angle difference " << worst << " rad");
  CHECK(worst < 1e-4);
  CHECK(worst_time < 1e-9);
  // And the poses are poses: the shipped model tracks this unseen subject (mean error in degrees).
  double error = 0.0;
  for (std::size_t i = kSettle; i < streamed.size(); ++i)
    for (std::size_t k = 0; k < hand::kDofCount; ++k) error += std::abs(streamed[i][k] - d.angles[(begin + i) * hand::kDofCount + k]);
  error *= core::kDegreesPerRadian / static_cast<double>((streamed.size() - kSettle) * hand::kDofCount);
  MESSAGE("mean angle error of the streamed poses: " << error << " degrees");
  CHECK(error < 10.0);
}

TEST_CASE("estimator: 16-bit weights on the shipped model: Fixed16 within 0.1 degree of F32 over a session, F16 exact, BF16 measured") {
  const io::Dataset& d = session().data;
  const std::size_t begin = session().first_session_frame, end = d.frames();
  const GlovePoseEstimator estimator = calibrated(shipped());
  const auto predict = [&](nn::WeightStorage storage) {
    PoseModelOptions options;
    options.storage = storage;
    return PoseModel::load(kShippedModel, options)
        ->predict(d.cells.data() + begin * d.cell_count, static_cast<long>(end - begin), *estimator.calibration(), 2);
  };
  const std::vector<hand::Angles> exact = predict(nn::WeightStorage::F32);
  const nn::WeightStorage storages[3] = {nn::WeightStorage::Fixed16, nn::WeightStorage::F16, nn::WeightStorage::BF16};
  double worst[3] = {0.0, 0.0, 0.0}, mean[3] = {0.0, 0.0, 0.0};
  for (int s = 0; s < 3; ++s) {
    const std::vector<hand::Angles> rounded = predict(storages[s]);
    for (std::size_t f = 0; f < exact.size(); ++f)
      for (std::size_t k = 0; k < hand::kDofCount; ++k) {
        const double degrees = std::abs(exact[f][k] - rounded[f][k]) * core::kDegreesPerRadian;
        worst[s] = std::max(worst[s], degrees);
        mean[s] += degrees / static_cast<double>(exact.size() * hand::kDofCount);
      }
  }
  MESSAGE("shipped model, " << exact.size() << " frames, largest angle difference to F32 (mean): Fixed16 " << worst[0] << " degrees ("
                            << mean[0] << "), F16 " << worst[1] << " (" << mean[1] << "), BF16 " << worst[2] << " (" << mean[2] << ")");
  CHECK(worst[0] > 0.0);  // Fixed16 rounds (2^-16 of the channel's largest weight)
  CHECK(worst[0] < 0.1);
  // The file stores binary16 weights and an FCN has no batch norm to fold: F16 keeps them exactly.
  CHECK(worst[1] == 0.0);
  CHECK(worst[2] > worst[0]);  // 8 significant bits: BF16 is not a bounded path
  CHECK(worst[2] > 0.05);
}

TEST_CASE("estimator: the shipped U-Net leaves about half of each hidden layer exactly zero over a session") {
  // docs/performance.md: the single-frame products skip zero activations, so this share sets how
  // much of the weights a frame reads. Measured, not assumed: the band is the claim the docs make.
  const io::Dataset& d = session().data;
  const GlovePoseEstimator estimator = calibrated(shipped_unet());
  const PoseModel& model = *shipped_unet();
  REQUIRE(model.network().unet() != nullptr);
  const auto& unet = *model.network().unet();
  auto ws = unet.make_workspace(1);
  Eigen::VectorXd raw(model.cell_count()), normalized(model.cell_count());
  std::array<float, nn::kUNetInputs> maps{};
  std::array<float, nn::kUNetOutputs> pose_map{};
  std::array<double, nn::kUNetBufferCount - 2> mean{};
  const std::size_t begin = session().first_session_frame, frames = d.frames() - begin;
  for (std::size_t f = begin; f < d.frames(); ++f) {
    for (int c = 0; c < model.cell_count(); ++c) raw(c) = d.cells[f * d.cell_count + static_cast<std::size_t>(c)];
    REQUIRE(estimator.calibration()->normalize(raw, normalized) == Status::Ok);
    REQUIRE(model.glove().map().to_stretch_maps(normalized.data(), maps) == Status::Ok);
    REQUIRE(unet.forward(maps, pose_map, ws) == Status::Ok);
    const auto fractions = nn::zero_fractions(unet, ws, 1);
    for (std::size_t l = 0; l < mean.size(); ++l) mean[l] += fractions[l] / static_cast<double>(frames);
  }
  MESSAGE("shipped model, " << frames << " frames, mean share of exact zeros e1..d3: " << mean[0] << " " << mean[1] << " " << mean[2] << " "
                            << mean[3] << " " << mean[4] << " " << mean[5] << " " << mean[6]);
  for (double share : mean) CHECK((share > 0.2 && share < 0.8));
}

TEST_CASE("estimator: rows, whole C_m frames and solved C_c frames give the same poses") {
  const auto model = shipped();
  const io::Dataset& d = session().data;
  const std::size_t begin = session().first_session_frame + 10, end = begin + 60;
  GlovePoseEstimator by_rows = calibrated(model), by_frames = calibrated(model), by_cells = calibrated(model);
  by_frames.set_calibration(*by_rows.calibration());
  by_cells.set_calibration(*by_rows.calibration());
  double worst_frames = 0.0, worst_cells = 0.0;
  std::vector<double> frame(d.row_count), cells(d.cell_count);
  stream_rows(by_rows, session().first_session_frame, end, [&](std::size_t f) {
    if (f < begin) return;
    // The same readings as one frame: with solve_every = 180 the ring holds the same values, so the
    // solve and the pose are the same.
    for (std::size_t r = 0; r < d.row_count; ++r) frame[r] = d.raw_rows[f * d.row_count + r];
    (void)by_frames.push_measurements(frame.data(), static_cast<int>(frame.size()), d.timestamps[f]);
    for (std::size_t c = 0; c < d.cell_count; ++c) cells[c] = by_rows.cells()[c];
    REQUIRE(by_cells.push_cells(cells.data(), static_cast<int>(cells.size()), d.timestamps[f]) == Status::Solved);
    worst_cells = std::max(worst_cells, max_difference(by_rows.pose().angles, by_cells.pose().angles));
  });
  // The frame path's ring was filled frame by frame from `begin` on: compare after it has cycled.
  GlovePoseEstimator rows_again = calibrated(model), frames_again = calibrated(model);
  frames_again.set_calibration(*rows_again.calibration());
  for (std::size_t f = session().first_session_frame; f < end; ++f) {
    for (std::size_t r = 0; r < d.row_count; ++r) frame[r] = d.raw_rows[f * d.row_count + r];
    const Status s = frames_again.push_measurements(frame.data(), static_cast<int>(frame.size()), d.timestamps[f]);
    stream_rows(rows_again, f, f + 1, [](std::size_t) {});
    REQUIRE(s == Status::Solved);
    if (f >= begin) worst_frames = std::max(worst_frames, max_difference(rows_again.pose().angles, frames_again.pose().angles));
  }
  MESSAGE("rows vs C_m frames: " << worst_frames << " rad; rows vs C_c frames: " << worst_cells << " rad");
  CHECK(worst_frames < 1e-12);
  CHECK(worst_cells < 1e-12);
}

TEST_CASE("estimator: calibration state machine, saved calibrations, training range") {
  const auto model = shipped();
  const io::Dataset& d = session().data;
  GlovePoseEstimator estimator(model, cycle_config());
  CHECK(estimator.calibration_source() == CalibrationSource::Continuous);  // the shipped model carries a range map
  estimator.clear_calibration();
  CHECK(estimator.calibration_source() == CalibrationSource::None);
  CHECK_THROWS_WITH_AS(estimator.finish_calibration(), doctest::Contains("start_calibration"), Error);
  // Without a range, solved frames give no pose.
  Status last = Status::Ok;
  stream_rows(estimator, 0, 6, [](std::size_t) {});
  for (int r = 0; r < 180; ++r) last = estimator.push_row(r, d.raw_rows[6 * d.row_count + static_cast<std::size_t>(r)], d.row_time(6, static_cast<std::size_t>(r)));
  CHECK(last == Status::Uncalibrated);
  CHECK_FALSE(estimator.pose().valid);

  estimator.start_calibration();
  stream_rows(estimator, 7, 20, [](std::size_t) {});
  CalibrationProgress p = estimator.calibration_progress();
  CHECK(p.collecting);
  CHECK(p.frames == 13);
  CHECK(p.frames_needed == 20);
  CHECK_FALSE(p.ready);
  CHECK_THROWS_WITH_AS(estimator.finish_calibration(), doctest::Contains("expected at least 20"), Error);
  stream_rows(estimator, 20, session().first_session_frame, [](std::size_t) {});
  CHECK(estimator.calibration_progress().ready);
  estimator.finish_calibration();
  CHECK(estimator.calibration_source() == CalibrationSource::OnTheFly);
  CHECK_FALSE(estimator.calibration_progress().collecting);

  // While a new calibration collects, poses keep coming from the old range, flagged.
  estimator.start_calibration();
  stream_rows(estimator, session().first_session_frame, session().first_session_frame + 1, [](std::size_t) {});
  CHECK(estimator.pose().valid);
  CHECK((estimator.pose().flags & kPoseCalibrating) != 0);
  estimator.cancel_calibration();

  // Save and load: the same range, exactly.
  const std::string path = std::string(GLOVEPOSE_TEST_TMP_DIR) + "/estimator_user.calibration";
  estimator.save_calibration(path);
  GlovePoseEstimator other(model, cycle_config());
  other.load_calibration(path);
  CHECK(other.calibration_source() == CalibrationSource::User);
  CHECK(other.calibration()->min() == estimator.calibration()->min());
  CHECK(other.calibration()->max() == estimator.calibration()->max());
  const sensor::CalibrationRange wrong(Eigen::VectorXd::Zero(3), Eigen::VectorXd::Ones(3), {"a", "b", "c"});
  CHECK_THROWS_WITH_AS(other.set_calibration(wrong), doctest::Contains("expected the 44 cells"), Error);

  // The model's training range: absent in the shipped (on-the-fly) model; present when recorded.
  CHECK_THROWS_WITH_AS(other.use_training_calibration(), doctest::Contains("no training-set range"), Error);
  model::UNetModel<> loaded = model::UNetModel<>::load(kUNetModel);
  loaded.info.calibration_min = std::vector<double>(44, 10.0);
  loaded.info.calibration_max = std::vector<double>(44, 30.0);
  const auto with_range = std::make_shared<const PoseModel>(loaded.info, loaded.unet, PoseModelOptions{});
  GlovePoseEstimator generic(with_range, cycle_config());
  generic.use_training_calibration();
  std::vector<double> cells(44, 20.0);
  REQUIRE(generic.push_cells(cells.data(), 44, 0.0) == Status::Solved);
  CHECK((generic.pose().flags & kPoseTrainingCalibration) != 0);
}

TEST_CASE("estimator: smoothing is the 1-euro filter of the raw angles, joints follow the kinematics") {
  const auto model = shipped();
  EstimatorConfig config = cycle_config();
  config.smoothing = filter::OneEuroConfig{60.0, 1.0, 0.5, 1.0};
  config.joint_transforms = true;
  GlovePoseEstimator estimator = calibrated(model, config);
  filter::OneEuroFilter<hand::kDofCount> reference(*config.smoothing);
  const hand::Kinematics kinematics;
  hand::Skeleton skeleton;
  double worst_filter = 0.0, worst_joint = 0.0, smoothing_effect = 0.0;
  const std::size_t begin = session().first_session_frame;
  stream_rows(estimator, begin, begin + 120, [&](std::size_t) {
    const Pose& p = estimator.pose();
    hand::Angles expected{};
    (void)reference.filter(p.raw_angles, p.timestamp, expected);
    worst_filter = std::max(worst_filter, max_difference(expected, p.angles));
    smoothing_effect = std::max(smoothing_effect, max_difference(p.raw_angles, p.angles));
    kinematics.pose(p.angles, skeleton);
    for (std::size_t f = 0; f < hand::kFingerCount; ++f) {
      const Eigen::Vector3d tip = kinematics.fingertip(skeleton, static_cast<hand::Finger>(f)) * 1e-3;
      const auto& joint = estimator.joints()[4 + 4 * f].position;
      worst_joint = std::max(worst_joint, (tip - Eigen::Vector3d(joint[0], joint[1], joint[2])).norm());
    }
  });
  // No pose (and no filtering) happens before the calibration ends: both filters start at `begin`.
  MESSAGE("smoothing: largest difference to the reference filter " << worst_filter << " rad, effect " << smoothing_effect << " rad");
  CHECK(worst_filter < 1e-12);
  CHECK(smoothing_effect > 1e-3);  // it does smooth
  CHECK(worst_joint < 1e-6);       // metres, float rounding
  // The joint list's documented frame: fingers along +Y at rest, flexion moves a tip towards -Z.
  hand::JointList rest{}, bent{};
  hand::Angles angles{};
  kinematics.pose(angles, skeleton);
  hand::to_joint_list(kinematics, skeleton, rest);
  angles[hand::dof_of(hand::Finger::Middle, hand::Motion::BaseFlexion)] = 1.0;
  kinematics.pose(angles, skeleton);
  hand::to_joint_list(kinematics, skeleton, bent);
  const auto tip = static_cast<std::size_t>(hand::Joint::MiddleTip);
  CHECK(rest[tip].position[1] > 0.1f);
  CHECK(bent[tip].position[2] < rest[tip].position[2] - 0.03f);
  CHECK(hand::kJointNames[tip] == std::string("middle_tip"));
}

TEST_CASE("estimator: the smoothing filter restarts with reset() and equals the reference from there") {
  const auto model = shipped();
  EstimatorConfig config = cycle_config();
  config.smoothing = filter::OneEuroConfig{60.0, 1.0, 0.5, 1.0};
  GlovePoseEstimator estimator = calibrated(model, config);
  estimator.reset();
  filter::OneEuroFilter<hand::kDofCount> reference(*config.smoothing);
  double worst = 0.0;
  int poses = 0;
  const std::size_t begin = session().first_session_frame;
  stream_rows(estimator, begin, begin + 60, [&](std::size_t) {
    hand::Angles expected{};
    (void)reference.filter(estimator.pose().raw_angles, estimator.pose().timestamp, expected);
    worst = std::max(worst, max_difference(expected, estimator.pose().angles));
    ++poses;
  });
  CHECK(poses == 60);  // after reset() the first pose comes once every row was read again
  CHECK(worst < 1e-12);
}

TEST_CASE("estimator: no heap allocation per row, per frame, while calibrating or smoothing") {
  const auto model = shipped();
  const io::Dataset& d = session().data;
  EstimatorConfig config;  // the paper's cadence: a solve every 16 rows
  config.smoothing = filter::OneEuroConfig{};
  config.joint_transforms = true;
  GlovePoseEstimator estimator = calibrated(model, config);
  const std::size_t begin = session().first_session_frame;
  std::vector<double> frame(d.row_count), cells(d.cell_count, 20.0);
  int poses = 0;
  const std::size_t allocations = test::allocations_during([&] {
    estimator.start_calibration();
    stream_rows(estimator, begin, begin + 30, [&](std::size_t) { ++poses; });
    estimator.cancel_calibration();
    stream_rows(estimator, begin + 30, begin + 60, [&](std::size_t) { ++poses; });
    for (std::size_t r = 0; r < d.row_count; ++r) frame[r] = d.raw_rows[(begin + 60) * d.row_count + r];
    (void)estimator.push_measurements(frame.data(), static_cast<int>(frame.size()), d.timestamps[begin + 60]);
    (void)estimator.push_cells(cells.data(), static_cast<int>(cells.size()), d.timestamps[begin + 60]);
    (void)estimator.push_row(3, std::nan(""), 1e9);
    (void)estimator.calibration_progress();
    PredictedPose ahead;
    hand::XrHandJoints joints;
    (void)estimator.pose_at(estimator.pose().timestamp + 0.02, ahead);
    (void)estimator.joints_at(estimator.pose().timestamp + 0.02, joints);
    (void)estimator.joints_at(estimator.pose().timestamp - 0.01, joints);
    estimator.reset();
  });
  CHECK(poses == 60);
  CHECK(estimator.pose().sequence > 600);  // 11.25 solves per 180-row cycle
  CHECK(allocations == 0);
}

TEST_CASE("estimator: one model shared by estimators on threads gives every stream the single-thread poses") {
  const auto model = shipped();
  const io::Dataset& d = session().data;
  const std::size_t begin = session().first_session_frame, end = std::min(d.frames(), begin + 120);
  const auto run = [&](std::vector<hand::Angles>& out) {
    GlovePoseEstimator estimator = calibrated(model);
    stream_rows(estimator, begin, end, [&](std::size_t) { out.push_back(estimator.pose().angles); });
  };
  std::vector<hand::Angles> alone;
  run(alone);
  std::vector<std::vector<hand::Angles>> results(4);
  std::vector<std::thread> threads;
  for (auto& r : results) threads.emplace_back(run, std::ref(r));
  for (auto& t : threads) t.join();
  for (const auto& r : results) CHECK(r == alone);
}

TEST_CASE("estimator: bad input is answered with a status and never reaches the pose") {
  const auto model = shipped();
  GlovePoseEstimator estimator = calibrated(model);
  const std::size_t f = session().first_session_frame;
  stream_rows(estimator, f, f + 1, [](std::size_t) {});
  const Pose before = estimator.pose();
  CHECK(estimator.push_row(-1, 30.0, 100.0) == Status::UnknownIndex);
  CHECK(estimator.push_row(180, 30.0, 100.0) == Status::UnknownIndex);
  CHECK(estimator.push_row(0, std::nan(""), 100.0) == Status::NonFinite);
  CHECK(estimator.push_row(0, INFINITY, 100.0) == Status::NonFinite);
  CHECK(estimator.push_row(0, -1.0, 100.0) == Status::Negative);
  CHECK(estimator.push_row(0, 30.0, 0.0) == Status::TimestampBackwards);
  std::vector<double> cells(44, 20.0);
  CHECK(estimator.push_cells(cells.data(), 43, 100.0) == Status::SizeMismatch);
  CHECK(estimator.push_cells(nullptr, 44, 100.0) == Status::SizeMismatch);
  cells[5] = std::nan("");
  CHECK(estimator.push_cells(cells.data(), 44, 100.0) == Status::NonFinite);
  std::vector<double> frame(179, 30.0);
  CHECK(estimator.push_measurements(frame.data(), 179, 100.0) == Status::SizeMismatch);
  CHECK(estimator.pose().sequence == before.sequence);
  CHECK(estimator.pose().angles == before.angles);
  // The rejected readings are counted in the next pose, and flagged.
  stream_rows(estimator, f + 1, f + 2, [](std::size_t) {});
  CHECK(estimator.pose().rejected >= 4);
  CHECK((estimator.pose().flags & kPoseReadingsRejected) != 0);
  for (double a : estimator.pose().angles) CHECK(std::isfinite(a));
}

TEST_CASE("estimator: set-up errors name what is wrong") {
  CHECK_THROWS_WITH_AS(GlovePoseEstimator(nullptr), doctest::Contains("no model"), Error);
  CHECK_THROWS_WITH_AS(PoseModel::load("/nonexistent/model.safetensors"), doctest::Contains("/nonexistent/model.safetensors"), Error);
  PoseModelOptions other;
  grid::GloveDescription builtin = grid::GloveDescription::glauser2019();
  other.glove = grid::GloveDescription("another-glove", builtin.cell_names(), builtin.map());
  CHECK_THROWS_WITH_AS(PoseModel::load(kShippedModel, other), doctest::Contains("expected the model's glove 'glauser2019-44'"), Error);
  EstimatorConfig config;
  config.calibration_sample_period = -1.0;
  CHECK_THROWS_WITH_AS(GlovePoseEstimator(shipped(), config), doctest::Contains("calibration_sample_period"), Error);
  config = EstimatorConfig{};
  config.prediction_window = 0.0;
  CHECK_THROWS_WITH_AS(GlovePoseEstimator(shipped(), config), doctest::Contains("prediction_window 0.000000 s, expected a positive time"),
                       Error);
  config = EstimatorConfig{};
  config.max_prediction = std::nan("");
  CHECK_THROWS_WITH_AS(GlovePoseEstimator(shipped(), config), doctest::Contains("max_prediction"), Error);
}

TEST_CASE("estimator: pose_at interpolates the recent poses and extrapolates their least-squares slope up to the bound") {
  const auto model = shipped();
  const io::Dataset& d = session().data;
  EstimatorConfig config;  // the paper's cadence: a pose every 16 rows
  GlovePoseEstimator estimator = calibrated(model, config);
  PredictedPose out;
  hand::XrHandJoints joints;
  GlovePoseEstimator fresh(model, config);
  CHECK(fresh.pose_at(0.0, out) == Status::NotReady);
  CHECK(fresh.joints_at(0.0, joints) == Status::NotReady);
  CHECK_FALSE(joints.active);
  std::vector<double> times;
  std::vector<hand::Angles> poses;
  const std::size_t begin = session().first_session_frame;
  for (std::size_t f = begin; f < begin + 20; ++f)
    for (int r = 0; r < static_cast<int>(d.row_count); ++r)
      if (estimator.push_row(r, d.raw_rows[f * d.row_count + static_cast<std::size_t>(r)], d.row_time(f, static_cast<std::size_t>(r))) == Status::Solved) {
        times.push_back(estimator.pose().timestamp);
        poses.push_back(estimator.pose().angles);
      }
  REQUIRE(poses.size() > 200);
  const std::size_t n = poses.size();
  // Between two poses: the straight line between them.
  const double mid = 0.25 * times[n - 3] + 0.75 * times[n - 2];
  REQUIRE(estimator.pose_at(mid, out) == Status::Ok);
  CHECK_FALSE(out.predicted);
  CHECK(out.horizon == doctest::Approx(mid - times[n - 1]));
  for (std::size_t k = 0; k < hand::kDofCount; ++k)
    CHECK(out.angles[k] == doctest::Approx(0.25 * poses[n - 3][k] + 0.75 * poses[n - 2][k]).epsilon(1e-12));
  // Ahead: the newest pose moved along the least-squares line through the poses of the window.
  std::vector<std::size_t> window;
  for (std::size_t i = 0; i < n; ++i)
    if (times[n - 1] - times[i] <= config.prediction_window) window.push_back(i);
  REQUIRE(window.size() > 10);
  Eigen::MatrixXd design(static_cast<Eigen::Index>(window.size()), 2);
  Eigen::MatrixXd values(static_cast<Eigen::Index>(window.size()), static_cast<Eigen::Index>(hand::kDofCount));
  for (std::size_t i = 0; i < window.size(); ++i) {
    design(static_cast<Eigen::Index>(i), 0) = 1.0;
    design(static_cast<Eigen::Index>(i), 1) = times[window[i]] - times[n - 1];
    for (std::size_t k = 0; k < hand::kDofCount; ++k)
      values(static_cast<Eigen::Index>(i), static_cast<Eigen::Index>(k)) = poses[window[i]][k];
  }
  const Eigen::MatrixXd line = design.colPivHouseholderQr().solve(values);
  const double t = times[n - 1] + 0.02;
  REQUIRE(estimator.pose_at(t, out) == Status::Ok);
  CHECK(out.predicted);
  CHECK_FALSE(out.clamped);
  CHECK(out.has_rate);
  const hand::JointLimits& limits = model->joint_limits();
  for (std::size_t k = 0; k < hand::kDofCount; ++k) {
    const double slope = line(1, static_cast<Eigen::Index>(k));
    CHECK(out.rate[k] == doctest::Approx(slope).epsilon(1e-9));
    CHECK(out.angles[k] == doctest::Approx(std::clamp(poses[n - 1][k] + 0.02 * slope, limits.min()[k], limits.max()[k])).epsilon(1e-9));
  }
  // Beyond the bound: located at the bound, flagged, not tracked.
  REQUIRE(estimator.pose_at(times[n - 1] + 1.0, out) == Status::Ok);
  CHECK(out.clamped);
  CHECK(out.horizon == doctest::Approx(config.max_prediction));
  REQUIRE(estimator.joints_at(times[n - 1] + 1.0, joints) == Status::Ok);
  CHECK(joints.active);
  CHECK(joints.locations[0].location_flags == (hand::kXrOrientationValid | hand::kXrPositionValid));
  REQUIRE(estimator.joints_at(times[n - 1], joints) == Status::Ok);
  CHECK(joints.locations[0].location_flags == (estimator.pose().trusted() ? 0xFu : 0x3u));
  CHECK(joints.velocities[5].velocity_flags == (hand::kXrLinearVelocityValid | hand::kXrAngularVelocityValid));
  CHECK(estimator.pose_at(std::nan(""), out) == Status::NonFinite);
  // A reader of LatestHand predicts the same from the published state.
  PredictedPose from_state;
  REQUIRE(predict(estimator.state(), estimator.locator(), t, config.max_prediction, from_state) == Status::Ok);
  REQUIRE(estimator.pose_at(t, out) == Status::Ok);
  for (std::size_t k = 0; k < hand::kDofCount; ++k) CHECK(from_state.angles[k] == out.angles[k]);
  estimator.reset();
  CHECK(estimator.pose_at(t, out) == Status::NotReady);
}

TEST_CASE("estimator: a left-hand session gives the mirrored joints of the right-hand session") {
  const Session& right_session = session();
  static const Session left_session = simulate_session(hand::Handedness::Left);
  // The mirrored hand in the mirrored glove stretches every cell as the right one does.
  REQUIRE(left_session.data.raw_rows.size() == right_session.data.raw_rows.size());
  CHECK(left_session.data.raw_rows == right_session.data.raw_rows);
  EstimatorConfig config = cycle_config();
  config.joint_transforms = true;
  GlovePoseEstimator right = calibrated(shipped(), config, right_session);
  config.handedness = hand::Handedness::Left;
  GlovePoseEstimator left = calibrated(shipped(), config, left_session);
  const std::size_t begin = right_session.first_session_frame;
  double worst_xr = 0.0, worst_list = 0.0, thumb_x = 0.0;
  int poses = 0;
  stream_rows(
      right, begin, begin + 60,
      [&](std::size_t f) {
        stream_rows(
            left, f, f + 1, [](std::size_t) {}, left_session.data);
        ++poses;
        hand::XrHandJoints r, l;
        REQUIRE(right.joints_at(right.pose().timestamp + 0.01, r) == Status::Ok);
        REQUIRE(left.joints_at(right.pose().timestamp + 0.01, l) == Status::Ok);
        CHECK(l.side == hand::Handedness::Left);
        for (std::size_t j = 0; j < hand::kXrJointCount; ++j) {
          const hand::XrPose& a = r.locations[j].pose;
          const hand::XrPose& b = l.locations[j].pose;
          for (float diff : {b.position.x + a.position.x, b.position.y - a.position.y, b.position.z - a.position.z,
                             b.orientation.x - a.orientation.x, b.orientation.y + a.orientation.y, b.orientation.z + a.orientation.z,
                             b.orientation.w - a.orientation.w, l.velocities[j].linear_velocity.x + r.velocities[j].linear_velocity.x,
                             l.velocities[j].linear_velocity.y - r.velocities[j].linear_velocity.y})
            worst_xr = std::max(worst_xr, static_cast<double>(std::abs(diff)));
        }
        thumb_x = l.locations[static_cast<std::size_t>(hand::XrJoint::ThumbTip)].pose.position.x;
        for (std::size_t j = 0; j < hand::kJointCount; ++j) {
          const auto& a = right.joints()[j].position;
          const auto& b = left.joints()[j].position;
          worst_list = std::max({worst_list, static_cast<double>(std::abs(a[0] + b[0])), static_cast<double>(std::abs(a[1] - b[1])),
                                 static_cast<double>(std::abs(a[2] - b[2]))});
        }
      },
      right_session.data);
  CHECK(poses == 60);
  MESSAGE("left vs mirrored right: OpenXR joints " << worst_xr << ", joint list " << worst_list << " m");
  CHECK(worst_xr < 1e-5);
  CHECK(worst_list < 1e-6);
  CHECK(thumb_x < 0.0);
}
