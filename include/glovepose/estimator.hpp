/// @file estimator.hpp
/// @brief GlovePoseEstimator: the one class that composes the stages, from the glove's rows to a
/// hand pose (docs/architecture.md).
///
/// Two objects:
/// - PoseModel: what is loaded once and shared, immutable, by any number of estimators on any number
///   of threads: the network, the glove description, the capacitance solver of the glove's wiring,
///   the joint limits and the model's training-set calibration range.
/// - GlovePoseEstimator: one glove's stream. It owns the per-stream state (the readout ring, the
///   calibration, the 1-euro filter, the network's workspace) and answers every per-frame call
///   without allocating or throwing.
///
/// Inputs, whichever the glove's firmware delivers: raw rows (row, value, timestamp), whole frames
/// of compound measurements C_m, or already solved cell capacitances C_c. Each accepted input that
/// completes a frame yields a Pose: 25 angles, timestamp, status flags, and the frame's latency
/// budget (age of the oldest reading, compute time).
#pragma once

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <limits>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include "calibration/pose_offset.hpp"
#include "calibration_session.hpp"
#include "calibration/user_calibration.hpp"
#include "config.hpp"
#include "estimator_config.hpp"
#include "filter/one_euro.hpp"
#include "filter/trend.hpp"
#include "grid/glove_description.hpp"
#include "grid/grid_map.hpp"
#include "hand/dofs.hpp"
#include "hand/joint_list.hpp"
#include "hand/kinematics.hpp"
#include "core/latest.hpp"
#include "model/model_info.hpp"
#include "pose.hpp"
#include "pose_model.hpp"
#include "model/pose_network.hpp"
#include "sensor/calibration.hpp"
#include "sensor/layout.hpp"
#include "sensor/readout.hpp"
#include "sensor/solver.hpp"
#include "status.hpp"
#include "hand/xr_hand.hpp"

namespace glovepose {

/// @brief One glove stream: rows, frames or solved cells in, poses out. See the file comment.
///
/// Per-frame calls (push_*, pose(), joints(), calibration_progress(), start/cancel_calibration(),
/// reset()) are noexcept and never allocate. Calibration calls that build a range (finish, set,
/// load, save, use_training_calibration) are set-up code and throw glovepose::Error.
/// One estimator is used by one thread at a time; estimators sharing a model may run concurrently.
class GlovePoseEstimator {
 public:
  /// @brief An estimator over a shared model. Throws glovepose::Error for a null model or bad settings.
  explicit GlovePoseEstimator(std::shared_ptr<const PoseModel> model, EstimatorConfig config = {})
      : model_(checked(std::move(model))),
        config_(with_glove_calibration(std::move(config), model_->glove())),
        calibration_session_(model_->glove().cell_names(), config_.calibration_median_window, config_.calibration,
                             config_.calibration_sample_period,
                             model_->pose_offset() && config_.calibration_method != CalibrationMethod::MinMax ? &model_->pose_offset()->sequence()
                                                                                                                 : nullptr),
        workspace_(model_->network().make_workspace(checked_threads(config_.network_threads))),
        kinematics_(config_.hand, config_.handedness),
        trend_(config_.prediction_window),
        locator_(config_.hand, config_.handedness, model_->joint_limits()),
        aim_tracker_(locator_.mapper()) {
    if (!(config_.prediction_window > 0.0) || !std::isfinite(config_.prediction_window))
      throw Error("GlovePoseEstimator: prediction_window " + std::to_string(config_.prediction_window) + " s, expected a positive time");
    if (!(config_.max_prediction >= 0.0) || !std::isfinite(config_.max_prediction))
      throw Error("GlovePoseEstimator: max_prediction " + std::to_string(config_.max_prediction) + " s, expected a time of at least 0");
    if (config_.clock_restart_frames < 1)
      throw Error("GlovePoseEstimator: clock_restart_frames " + std::to_string(config_.clock_restart_frames) + ", expected at least 1");
    if (config_.smoothing) smoothing_.emplace(*config_.smoothing);
    if (config_.contact) contact_.emplace(kinematics_, model_->joint_limits(), *config_.contact);
    if (config_.network_threads > 1 && model_->network().architecture() == model::Architecture::UNet) team_ = std::make_unique<core::Team>(config_.network_threads);
    if (model_->solver()) {
      readout_.emplace(model_->solver(), config_.readout);
      measurements_ = Eigen::VectorXd::Zero(model_->solver()->layout().row_count());
    }
    cells_ = Eigen::VectorXd::Zero(model_->cell_count());
    normalized_ = Eigen::VectorXd::Zero(model_->cell_count());
    skeleton_.fill(Eigen::Affine3d::Identity());
    if (config_.calibration_method == CalibrationMethod::PoseGuided && !model_->pose_offset())
      throw Error(
          "GlovePoseEstimator: calibration_method PoseGuided, but the model carries no pose-guided calibration, expected a model fitted by "
          "glovepose fit-guided");
  }

  // ---- input -------------------------------------------------------------------------------

  /// @brief One reading of measurement row `row` at `timestamp` (s). Returns Status::Solved when it
  /// completed a frame and a new pose is in pose(); Status::Ok or Status::NotReady when accepted
  /// without a new pose; Status::Uncalibrated when a frame was solved but no calibration range is
  /// set; a rejection status (readout.hpp) otherwise, or Status::UnknownIndex when the model has no
  /// wiring. A rejected reading changes nothing but the count in Pose::rejected.
  GLOVEPOSE_REALTIME Status push_row(int row, double value, double timestamp) noexcept {
    if (!readout_) return Status::UnknownIndex;
    const auto start = std::chrono::steady_clock::now();
    const Status status = readout_->push_row(row, value, timestamp);
    if (status != Status::Solved) return status;
    return estimate_from_readout(start);
  }

  /// @brief A whole frame of `count` compound measurements C_m at `timestamp`, solved at once. Bad
  /// rows are skipped (their previous readings stay in use) and counted; see Readout::push_frame.
  GLOVEPOSE_REALTIME Status push_measurements(const double* values, int count, double timestamp) noexcept {
    if (!readout_) return Status::UnknownIndex;
    if (values == nullptr || count != measurements_.size()) return Status::SizeMismatch;
    const auto start = std::chrono::steady_clock::now();
    measurements_ = Eigen::Map<const Eigen::VectorXd>(values, count);
    const Status status = readout_->push_frame(measurements_, timestamp);
    if (status != Status::Solved) return status;
    return estimate_from_readout(start);
  }

  /// @brief A frame of `count` already solved cell capacitances C_c at `timestamp` (firmware that
  /// solves on board). `oldest_age` is the age of its oldest reading, if the firmware knows it.
  /// After a gap (ReadoutConfig::gap_seconds) or a clock restart (clock_restart_frames frames
  /// timestamped backwards in a row; fewer are rejected) the smoothing starts over.
  GLOVEPOSE_REALTIME Status push_cells(const double* cells, int count, double timestamp, double oldest_age = 0.0) noexcept {
    if (cells == nullptr || count != cells_.size()) return Status::SizeMismatch;
    if (!std::isfinite(timestamp) || !std::isfinite(oldest_age)) return Status::NonFinite;
    for (int c = 0; c < count; ++c)
      if (!std::isfinite(cells[c])) return Status::NonFinite;
    if (timestamp < last_cells_timestamp_) {
      if (++cells_backwards_run_ < config_.clock_restart_frames) return Status::TimestampBackwards;
      last_cells_timestamp_ = -std::numeric_limits<double>::infinity();
    }
    const auto start = std::chrono::steady_clock::now();
    const bool restarted = !std::isfinite(last_cells_timestamp_) || timestamp - last_cells_timestamp_ > config_.readout.gap_seconds;
    if (restarted && smoothing_) smoothing_->reset();
    if (restarted && contact_) contact_->reset();
    cells_backwards_run_ = 0;
    cells_ = Eigen::Map<const Eigen::VectorXd>(cells, count);
    last_cells_timestamp_ = timestamp;
    return estimate(cells_, timestamp, oldest_age, 0, sensor::ReadoutHealth{}, start);
  }

  // ---- output ------------------------------------------------------------------------------

  /// @brief The latest pose (Pose::valid is false before the first).
  const Pose& pose() const noexcept { return pose_; }
  /// @brief The latest skeleton (reference chain, mm; posed with every pose: the pinch state reads its fingertips).
  const hand::Skeleton& skeleton() const noexcept { return skeleton_; }
  /// @brief What the contact stage (EstimatorConfig::contact) did to the latest pose: the pairs in
  /// contact and the one adjusted (none when the stage is off).
  const hand::ContactResult& contact() const noexcept { return contact_result_; }
  /// @brief The latest joint list (metres, quaternions; hand/joint_list.hpp), when joint_transforms is on.
  const hand::JointList& joints() const noexcept { return joints_; }
  /// @brief The latest solved cell capacitances C_c (the network's input before calibration).
  const Eigen::VectorXd& cells() const noexcept { return cells_; }
  /// @brief The latest calibrated cells in [-1, 1] (the network's input), when a pose came from them.
  const Eigen::VectorXd& normalized_cells() const noexcept { return normalized_; }
  /// @brief The latest pose, joint list, calibration progress and rate together (for LatestHand).
  /// The rate is filter::Trend::slope(), kept as poses arrive: a few dozen nanoseconds.
  HandState state() const noexcept { return HandState{pose_, joints_, calibration_progress(), trend_.slope(), trend_.has_slope()}; }

  /// @brief The pose at time t (the stream's clock): from the recent poses when t is not after the
  /// newest (interpolated; the oldest held for earlier times), else extrapolated along the recent
  /// poses' slope for at most EstimatorConfig::max_prediction seconds, held within the joint limits.
  /// Status::NotReady before the first pose (since the last reset), NonFinite for a non-finite t.
  GLOVEPOSE_REALTIME Status pose_at(double t, PredictedPose& out) const noexcept {
    if (!pose_.valid || trend_.size() == 0) return Status::NotReady;
    const Status status = predict(pose_, trend_.slope(), trend_.has_slope(), locator_, t, config_.max_prediction, out);
    if (status != Status::Ok || out.predicted) return status;
    out.horizon = t - pose_.timestamp;
    return trend_.at(t, out.angles);
  }

  /// @brief The OpenXR joints (hand/xr_hand.hpp) at time t, located from pose_at(t), with velocities.
  GLOVEPOSE_REALTIME Status joints_at(double t, XrHandJoints& out) const noexcept {
    PredictedPose pose;
    const Status status = pose_at(t, pose);
    if (status != Status::Ok) {
      out.active = false;
      return status;
    }
    locate(pose, locator_, out);
    return Status::Ok;
  }

  /// @brief The pinch and aim state of the latest pose (hand/xr_hand.hpp, XR_FB_hand_tracking_aim):
  /// pinch strengths, the pinching flags with their hysteresis kept from pose to pose, the aim pose
  /// in the wrist frame. active is false before the first pose. Publish it to reader threads with a
  /// LatestAim beside the LatestHand.
  const XrHandAim& aim() const noexcept { return aim_tracker_.aim(); }

  /// @brief The locator of this estimator's hand (side, hand model, joint limits), for readers of
  /// LatestHand that locate joints on their own thread (predict() and locate()).
  const XrHandLocator& locator() const noexcept { return locator_; }

  // ---- calibration -------------------------------------------------------------------------

  /// @brief Starts (or restarts) an on-the-fly calibration: from now on solved frames also feed the
  /// per-sensor min/max (median of calibration_median_window frames). The user moves through
  /// extreme poses; poses keep coming from the previous range, if any, flagged kPoseCalibrating.
  /// With a pose-guided calibration the user follows the model's calibration sequence, whose clock
  /// starts at the first frame taken (calibration_progress() says which step is under way).
  void start_calibration() noexcept { calibration_session_.start(); }
  /// @brief How far the calibration has come.
  CalibrationProgress calibration_progress() const noexcept { return calibration_session_.progress(); }
  /// @brief Ends the calibration and uses its range. Throws glovepose::Error (and keeps collecting)
  /// when fewer frames than the median window arrived or no calibration was started. The range's
  /// flat sensors (too small a range) are listed by CalibrationRange::flat_sensors().
  /// With CalibrationMethod::PoseGuided (or Auto when the model carries one and the whole sequence
  /// was performed) it also estimates the user's angle offsets (calibration_offsets()); PoseGuided
  /// throws glovepose::Error naming the first step that was not held. Bounded time: one network
  /// forward per held frame of the sequence.
  const sensor::CalibrationRange& finish_calibration() {
    if (!calibration_session_.collecting())
      throw Error("GlovePoseEstimator::finish_calibration: no calibration running, expected start_calibration() first");
    sensor::CalibrationRange range = calibration_session_.range();
    std::optional<hand::Angles> offsets;
    if (model_->pose_offset() && config_.calibration_method != CalibrationMethod::MinMax) offsets = guided_offsets(range);
    set_range(std::move(range), CalibrationSource::OnTheFly, offsets);
    calibration_session_.stop();
    return *range_;
  }
  /// @brief Stops collecting and keeps the previous range.
  void cancel_calibration() noexcept { calibration_session_.stop(); }
  /// @brief Uses a range the caller has (e.g. a saved user calibration). Throws glovepose::Error
  /// when its size or sensor names differ from the glove's.
  void set_calibration(const sensor::CalibrationRange& range) {
    if (range.size() != model_->cell_count() || range.names() != model_->glove().cell_names())
      throw Error("GlovePoseEstimator::set_calibration: a range of " + std::to_string(range.size()) +
                  " sensors with other names, expected the " + std::to_string(model_->cell_count()) + " cells of glove '" +
                  model_->glove().id() + "'");
    set_range(range, CalibrationSource::User);
  }
  /// @brief Uses a range and the pose-guided angle offsets (radians) the caller has.
  void set_calibration(const sensor::CalibrationRange& range, const hand::Angles& offsets) {
    for (double o : offsets)
      if (!std::isfinite(o)) throw Error("GlovePoseEstimator::set_calibration: a non-finite angle offset, expected finite radians");
    set_calibration(range);
    offsets_ = offsets;
    guided_ = true;
  }
  /// @brief Loads a calibration saved by save_calibration() for this glove (its range and, when it
  /// was pose-guided, its angle offsets).
  void load_calibration(const std::string& path) {
    calibration::UserCalibration user =
        calibration::UserCalibration::load(path, model_->glove().id(), model_->glove().cell_names(), config_.calibration);
    set_range(std::move(user.range), CalibrationSource::User, user.offsets);
  }
  /// @brief Saves the calibration in use, range and pose-guided offsets (to load it for the same
  /// user and glove later).
  void save_calibration(const std::string& path) const {
    if (!range_) throw Error("GlovePoseEstimator::save_calibration: no calibration range set, expected one to save");
    calibration::UserCalibration{*range_, guided_ ? std::optional<hand::Angles>(offsets_) : std::nullopt}.save(path, model_->glove().id());
  }
  /// @brief Uses the model's training-set range. Throws glovepose::Error when the file has none.
  void use_training_calibration() {
    if (!model_->training_range())
      throw Error(
          "GlovePoseEstimator::use_training_calibration: the model records no training-set range, expected a model trained with "
          "--calibration-mode training");
    set_range(*model_->training_range(), CalibrationSource::Training);
  }
  /// @brief The range in use, if any.
  const std::optional<sensor::CalibrationRange>& calibration() const noexcept { return range_; }
  /// @brief Where the range in use came from.
  CalibrationSource calibration_source() const noexcept { return source_; }
  /// @brief The method of the calibration in use: PoseGuided when angle offsets are applied, MinMax otherwise.
  CalibrationMethod calibration_method() const noexcept { return guided_ ? CalibrationMethod::PoseGuided : CalibrationMethod::MinMax; }
  /// @brief The angle offsets (radians) added to every pose; zero unless pose-guided.
  const hand::Angles& calibration_offsets() const noexcept { return offsets_; }

  // ---- state -------------------------------------------------------------------------------

  /// @brief Forgets the stream (readings, filter, timestamps, the pinch flags' history), e.g. after
  /// the glove was unplugged or its clock restarted; keeps the calibration and the last pose (marked
  /// by its sequence) and its aim().
  void reset() noexcept {
    if (readout_) readout_->reset();
    if (smoothing_) smoothing_->reset();
    if (contact_) contact_->reset();
    trend_.reset();
    aim_tracker_.reset();
    last_cells_timestamp_ = -std::numeric_limits<double>::infinity();
    cells_backwards_run_ = 0;
    calibration_session_.restart_clock();
  }
  /// @brief The shared model.
  const PoseModel& model() const noexcept { return *model_; }
  /// @brief The settings in use, the glove's filled in where the given ones said "the glove's"
  /// (calibration_median_window 0, a negative calibration.min_relative_range or min_range_to_noise).
  const EstimatorConfig& config() const noexcept { return config_; }

 private:
  // The settings that say "the glove's" made the glove's: its flat and noise rules, and a median window
  // spanning its median_seconds at the period frames are taken. Frames are taken no faster than the
  // glove's rate (its frame period when that is longer than the sample period), as training saw them.
  static EstimatorConfig with_glove_calibration(EstimatorConfig config, const grid::GloveDescription& glove) {
    if (!(config.calibration_sample_period >= 0.0) || !std::isfinite(config.calibration_sample_period))
      throw Error("GlovePoseEstimator: calibration_sample_period " + std::to_string(config.calibration_sample_period) +
                  " s, expected a finite value >= 0");
    const grid::GloveCalibration& own = glove.calibration();
    if (config.calibration.min_relative_range < 0.0) config.calibration.min_relative_range = own.flat_relative_range;
    if (config.calibration.min_range_to_noise < 0.0) config.calibration.min_range_to_noise = own.min_range_to_noise;
    if (glove.rate_hz() && config.calibration_sample_period > 0.0)
      config.calibration_sample_period = std::max(config.calibration_sample_period, 1.0 / *glove.rate_hz());
    if (config.calibration_median_window == 0) {
      double period = config.calibration_sample_period;
      if (!(period > 0.0)) period = 1.0 / 60.0;  // 0: every frame is taken, at the 60 Hz the glove streams
      config.calibration_median_window = own.median_frames(1.0 / period);
    }
    return config;
  }

  static std::shared_ptr<const PoseModel> checked(std::shared_ptr<const PoseModel> model) {
    if (!model) throw Error("GlovePoseEstimator: no model given, expected a loaded PoseModel");
    return model;
  }
  static int checked_threads(int threads) {
    if (threads < 1 || threads > 64) throw Error("GlovePoseEstimator: network_threads " + std::to_string(threads) + ", expected 1..64");
    return threads;
  }

  void set_range(sensor::CalibrationRange range, CalibrationSource source, const std::optional<hand::Angles>& offsets = std::nullopt) {
    range_.emplace(std::move(range));
    source_ = source;
    guided_ = offsets.has_value();
    offsets_ = offsets.value_or(hand::Angles{});
  }

  // Calibrated cells -> network (the U-Net through the stretch maps and the pose map) -> angles (radians), the network's
  // angles as the pose and the pose-guided calibration both see them. `angles` is untouched on failure.
  Status network_angles(const Eigen::VectorXd& normalized, hand::Angles& angles) noexcept {
    hand::Angles normalized_angles{};
    const Status net =
        model_->network().normalized_dofs(model_->glove().map(), normalized.data(), normalized_angles, workspace_, team_.get());
    if (net != Status::Ok) return net;
    angles = model_->joint_limits().denormalize(model_->model_outputs(normalized_angles));
    return Status::Ok;
  }

  // The pose-guided offsets of the frames stored during the sequence, calibrated by `range`;
  // nullopt when the sequence was not performed to the end (Auto falls back to min-max).
  std::optional<hand::Angles> guided_offsets(const sensor::CalibrationRange& range) {
    const calibration::PoseOffsetModel& model = *model_->pose_offset();
    calibration::StepHoldMeans means(model.sequence(), model_->cell_count());
    Eigen::VectorXd raw(model_->cell_count()), normalized(model_->cell_count());
    std::vector<float> cells(static_cast<std::size_t>(model_->cell_count()));
    for (Eigen::Index f = 0; f < calibration_session_.sequence_frames(); ++f) {
      const double t = calibration_session_.sequence_time(f);
      if (!means.holding(t)) continue;
      raw = calibration_session_.sequence_cells(f).transpose();
      hand::Angles angles{};
      if (range.normalize(raw, normalized) != Status::Ok || network_angles(normalized, angles) != Status::Ok) continue;
      for (Eigen::Index c = 0; c < normalized.size(); ++c) cells[static_cast<std::size_t>(c)] = static_cast<float>(normalized(c));
      means.add(t, angles, cells.data());
    }
    if (!means.missing_step().empty()) {
      if (config_.calibration_method == CalibrationMethod::PoseGuided) (void)means.features();  // throws, naming the step
      return std::nullopt;
    }
    const Eigen::VectorXd features = means.features();
    if (!model.followed(features)) {
      if (config_.calibration_method == CalibrationMethod::PoseGuided)
        throw Error("GlovePoseEstimator::finish_calibration: the calibration does not look like sequence '" + model.sequence().id() +
                    "' (RMS z-score " + std::to_string(model.rms_z(features)) + ", at most " +
                    std::to_string(calibration::kFollowedMargin * model.max_rms_z()) +
                    " among the people the model was fitted on), expected the user to follow its steps");
      return std::nullopt;
    }
    return model.offsets(features);
  }

  Status estimate_from_readout(std::chrono::steady_clock::time_point start) noexcept {
    const auto& frame = readout_->frame();
    // A gap or a clock restart started the readout over: the smoothing follows (its clock and its
    // history belong to the stream before).
    if (frame.health.restarts != readout_restarts_) {
      if (smoothing_) smoothing_->reset();
      if (contact_) contact_->reset();
      trend_.reset();
    }
    readout_restarts_ = frame.health.restarts;
    return estimate(frame.cells, frame.timestamp, frame.oldest_age, frame.rejected, frame.health, start);
  }

  static std::uint32_t fault_flags(const sensor::ReadoutHealth& health) noexcept {
    std::uint32_t flags = 0;
    if (health.filling_rows > 0) flags |= kPoseRecovering;
    if (health.stale_rows > 0) flags |= kPoseStaleReadings;
    if (health.stuck_rows > 0) flags |= kPoseStuckRows;
    if (health.disconnected_rows > 0) flags |= kPoseDisconnectedRows;
    if (health.outlier_rows > 0) flags |= kPoseOutlierRows;
    return flags;
  }

  Status estimate(const Eigen::VectorXd& cells, double timestamp, double oldest_age, std::uint32_t rejected,
                  const sensor::ReadoutHealth& health, std::chrono::steady_clock::time_point start) noexcept {
    if (&cells != &cells_) cells_ = cells;
    rejected_ += rejected;
    calibration_session_.add(cells, timestamp);  // takes the frame while a calibration collects
    if (!range_) return Status::Uncalibrated;
    if (range_->normalize(cells, normalized_) != Status::Ok) return Status::NonFinite;
    std::uint32_t flags = fault_flags(health) | (rejected_ > 0 ? kPoseReadingsRejected : 0u);
    if (normalized_.cwiseAbs().maxCoeff() >= config_.calibration.clamp_limit) flags |= kPoseInputClamped;
    if (source_ == CalibrationSource::Training) flags |= kPoseTrainingCalibration;
    if (calibration_session_.collecting()) flags |= kPoseCalibrating;
    const Status net = network_angles(normalized_, pose_.raw_angles);
    if (net != Status::Ok) return net;
    if (guided_) pose_.raw_angles = calibration::with_offsets(pose_.raw_angles, offsets_, model_->joint_limits());
    pose_.angles = pose_.raw_angles;
    if (smoothing_) (void)smoothing_->filter(pose_.raw_angles, timestamp, pose_.angles);
    kinematics_.pose(pose_.angles, skeleton_);  // the pinch state's fingertips, and the joints when asked
    if (contact_) contact_result_ = contact_->apply(pose_.angles, skeleton_);  // adjusts the skeleton with the angles
    if (config_.joint_transforms) hand::to_joint_list(kinematics_, skeleton_, joints_);
    (void)trend_.add(timestamp, pose_.angles);  // refuses non-finite angles, keeping the trend as it was
    pose_.timestamp = timestamp;
    pose_.oldest_age = oldest_age;
    pose_.rejected = rejected_;
    pose_.flags = flags;
    pose_.health = health;
    pose_.valid = true;
    ++pose_.sequence;
    (void)aim_tracker_.update(hand::pinch_distances(hand::fingertip_positions(kinematics_, skeleton_)), pose_.trusted(), timestamp,
                              pose_.sequence);
    rejected_ = 0;
    pose_.compute_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    return Status::Solved;
  }

  std::shared_ptr<const PoseModel> model_;
  EstimatorConfig config_;
  std::optional<sensor::Readout> readout_;
  CalibrationSession calibration_session_;  // an on-the-fly calibration while it runs
  std::optional<sensor::CalibrationRange> range_;
  CalibrationSource source_ = CalibrationSource::None;
  bool guided_ = false;               // offsets_ apply (pose-guided calibration in use)
  hand::Angles offsets_{};            // per-user angle offsets, radians
  std::optional<filter::OneEuroFilter<hand::kDofCount>> smoothing_;
  std::optional<hand::ContactStage> contact_;  // EstimatorConfig::contact
  hand::ContactResult contact_result_;
  model::PoseNetwork::Workspace workspace_;
  std::unique_ptr<core::Team> team_;  // network_threads > 1 with a U-Net
  hand::Kinematics kinematics_;
  filter::Trend<hand::kDofCount> trend_;
  XrHandLocator locator_;
  XrAimTracker aim_tracker_;  // the pinch flags' hysteresis and the latest aim state
  Eigen::VectorXd measurements_;
  Eigen::VectorXd cells_;
  Eigen::VectorXd normalized_;
  double last_cells_timestamp_ = -std::numeric_limits<double>::infinity();
  int cells_backwards_run_ = 0;
  std::uint64_t readout_restarts_ = 0;
  std::uint32_t rejected_ = 0;
  Pose pose_;
  hand::Skeleton skeleton_;
  hand::JointList joints_{};
};

}  // namespace glovepose
