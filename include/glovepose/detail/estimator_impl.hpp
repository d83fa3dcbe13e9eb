/// @file estimator_impl.hpp
/// @brief GlovePoseEstimator's members (estimator.hpp), each a call of detail::EstimatorCore: inline
/// in header-only use, compiled once into glovepose::compiled otherwise (src/estimator.cpp).
#pragma once

#include <memory>
#include <optional>
#include <string>
#include <utility>

#include "../estimator.hpp"
#include "estimator_core.hpp"

namespace glovepose {

GLOVEPOSE_INLINE GlovePoseEstimator::GlovePoseEstimator(std::shared_ptr<const PoseModel> model, EstimatorConfig config)
    : core_(std::make_unique<detail::EstimatorCore>(std::move(model), std::move(config))) {}
GLOVEPOSE_INLINE GlovePoseEstimator::GlovePoseEstimator(GlovePoseEstimator&&) noexcept = default;
GLOVEPOSE_INLINE GlovePoseEstimator& GlovePoseEstimator::operator=(GlovePoseEstimator&&) noexcept = default;
GLOVEPOSE_INLINE GlovePoseEstimator::~GlovePoseEstimator() = default;

GLOVEPOSE_INLINE Status GlovePoseEstimator::push_row(int row, double value, double timestamp) noexcept {
  return core_->push_row(row, value, timestamp);
}
GLOVEPOSE_INLINE Status GlovePoseEstimator::push_measurements(const double* values, int count, double timestamp) noexcept {
  return core_->push_measurements(values, count, timestamp);
}
GLOVEPOSE_INLINE Status GlovePoseEstimator::push_cells(const double* cells, int count, double timestamp, double oldest_age) noexcept {
  return core_->push_cells(cells, count, timestamp, oldest_age);
}

GLOVEPOSE_INLINE const Pose& GlovePoseEstimator::pose() const noexcept { return core_->pose(); }
GLOVEPOSE_INLINE const hand::JointList& GlovePoseEstimator::joints() const noexcept { return core_->joints(); }
GLOVEPOSE_INLINE core::Span<const double> GlovePoseEstimator::cells() const noexcept {
  return {core_->cells().data(), static_cast<std::size_t>(core_->cells().size())};
}
GLOVEPOSE_INLINE core::Span<const double> GlovePoseEstimator::normalized_cells() const noexcept {
  return {core_->normalized_cells().data(), static_cast<std::size_t>(core_->normalized_cells().size())};
}
GLOVEPOSE_INLINE HandState GlovePoseEstimator::state() const noexcept { return core_->state(); }
GLOVEPOSE_INLINE const hand::ContactResult& GlovePoseEstimator::contact() const noexcept { return core_->contact(); }
GLOVEPOSE_INLINE Status GlovePoseEstimator::pose_at(double t, PredictedPose& out) const noexcept { return core_->pose_at(t, out); }
GLOVEPOSE_INLINE Status GlovePoseEstimator::joints_at(double t, hand::XrHandJoints& out) const noexcept { return core_->joints_at(t, out); }
GLOVEPOSE_INLINE const hand::XrHandAim& GlovePoseEstimator::aim() const noexcept { return core_->aim(); }
GLOVEPOSE_INLINE const std::vector<int>& GlovePoseEstimator::masked_cells() const noexcept { return core_->masked_cells(); }
GLOVEPOSE_INLINE bool GlovePoseEstimator::glove_off() const noexcept { return core_->glove_off(); }
GLOVEPOSE_INLINE const hand::XrHandLocator& GlovePoseEstimator::locator() const noexcept { return core_->locator(); }

GLOVEPOSE_INLINE void GlovePoseEstimator::start_calibration() noexcept { core_->start_calibration(); }
GLOVEPOSE_INLINE CalibrationProgress GlovePoseEstimator::calibration_progress() const noexcept { return core_->calibration_progress(); }
GLOVEPOSE_INLINE const sensor::CalibrationRange& GlovePoseEstimator::finish_calibration() { return core_->finish_calibration(); }
GLOVEPOSE_INLINE void GlovePoseEstimator::cancel_calibration() noexcept { core_->cancel_calibration(); }
GLOVEPOSE_INLINE void GlovePoseEstimator::set_calibration(const sensor::CalibrationRange& range) { core_->set_calibration(range); }
GLOVEPOSE_INLINE void GlovePoseEstimator::set_calibration(const sensor::CalibrationRange& range, const hand::Angles& offsets) {
  core_->set_calibration(range, offsets);
}
GLOVEPOSE_INLINE void GlovePoseEstimator::load_calibration(const std::string& path) { core_->load_calibration(path); }
GLOVEPOSE_INLINE void GlovePoseEstimator::save_calibration(const std::string& path) const { core_->save_calibration(path); }
GLOVEPOSE_INLINE void GlovePoseEstimator::use_training_calibration() { core_->use_training_calibration(); }
GLOVEPOSE_INLINE void GlovePoseEstimator::use_continuous_calibration() { core_->use_continuous_calibration(); }
GLOVEPOSE_INLINE void GlovePoseEstimator::clear_calibration() noexcept { core_->clear_calibration(); }
GLOVEPOSE_INLINE const std::optional<sensor::CalibrationRange>& GlovePoseEstimator::calibration() const noexcept {
  return core_->calibration();
}
GLOVEPOSE_INLINE CalibrationSource GlovePoseEstimator::calibration_source() const noexcept { return core_->calibration_source(); }
GLOVEPOSE_INLINE CalibrationMethod GlovePoseEstimator::calibration_method() const noexcept { return core_->calibration_method(); }
GLOVEPOSE_INLINE const hand::Angles& GlovePoseEstimator::calibration_offsets() const noexcept { return core_->calibration_offsets(); }

GLOVEPOSE_INLINE void GlovePoseEstimator::reset() noexcept { core_->reset(); }
GLOVEPOSE_INLINE const PoseModel& GlovePoseEstimator::model() const noexcept { return core_->model(); }
GLOVEPOSE_INLINE const EstimatorConfig& GlovePoseEstimator::config() const noexcept { return core_->config(); }

}  // namespace glovepose
