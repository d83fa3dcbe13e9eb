/// @file estimator_core.hpp
/// @brief The estimator's stages composed (GlovePoseEstimator, estimator.hpp, is its narrow front):
/// readout, calibration, network, smoothing, kinematics, contact, joints, prediction.
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

#include "../calibration/donning.hpp"
#include "../calibration/free_motion.hpp"
#include "../calibration/pose_offset.hpp"
#include "../calibration/user_calibration.hpp"
#include "../calibration_session.hpp"
#include "../config.hpp"
#include "../core/latest.hpp"
#include "../core/team.hpp"
#include "../estimator_config.hpp"
#include "../filter/one_euro.hpp"
#include "../filter/trend.hpp"
#include "../grid/glove_description.hpp"
#include "../grid/grid_map.hpp"
#include "../hand/contact.hpp"
#include "../hand/dofs.hpp"
#include "../hand/joint_list.hpp"
#include "../hand/kinematics.hpp"
#include "../hand/xr_hand.hpp"
#include "../model/model_info.hpp"
#include "../model/pose_network.hpp"
#include "../pose.hpp"
#include "../pose_model.hpp"
#include "../pose_prediction.hpp"
#include "../sensor/calibration.hpp"
#include "../sensor/floating_cells.hpp"
#include "../sensor/input_conditioning.hpp"
#include "../sensor/layout.hpp"
#include "../sensor/readout.hpp"
#include "../sensor/solver.hpp"
#include "../status.hpp"

namespace glovepose::detail {

/// @brief What GlovePoseEstimator (estimator.hpp) does, with the stages' own types: the front
/// forwards every call here. The documentation of each member is the front's.
class EstimatorCore {
 public:
  EstimatorCore(std::shared_ptr<const PoseModel> model, EstimatorConfig config)
      : model_(checked(std::move(model))),
        config_(with_glove_calibration(std::move(config), model_->glove())),
        calibration_session_(model_->glove().cell_names(), config_.calibration_median_window, config_.calibration,
                             config_.calibration_sample_period,
                             model_->pose_offset() && config_.calibration_method != CalibrationMethod::MinMax ? &model_->pose_offset()->sequence()
                                                                                                                 : nullptr),
        workspace_(model_->network().make_workspace(checked_threads(config_.network_threads))),
        kinematics_(hand::HandModel::chosen_or_reference(config_.hand), config_.handedness),
        trend_(config_.prediction_window),
        locator_(kinematics_.model(), config_.handedness, model_->joint_limits()),
        aim_tracker_(locator_.mapper()) {
    if (!(config_.prediction_window > 0.0) || !std::isfinite(config_.prediction_window))
      throw Error("GlovePoseEstimator: prediction_window " + std::to_string(config_.prediction_window) + " s, expected a positive time");
    if (!(config_.max_prediction >= 0.0) || !std::isfinite(config_.max_prediction))
      throw Error("GlovePoseEstimator: max_prediction " + std::to_string(config_.max_prediction) + " s, expected a time of at least 0");
    if (!(config_.confidence_tolerance >= 0.0) || !std::isfinite(config_.confidence_tolerance))
      throw Error("GlovePoseEstimator: confidence_tolerance " + std::to_string(config_.confidence_tolerance) +
                  " rad, expected a finite angle of at least 0");
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
    conditioner_ = sensor::InputConditioner(model_->glove().demean_frames());
    sensor::FloatingCellsConfig floating = config_.floating_cells;
    floating.enabled = floating.enabled && !conditioner_.active();  // de-meaned cells have no minimum to fall below
    floating_ = sensor::FloatingCells(model_->cell_count(), floating);
    skeleton_.fill(Eigen::Affine3d::Identity());
    if (model_->range_map()) continuous_.emplace(*model_->range_map());  // also for a restart at a donning
    if (config_.donning) donning_.emplace(model_->cell_count(), *config_.donning);
    if (config_.continuous_calibration && model_->range_map()) use_continuous_calibration();
    if (config_.calibration_method == CalibrationMethod::PoseGuided && !model_->pose_offset())
      throw Error(
          "GlovePoseEstimator: calibration_method PoseGuided, but the model carries no pose-guided calibration, expected a model fitted by "
          "glovepose fit-guided");
  }

  // ---- input -------------------------------------------------------------------------------

  GLOVEPOSE_REALTIME Status push_row(int row, double value, double timestamp) noexcept {
    if (!readout_) return Status::UnknownIndex;
    const auto start = std::chrono::steady_clock::now();
    const Status status = readout_->push_row(row, value, timestamp);
    if (status != Status::Solved) return status;
    return estimate_from_readout(start);
  }

  GLOVEPOSE_REALTIME Status push_measurements(const double* values, int count, double timestamp) noexcept {
    if (!readout_) return Status::UnknownIndex;
    if (values == nullptr || count != measurements_.size()) return Status::SizeMismatch;
    const auto start = std::chrono::steady_clock::now();
    measurements_ = Eigen::Map<const Eigen::VectorXd>(values, count);
    const Status status = readout_->push_frame(measurements_, timestamp);
    if (status != Status::Solved) return status;
    return estimate_from_readout(start);
  }

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
    if (restarted) conditioner_.reset();
    cells_backwards_run_ = 0;
    cells_ = Eigen::Map<const Eigen::VectorXd>(cells, count);
    last_cells_timestamp_ = timestamp;
    return estimate(cells_, timestamp, oldest_age, 0, sensor::ReadoutHealth{}, start);
  }

  // ---- output ------------------------------------------------------------------------------

  const Pose& pose() const noexcept { return pose_; }
  const hand::Skeleton& skeleton() const noexcept { return skeleton_; }
  const hand::ContactResult& contact() const noexcept { return contact_result_; }
  const hand::JointList& joints() const noexcept { return joints_; }
  const Eigen::VectorXd& cells() const noexcept { return cells_; }
  const Eigen::VectorXd& normalized_cells() const noexcept { return normalized_; }
  HandState state() const noexcept { return HandState{pose_, joints_, calibration_progress(), trend_.slope(), trend_.has_slope()}; }

  GLOVEPOSE_REALTIME Status pose_at(double t, PredictedPose& out) const noexcept {
    if (!pose_.valid || trend_.size() == 0) return Status::NotReady;
    const Status status = predict(pose_, trend_.slope(), trend_.has_slope(), locator_, t, config_.max_prediction, out);
    if (status != Status::Ok || out.predicted) return status;
    out.horizon = t - pose_.timestamp;
    return trend_.at(t, out.angles);
  }

  GLOVEPOSE_REALTIME Status joints_at(double t, hand::XrHandJoints& out) const noexcept {
    PredictedPose pose;
    const Status status = pose_at(t, pose);
    if (status != Status::Ok) {
      out.active = false;
      return status;
    }
    locate(pose, locator_, out);
    return Status::Ok;
  }

  const hand::XrHandAim& aim() const noexcept { return aim_tracker_.aim(); }

  const std::vector<int>& masked_cells() const noexcept { return floating_.floating(); }

  const hand::XrHandLocator& locator() const noexcept { return locator_; }

  // ---- calibration -------------------------------------------------------------------------

  void start_calibration() noexcept { calibration_session_.start(); }
  CalibrationProgress calibration_progress() const noexcept {
    CalibrationProgress progress = calibration_session_.progress();
    if (source_ == CalibrationSource::Continuous) progress.motion_frames = continuous_->histogram().effective_frames();
    progress.donnings = donnings_;
    return progress;
  }
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
  void cancel_calibration() noexcept { calibration_session_.stop(); }
  void set_calibration(const sensor::CalibrationRange& range) {
    if (range.size() != model_->cell_count() || range.names() != model_->glove().cell_names())
      throw Error("GlovePoseEstimator::set_calibration: a range of " + std::to_string(range.size()) +
                  " sensors with other names, expected the " + std::to_string(model_->cell_count()) + " cells of glove '" +
                  model_->glove().id() + "'");
    set_range(range, CalibrationSource::User);
  }
  void set_calibration(const sensor::CalibrationRange& range, const hand::Angles& offsets) {
    for (double o : offsets)
      if (!std::isfinite(o)) throw Error("GlovePoseEstimator::set_calibration: a non-finite angle offset, expected finite radians");
    set_calibration(range);
    offsets_ = offsets;
    guided_ = true;
  }
  void load_calibration(const std::string& path) {
    calibration::UserCalibration user =
        calibration::UserCalibration::load(path, model_->glove().id(), model_->glove().cell_names(), config_.calibration);
    set_range(std::move(user.range), CalibrationSource::User, user.offsets);
  }
  void save_calibration(const std::string& path) const {
    if (!range_) throw Error("GlovePoseEstimator::save_calibration: no calibration range set, expected one to save");
    calibration::UserCalibration{*range_, guided_ ? std::optional<hand::Angles>(offsets_) : std::nullopt}.save(path, model_->glove().id());
  }
  void use_training_calibration() {
    if (!model_->training_range())
      throw Error(
          "GlovePoseEstimator::use_training_calibration: the model records no training-set range, expected a model trained with "
          "--calibration-mode training");
    set_range(*model_->training_range(), CalibrationSource::Training);
  }
  void use_continuous_calibration() {
    if (!model_->range_map())
      throw Error("GlovePoseEstimator::use_continuous_calibration: the model carries no range map, expected a model fitted by glovepose fit-guided");
    continuous_->reset();
    set_range(sensor::CalibrationRange(continuous_->min(), continuous_->max(), model_->glove().cell_names(), config_.calibration),
              CalibrationSource::Continuous);
  }
  void clear_calibration() noexcept {
    range_.reset();
    source_ = CalibrationSource::None;
    guided_ = false;
    offsets_ = hand::Angles{};
  }
  const std::optional<sensor::CalibrationRange>& calibration() const noexcept { return range_; }
  CalibrationSource calibration_source() const noexcept { return source_; }
  CalibrationMethod calibration_method() const noexcept { return guided_ ? CalibrationMethod::PoseGuided : CalibrationMethod::MinMax; }
  const hand::Angles& calibration_offsets() const noexcept { return offsets_; }

  // ---- state -------------------------------------------------------------------------------

  void reset() noexcept {
    if (readout_) readout_->reset();
    if (smoothing_) smoothing_->reset();
    if (contact_) contact_->reset();
    trend_.reset();
    aim_tracker_.reset();
    last_cells_timestamp_ = -std::numeric_limits<double>::infinity();
    cells_backwards_run_ = 0;
    calibration_session_.restart_clock();
    conditioner_.reset();
    floating_.reset();
    if (donning_) donning_->reset();
  }
  bool glove_off() const noexcept { return donning_ && donning_->off(); }
  const PoseModel& model() const noexcept { return *model_; }
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
    floating_.set_range(*range_);
    source_ = source;
    guided_ = offsets.has_value();
    offsets_ = offsets.value_or(hand::Angles{});
    // A new calibration: the glove counts as worn, and the range is the profile a donning restarts from.
    if (donning_) donning_->reset();
    profile_min_ = recent_min_ = range_->min();
    profile_max_ = recent_max_ = range_->max();
    next_profile_ = -std::numeric_limits<double>::infinity();
  }

  // The profile a donning restarts from: the range of kProfileSeconds to twice that before now,
  // so that the frames of the glove being pulled off (before it counts as off) are not in it.
  static constexpr double kProfileSeconds = 4.0;
  GLOVEPOSE_REALTIME void keep_profile(double timestamp) noexcept {
    if (timestamp < next_profile_ && timestamp >= next_profile_ - kProfileSeconds) return;  // a clock gone back starts over
    next_profile_ = timestamp + kProfileSeconds;
    profile_min_ = recent_min_;
    profile_max_ = recent_max_;
    recent_min_ = range_->min();
    recent_max_ = range_->max();
  }

  // The glove off the hand and on again (EstimatorConfig::donning): returns whether the range changed.
  GLOVEPOSE_REALTIME bool watch_donning(double timestamp) noexcept {
    if (!donning_ || calibration_session_.collecting()) return false;
    if (source_ == CalibrationSource::Continuous && continuous_->histogram().effective_frames() < donning_->config().min_motion_frames) {
      donning_->reset();  // too young a range to tell
      return false;
    }
    const calibration::DonningEvent event = donning_->update(normalized_.data(), timestamp);
    if (event != calibration::DonningEvent::Donned) return false;
    ++donnings_;
    if (!continuous_) return false;  // no range map: the range is kept
    continuous_->reset(profile_min_, profile_max_);
    (void)range_->move_limits(continuous_->min(), continuous_->max());
    floating_.follow_range(*range_);
    source_ = CalibrationSource::Continuous;
    guided_ = false;
    offsets_ = hand::Angles{};
    return true;
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
      conditioner_.reset();
    }
    readout_restarts_ = frame.health.restarts;
    return estimate(frame.cells, frame.timestamp, frame.oldest_age, frame.rejected, frame.health, start);
  }

  static std::uint32_t fault_flags(const sensor::ReadoutHealth& health) noexcept {
    std::uint32_t flags = 0;
    if (health.filling_rows > 0) flags |= kPoseRecovering;
    if (health.stale_rows > 0) flags |= kPoseStaleReadings;
    if (health.stuck_rows > 0) flags |= kPoseStuckRows;
    if (health.disconnected_rows > health.excluded_rows) flags |= kPoseDisconnectedRows;  // in the solve: it needed them
    if (health.outlier_rows > 0) flags |= kPoseOutlierRows;
    return flags;
  }

  Status estimate(const Eigen::VectorXd& cells, double timestamp, double oldest_age, std::uint32_t rejected,
                  const sensor::ReadoutHealth& health, std::chrono::steady_clock::time_point start) noexcept {
    if (&cells != &cells_) cells_ = cells;
    rejected_ += rejected;
    if (conditioner_.active()) {  // as training conditioned them (train::conditioned_for)
      if (!cells_.allFinite()) return Status::NonFinite;  // a NaN would stay in the rolling means
      conditioner_.apply(cells_.data(), cells_.data());
      // Rounded as a dataset stores cells: the network's inputs are training's, bit for bit.
      for (Eigen::Index c = 0; c < cells_.size(); ++c) cells_(c) = static_cast<float>(cells_(c));
    }
    // Floating cells are stood in for before a calibration takes the frame: a torn trace must not
    // become the new range's minimum.
    const int masked = floating_.apply(cells_, timestamp, health.outlier_rows == 0);
    calibration_session_.add(cells_, timestamp);  // takes the frame while a calibration collects
    const bool off = glove_off();  // a glove lying off the hand teaches the calibration nothing
    if (source_ == CalibrationSource::Continuous && !off && cells_.allFinite() && continuous_->add(cells_, timestamp)) {
      (void)range_->move_limits(continuous_->min(), continuous_->max());
      floating_.follow_range(*range_);
    }
    if (!range_) return Status::Uncalibrated;
    if (!off) keep_profile(timestamp);
    if (range_->normalize(cells_, normalized_) != Status::Ok) return Status::NonFinite;
    if (watch_donning(timestamp) && range_->normalize(cells_, normalized_) != Status::Ok) return Status::NonFinite;
    std::uint32_t flags = fault_flags(health) | (rejected_ > 0 ? kPoseReadingsRejected : 0u) | (masked > 0 ? kPoseMaskedCells : 0u) |
                          (glove_off() ? kPoseGloveOff : 0u);
    if (normalized_.cwiseAbs().maxCoeff() >= config_.calibration.clamp_limit) flags |= kPoseInputClamped;
    if (source_ == CalibrationSource::Training) flags |= kPoseTrainingCalibration;
    if (calibration_session_.collecting()) flags |= kPoseCalibrating;
    const Status net = network_angles(normalized_, pose_.raw_angles);
    if (net != Status::Ok) return net;
    // Held within the joint limits as the last step, the user's pose offsets (if any) added before:
    // a network's overshoot is what the offsets correct for this user.
    pose_.raw_angles = guided_ ? calibration::with_offsets(pose_.raw_angles, offsets_, model_->joint_limits())
                               : model_->joint_limits().clamp(pose_.raw_angles);
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
    set_confidence();
    pose_.compute_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    return Status::Solved;
  }

  // Pose::confidence from the model's measured errors under the calibration in use, the angles'
  // rate and the cells stood in for; 0 when the pose is not trusted, 1 when the model measured none.
  void set_confidence() noexcept {
    const bool trusted = pose_.trusted();
    pose_.confidence.fill(trusted ? 1.0 : 0.0);
    if (!trusted || !model_->pose_error()) return;
    model::ErrorCondition condition = guided_ ? model::ErrorCondition::Guided : model::ErrorCondition::MinMax;
    double frames = 0.0;
    if (source_ == CalibrationSource::Training) condition = model::ErrorCondition::Training;
    if (source_ == CalibrationSource::Continuous) {
      condition = model::ErrorCondition::Continuous;
      frames = continuous_->histogram().effective_frames();
    }
    const hand::Angles rate = trend_.slope();
    const std::vector<int>& masked = floating_.floating();
    (void)model_->pose_error()->confidence(condition, frames, trend_.has_slope() ? &rate : nullptr, masked.data(), masked.size(),
                                           config_.confidence_tolerance, pose_.confidence);
  }

  std::shared_ptr<const PoseModel> model_;
  EstimatorConfig config_;
  std::optional<sensor::Readout> readout_;
  CalibrationSession calibration_session_;  // an on-the-fly calibration while it runs
  std::optional<sensor::CalibrationRange> range_;
  std::optional<calibration::ContinuousRange> continuous_;  // the wearer's free motion, while source_ is Continuous; any model with a range map
  std::optional<calibration::DonningDetector> donning_;     // EstimatorConfig::donning
  long donnings_ = 0;
  Eigen::VectorXd profile_min_, profile_max_;  // the range a donning restarts from (keep_profile)
  Eigen::VectorXd recent_min_, recent_max_;    // the range when the profile was last kept
  double next_profile_ = -std::numeric_limits<double>::infinity();
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
  hand::XrHandLocator locator_;
  hand::XrAimTracker aim_tracker_;  // the pinch flags' hysteresis and the latest aim state
  Eigen::VectorXd measurements_;
  Eigen::VectorXd cells_;  // the latest cells, conditioned when the glove says (conditioner_)
  sensor::InputConditioner conditioner_;
  sensor::FloatingCells floating_;  // EstimatorConfig::floating_cells
  Eigen::VectorXd normalized_;
  double last_cells_timestamp_ = -std::numeric_limits<double>::infinity();
  int cells_backwards_run_ = 0;
  std::uint64_t readout_restarts_ = 0;
  std::uint32_t rejected_ = 0;
  Pose pose_;
  hand::Skeleton skeleton_;
  hand::JointList joints_{};
};

}  // namespace glovepose::detail
