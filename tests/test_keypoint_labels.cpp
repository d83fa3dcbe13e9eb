// Hand-tracker keypoints to training labels: the layouts on the hand model, inverse kinematics
// against exact keypoints, the person's hand shape against the simulated person's, and whole takes
// (noise, another clock, missing digits) against the true angles and the true clock offset.
#include <doctest/doctest.h>

#include <glovepose/hand/keypoint_fit.hpp>
#include <glovepose/hand/keypoints.hpp>
#include <glovepose/sim/corpus.hpp>
#include <glovepose/sim/keypoint_tracker.hpp>
#include <glovepose/train/keypoint_labels.hpp>
#include <glovepose/train/metrics.hpp>

#include <cmath>
#include <string>
#include <vector>

using namespace glovepose;

namespace {


// One simulated session: the corpus job, its recording and its motion.
struct TrackedSession {
  sim::CorpusConfig config;
  sim::CorpusWorld world;
  sim::SessionRecording job;
  sim::MotionSequence motion;

  static sim::CorpusConfig config_for(std::uint64_t seed, double minutes) {
    sim::CorpusConfig c;
    c.subjects = 1;
    c.sessions = 1;
    c.intra_sessions = 1;
    c.minutes = minutes;
    c.calibration_seconds = 0.0;
    c.seed = seed;
    c.world = sim::default_world();
    c.threads = 1;
    return c;
  }
  TrackedSession(std::uint64_t seed, double minutes)
      : config(config_for(seed, minutes)),
        world(config),
        job(sim::plan_corpus(config).front()),
        motion(sim::setup_session(config, world, job).motion) {
    const sim::SessionSetup setup = sim::setup_session(config, world, job);
    job.recording = setup.record(world.subjects[0].distal_radius(), config, config.recording);
  }
  const sim::Subject& subject() const { return world.subjects[0]; }
  std::vector<double> cells() const { return {job.recording.cells.begin(), job.recording.cells.end()}; }
  // The glove's response delay: the lag at which the true angles, on the glove's clock, best match
  // the cells' motion (the readout's averaging and the fabric's response).
  double response_delay() const {
    const std::vector<double> truth(job.recording.angles.begin(), job.recording.angles.end());
    return train::align_clocks(job.recording.timestamps, cells(), 44, job.recording.timestamps, truth, 1.0, 0.3).offset;
  }
};

struct LabelError {
  double mean_deg = 0.0;
  double trusted_share = 0.0;
};

// Mean absolute error (degrees) of the labelled DoFs of the trusted frames against the truth.
LabelError error_against_truth(const train::TakeLabels& labels, const sim::Recording& rec, const hand::DofSet& labelled) {
  double sum = 0.0;
  std::size_t n = 0, trusted = 0;
  for (std::size_t f = 0; f < labels.trusted.size(); ++f) {
    if (!labels.trusted[f]) continue;
    ++trusted;
    for (std::size_t d = 0; d < hand::kDofCount; ++d)
      if (labelled[d]) {
        sum += std::abs(labels.angles[f * hand::kDofCount + d] - rec.angles[f * hand::kDofCount + d]);
        ++n;
      }
  }
  return {n > 0 ? sum / static_cast<double>(n) * core::kDegreesPerRadian : NAN, static_cast<double>(trusted) / static_cast<double>(labels.trusted.size())};
}

}  // namespace

TEST_CASE("keypoint layouts: names, counts and anchors on the hand model") {
  CHECK(hand::keypoint_count(hand::KeypointLayout::MediaPipe) == 21);
  CHECK(hand::keypoint_count(hand::KeypointLayout::OpenXr) == 26);
  CHECK(std::string(hand::to_string(hand::KeypointLayout::OpenXr)) == "openxr");
  CHECK(std::string(hand::keypoint_name(hand::KeypointLayout::MediaPipe, 8)) == "index_finger_tip");
  CHECK(std::string(hand::keypoint_name(hand::KeypointLayout::OpenXr, 10)) == "index_tip");
  const hand::Kinematics kinematics;
  hand::Skeleton skeleton;
  hand::Angles pose{};
  pose[hand::dof_of(hand::Finger::Index, hand::Motion::BaseFlexion)] = 0.8;
  pose[hand::dof_of(hand::Finger::Index, hand::Motion::MiddleFlexion)] = 0.6;
  kinematics.pose(pose, skeleton);
  // MediaPipe's index tip is the model's fingertip; its PIP the index middle phalanx's origin.
  const hand::KeypointModel mediapipe(hand::KeypointLayout::MediaPipe, kinematics);
  hand::KeypointPositions points;
  mediapipe.positions(skeleton, points);
  CHECK((points[8] - kinematics.fingertip(skeleton, hand::Finger::Index)).norm() < 1e-9);
  CHECK((points[6] - skeleton[static_cast<std::size_t>(hand::Phalanx::Index2)].translation()).norm() < 1e-9);
  CHECK(mediapipe.on_palm(0));
  CHECK(mediapipe.on_palm(5));  // a knuckle moves with no DoF
  CHECK(!mediapipe.on_palm(6));
  CHECK(mediapipe.digit_of(7) == static_cast<int>(hand::Finger::Index));
  CHECK(mediapipe.moves(hand::dof_of(hand::Finger::Index, hand::Motion::BaseFlexion), 6));
  CHECK(!mediapipe.moves(hand::dof_of(hand::Finger::Index, hand::Motion::TipFlexion), 7));  // the DIP is where the tip turns
  // OpenXR's joints are XrJointMapper's, in its wrist frame (m): the same hand up to that frame.
  const hand::XrJointMapper mapper(kinematics);
  kinematics.pose(pose, skeleton, mapper.root());
  hand::XrJointFrames frames;
  mapper.frames(skeleton, frames);
  const hand::KeypointModel openxr(hand::KeypointLayout::OpenXr, kinematics);
  openxr.positions(skeleton, points);
  for (std::size_t j = 0; j < hand::kXrJointCount; ++j) CHECK((points[j] - frames.position[j] * 1e3).norm() < 1e-9);
}

TEST_CASE("keypoint inverse kinematics recovers poses and placements from exact keypoints") {
  core::Rng rng(5);
  const hand::JointLimits limits;
  for (hand::KeypointLayout layout : {hand::KeypointLayout::MediaPipe, hand::KeypointLayout::OpenXr}) {
    const std::string layout_name = hand::to_string(layout);
    CAPTURE(layout_name);
    const hand::Kinematics kinematics;
    const hand::KeypointIk ik(hand::KeypointModel(layout, kinematics));
    double error = 0.0, worst_rms = 0.0;
    const int poses = 20;
    for (int i = 0; i < poses; ++i) {
      hand::Angles truth{};
      for (std::size_t d = 0; d < hand::kDofCount; ++d) truth[d] = rng.uniform(limits.min()[d], limits.max()[d]);
      // Flexed enough that the twists show (a straight finger's twist moves no keypoint).
      for (std::size_t f = 1; f < hand::kFingerCount; ++f)
        truth[hand::dof_of(static_cast<hand::Finger>(f), hand::Motion::MiddleFlexion)] = rng.uniform(0.5, 1.5);
      Eigen::Affine3d root = Eigen::Affine3d::Identity();
      root.linear() = Eigen::AngleAxisd(rng.uniform(-1.0, 1.0), Eigen::Vector3d(rng.normal(), rng.normal(), rng.normal()).normalized())
                          .toRotationMatrix();
      root.translation() = Eigen::Vector3d(rng.uniform(-100, 100), rng.uniform(-100, 100), rng.uniform(300, 600));
      hand::Skeleton skeleton;
      kinematics.pose(truth, skeleton, root);
      hand::KeypointPositions observed;
      ik.model().positions(skeleton, observed);
      // Start from a pose near the truth, as from the frame before.
      hand::Angles start = truth;
      for (double& a : start) a += rng.normal(0.0, 0.15);
      const hand::KeypointIkResult fit = ik.solve(observed, start, nullptr);
      worst_rms = std::max(worst_rms, fit.rms_mm);
      for (std::size_t d = 0; d < hand::kDofCount; ++d) error += std::abs(fit.angles[d] - truth[d]);
      CHECK((fit.root.translation() - root.translation()).norm() < 1.0);
    }
    MESSAGE(layout_name << ": worst residual " << worst_rms << " mm, mean angle error "
                                    << error / (poses * hand::kDofCount) * core::kDegreesPerRadian << " deg");
    CHECK(worst_rms < 0.5);
    CHECK(error / (poses * hand::kDofCount) * core::kDegreesPerRadian < 1.0);
  }
}

TEST_CASE("the hand shape fitted to noisy keypoints is the simulated person's") {
  const TrackedSession session(11, 0.5);
  const hand::HandModel truth = session.subject().hand_model();
  const hand::Kinematics person(truth);
  for (hand::KeypointLayout layout : {hand::KeypointLayout::MediaPipe, hand::KeypointLayout::OpenXr}) {
    const std::string layout_name = hand::to_string(layout);
    CAPTURE(layout_name);
    sim::KeypointTrackerConfig tracker;
    tracker.layout = layout;
    tracker.noise_mm = 5.0;
    const train::KeypointTrack track = sim::track_keypoints(person, session.motion, 0.0, 30.0, tracker, 3);
    const hand::HandShapeFit fit = hand::fit_hand_shape(layout, track.points, hand::Kinematics());
    MESSAGE(layout_name << ": noise seen " << fit.noise_mm * std::sqrt(3.0) << " mm (3D RMS), hand length "
                                    << fit.hand_length_mm << " mm");
    CHECK(fit.noise_mm * std::sqrt(3.0) == doctest::Approx(5.0).epsilon(0.2));
    double worst_bone = 0.0, worst_base = 0.0;
    for (std::size_t f = 0; f < hand::kFingerCount; ++f) {
      const auto base = static_cast<std::size_t>(hand::kFingerBase[f]);
      worst_base = std::max(worst_base, (fit.model.rest[base].translation() - truth.rest[base].translation()).norm());
      for (std::size_t k = 1; k < 3; ++k)
        worst_bone = std::max(worst_bone, std::abs(fit.model.rest[base + k].translation().norm() - truth.rest[base + k].translation().norm()));
      worst_bone = std::max(worst_bone, std::abs(fit.model.tip_length[f] - truth.tip_length[f]));
    }
    MESSAGE("worst bone length error " << worst_bone << " mm, worst base position error " << worst_base << " mm");
    CHECK(worst_bone < 1.5);
    CHECK(worst_base < 3.0);
  }
  // Keypoints in metres read as millimetres: the bones are far too short, and the message says so.
  sim::KeypointTrackerConfig tracker;
  train::KeypointTrack metres = sim::track_keypoints(person, session.motion, 0.0, 10.0, tracker, 4);
  for (Eigen::Vector3d& p : metres.points) p *= 1e-3;
  CHECK_THROWS_WITH_AS(hand::fit_hand_shape(hand::KeypointLayout::MediaPipe, metres.points, hand::Kinematics()),
                       doctest::Contains("expected 3-150 mm"), Error);
}

TEST_CASE("a take's keypoints become labels within 3 degrees of the truth and its clock within a frame") {
  const TrackedSession session(33, 2.0);
  const sim::Recording& rec = session.job.recording;
  const hand::Kinematics person(session.subject().hand_model());
  const std::vector<double> glove_times = rec.timestamps;
  const double frame = glove_times[1] - glove_times[0];
  const double delay = session.response_delay();
  MESSAGE("the glove's response delay: " << delay * 1e3 << " ms");
  CHECK(delay > 0.0);
  CHECK(delay < 0.15);
  core::Rng rng(9);
  for (hand::KeypointLayout layout : {hand::KeypointLayout::MediaPipe, hand::KeypointLayout::OpenXr}) {
    const std::string layout_name = hand::to_string(layout);
    CAPTURE(layout_name);
    sim::KeypointTrackerConfig tracker;
    tracker.layout = layout;
    tracker.noise_mm = 5.0;
    tracker.rate_hz = layout == hand::KeypointLayout::MediaPipe ? 30.0 : 72.0;
    tracker.offset_seconds = rng.uniform(-2.0, 2.0);
    const train::KeypointTrack track =
        sim::track_keypoints(person, session.motion, glove_times.front(), glove_times.back(), tracker, 7);
    const hand::HandShapeFit shape = hand::fit_hand_shape(layout, track.points, hand::Kinematics());
    const hand::KeypointIk ik(hand::KeypointModel(layout, hand::Kinematics(shape.model)));
    train::KeypointLabelConfig config;
    config.glove_delay_seconds = delay;
    const train::TakeLabels labels =
        train::label_take(ik, track, hand::all_dofs(), glove_times, session.cells(), rec.cells.size() / rec.timestamps.size(), config);
    const LabelError error = error_against_truth(labels, rec, hand::all_dofs());
    MESSAGE(layout_name << ": mean " << error.mean_deg << " deg against the truth, " << error.trusted_share * 100
                                    << "% of frames labelled, offset " << labels.clock.offset << " s (true " << tracker.offset_seconds
                                    << ", correlation " << labels.clock.correlation << ", runner-up " << labels.clock.runner_up << ")");
    CHECK(error.mean_deg <= 3.0);
    CHECK(error.trusted_share > 0.9);
    CHECK(std::abs(labels.clock.offset - tracker.offset_seconds) <= frame);
  }
}

TEST_CASE("keypoint labels: missing digits are not labelled, unseen frames not trusted, foreign takes refused") {
  const TrackedSession session(34, 1.0);
  const sim::Recording& rec = session.job.recording;
  const hand::Kinematics person(session.subject().hand_model());
  sim::KeypointTrackerConfig tracker;
  tracker.offset_seconds = 0.4;
  train::KeypointTrack track = sim::track_keypoints(person, session.motion, rec.timestamps.front(), rec.timestamps.back(), tracker, 8);
  const std::size_t count = hand::kMediaPipeKeypointCount;
  const std::size_t frames = track.times.size();
  // A tracker that never reports the pinky (keypoints 17-20), and loses every keypoint for a second.
  std::array<bool, hand::kMaxKeypoints> present{};
  for (std::size_t k = 0; k < count; ++k) present[k] = k < 17;
  for (std::size_t f = 0; f < frames; ++f)
    for (std::size_t k = 0; k < count; ++k)
      if (!present[k] || (track.times[f] > 20.0 && track.times[f] < 21.0)) track.points[f * count + k] = Eigen::Vector3d::Constant(NAN);
  const hand::HandShapeFit shape = hand::fit_hand_shape(hand::KeypointLayout::MediaPipe, track.points, hand::Kinematics());
  const hand::KeypointIk ik(hand::KeypointModel(hand::KeypointLayout::MediaPipe, hand::Kinematics(shape.model)));
  const hand::DofSet labelled = train::labelled_by(ik.model(), present);
  for (std::size_t d = 0; d < hand::kDofCount; ++d) CHECK(labelled[d] == (hand::kDofs[d].finger != hand::Finger::Pinky));
  const train::TakeLabels labels = train::label_take(ik, track, labelled, rec.timestamps, session.cells(), 44, {});
  std::size_t lost = 0;
  for (std::size_t f = 0; f < labels.trusted.size(); ++f) {
    const double tracker_time = rec.timestamps[f] - labels.clock.offset;
    if (tracker_time > 20.05 && tracker_time < 20.95) {
      CHECK(labels.trusted[f] == 0);
      lost += 1;
    }
    if (labels.trusted[f]) {
      CHECK(labels.frame_rms_mm[f] <= labels.rms_threshold_mm);
      CHECK(std::isnan(labels.angles[f * hand::kDofCount + hand::dof_of(hand::Finger::Pinky, hand::Motion::BaseFlexion)]));
      CHECK(std::isfinite(labels.angles[f * hand::kDofCount + hand::dof_of(hand::Finger::Index, hand::Motion::BaseFlexion)]));
    }
  }
  CHECK(lost > 40);
  const LabelError error = error_against_truth(labels, rec, labelled);
  CHECK(error.mean_deg < 3.5);

  // Keypoints of another session: no offset makes the motions agree.
  const TrackedSession other(35, 1.0);
  const train::KeypointTrack foreign = sim::track_keypoints(hand::Kinematics(other.subject().hand_model()), other.motion, 0.0, 60.0, tracker, 9);
  const hand::HandShapeFit foreign_shape = hand::fit_hand_shape(hand::KeypointLayout::MediaPipe, foreign.points, hand::Kinematics());
  const hand::KeypointIk foreign_ik(hand::KeypointModel(hand::KeypointLayout::MediaPipe, hand::Kinematics(foreign_shape.model)));
  CHECK_THROWS_WITH_AS(train::label_take(foreign_ik, foreign, hand::all_dofs(), rec.timestamps, session.cells(), 44, {}),
                       doctest::Contains("clock alignment"), Error);
}
