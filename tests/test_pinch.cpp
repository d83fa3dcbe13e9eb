// The pinch rule (hand/pinch.hpp) and the pinch and aim state an engine reads (hand/xr_hand.hpp,
// XR_FB_hand_tracking_aim): strengths and flags of the gallery's poses against distances computed
// here from the kinematics; the hysteresis on distance ramps (one onset, one release, no chatter);
// the aim pose; the estimator's aim state; no allocation per frame; the C ABI's
// glovepose_xr_aim_state and hand::XrAimFlag against <openxr/openxr.h>.
#include <glovepose/hand/pinch.hpp>
#include <glovepose/hand/xr_hand.hpp>

#include <doctest/doctest.h>

#include <openxr/openxr.h>

#include <cmath>
#include <cstddef>
#include <string>
#include <vector>

#include <glovepose/estimator.hpp>
#include <glovepose/sim/corpus_dataset.hpp>
#include <glovepose/sim/pose_gallery.hpp>
#include <glovepose/train/fingertip_metrics.hpp>

#include "../capi/glovepose_c.h"
#include "alloc_counter.hpp"
#include "tip_distance.hpp"

using namespace glovepose;
using glovepose::test::tip_distance;

namespace {


// The strength the file comment of pinch.hpp defines: 1 up to 15 mm, 0 from 40 mm, the smoothstep between.
double expected_strength(double d) {
  if (d <= 15.0) return 1.0;
  if (d >= 40.0) return 0.0;
  const double u = (40.0 - d) / 25.0;
  return u * u * (3.0 - 2.0 * u);
}

// Onsets and releases of one pair fed a sequence of distances (mm).
struct Edges {
  int onsets = 0, releases = 0;
};
Edges edges(const std::vector<double>& distances) {
  hand::PinchTracker tracker;
  Edges e;
  bool was = false;
  for (double d : distances) {
    const hand::PinchState s = tracker.update({d, 100.0, 100.0, 100.0});
    e.onsets += s.pinching[0] && !was;
    e.releases += !s.pinching[0] && was;
    was = s.pinching[0];
    CHECK_FALSE(s.pinching[1]);
  }
  return e;
}
// A ramp from a to b (mm) in steps of 0.01 mm, without b.
void ramp(std::vector<double>& out, double a, double b) {
  const int n = static_cast<int>(std::lround(std::abs(b - a) / 0.01));
  for (int i = 0; i < n; ++i) out.push_back(a + (b - a) * i / n);
}

}  // namespace

TEST_CASE("pinch: one rule for evaluation and the live state") {
  static_assert(train::kPinchThresholdMm == hand::kPinchThresholdMm && hand::kPinchThresholdMm == 15.0);
  static_assert(train::kPinchReleaseMm == hand::kPinchReleaseMm && hand::kPinchReleaseMm == 18.0);
  static_assert(train::kPinchPairCount == hand::kPinchPairCount && hand::kPinchPairCount == 4);
  const hand::PinchRule rule = train::FingertipConfig{}.pinch_rule();
  CHECK(rule.threshold_mm == 15.0);
  CHECK(rule.release_mm == 18.0);
  CHECK(rule.far_mm == hand::kPinchFarMm);
  CHECK_THROWS_WITH_AS(hand::PinchTracker(hand::PinchRule{15.0, 14.0, 40.0}), doctest::Contains("release_mm is 14"), Error);
  CHECK_THROWS_WITH_AS(hand::PinchTracker(hand::PinchRule{15.0, 18.0, 15.0}), doctest::Contains("far_mm is 15"), Error);
  CHECK_THROWS_WITH_AS(hand::PinchTracker(hand::PinchRule{0.0, 18.0, 40.0}), doctest::Contains("threshold_mm is 0"), Error);
}

TEST_CASE("pinch: the strength is 1 at contact, 0 far, smooth and monotone between") {
  CHECK(hand::pinch_strength(0.0) == 1.0);
  CHECK(hand::pinch_strength(15.0) == 1.0);
  CHECK(hand::pinch_strength(40.0) == 0.0);
  CHECK(hand::pinch_strength(120.0) == 0.0);
  CHECK(hand::pinch_strength(NAN) == 0.0);
  CHECK(hand::pinch_strength(INFINITY) == 0.0);
  CHECK(hand::pinch_strength(27.5) == doctest::Approx(0.5));
  double previous = 1.0;
  for (double d = 15.0; d <= 40.0; d += 0.05) {
    const double s = hand::pinch_strength(d);
    CHECK(s <= previous);
    CHECK(s == doctest::Approx(expected_strength(d)).epsilon(1e-12));
    previous = s;
  }
  // No kink at the ends: the slope goes to 0 at 15 and at 40 mm.
  CHECK((1.0 - hand::pinch_strength(15.01)) / 0.01 < 1e-3);
  CHECK(hand::pinch_strength(39.99) / 0.01 < 1e-3);
}

TEST_CASE("pinch: the gallery's poses, strengths and flags against distances from the kinematics") {
  const hand::Kinematics fk;
  const std::vector<sim::KeyPose> gallery = sim::pose_gallery();
  for (const sim::KeyPose& p : gallery) {
    CAPTURE(p.name);
    hand::PinchTracker tracker;
    const hand::PinchState s = tracker.update(fk, p.angles);
    for (std::size_t k = 0; k < hand::kPinchPairCount; ++k) {
      CAPTURE(k);
      const double d = tip_distance(fk, p.angles, static_cast<hand::Finger>(k + 1));
      CHECK(s.distance_mm[k] == doctest::Approx(d).epsilon(1e-12));
      CHECK(s.strength[k] == doctest::Approx(expected_strength(d)).epsilon(1e-6));
      CHECK(s.pinching[k] == (d < 15.0));
    }
  }
  const auto flags = [&](const char* name) {
    hand::PinchTracker tracker;
    return tracker.update(fk, sim::gallery_pose(name).angles).pinching;
  };
  CHECK(flags("pinch_index") == hand::PinchFlags{true, false, false, false});
  CHECK(flags("ok") == hand::PinchFlags{true, false, false, false});
  CHECK(flags("key_grip") == hand::PinchFlags{true, false, false, false});
  CHECK(flags("pinch_ring") == hand::PinchFlags{false, false, true, false});
  CHECK(flags("pinch_pinky") == hand::PinchFlags{false, false, false, true});
  CHECK(flags("pinch_middle")[1]);  // its thumb also lies against the index (10.3 mm): both pinch
  for (const char* open : {"flat", "spread", "wave", "four_fingers", "point", "fist", "flat_bent", "thumbs_up", "tap_index"}) {
    CAPTURE(open);
    CHECK(flags(open) == hand::PinchFlags{});
  }
  // Open hands read no strength at all.
  for (const char* open : {"flat", "spread", "wave", "four_fingers"}) {
    hand::PinchTracker tracker;
    const hand::PinchState s = tracker.update(fk, sim::gallery_pose(open).angles);
    for (float v : s.strength) CHECK(v == 0.0f);
  }
}

TEST_CASE("pinch: hysteresis, a ramp 20 -> 14 -> 16 -> 14 -> 19 mm gives one onset and one release") {
  std::vector<double> d;
  ramp(d, 20.0, 14.0);
  ramp(d, 14.0, 16.0);
  ramp(d, 16.0, 14.0);
  ramp(d, 14.0, 19.0);
  d.push_back(19.0);
  const Edges e = edges(d);
  CHECK(e.onsets == 1);
  CHECK(e.releases == 1);
  // Where they happen: on below 15 mm, off from 18 mm.
  hand::PinchTracker tracker;
  CHECK_FALSE(tracker.update({15.0, 50, 50, 50}).pinching[0]);
  CHECK(tracker.update({14.99, 50, 50, 50}).pinching[0]);
  CHECK(tracker.update({17.99, 50, 50, 50}).pinching[0]);
  CHECK_FALSE(tracker.update({18.0, 50, 50, 50}).pinching[0]);  // on while closer than 18 mm
  CHECK_FALSE(tracker.update({17.0, 50, 50, 50}).pinching[0]);  // off again: needs < 15 to start
}

TEST_CASE("pinch: a distance hovering at the threshold with noise makes one onset, no chatter") {
  // 15 mm +- 1.4 mm of a slow sine and a fast wobble: crosses 15 mm hundreds of times, never 18.
  std::vector<double> d;
  ramp(d, 30.0, 15.0);
  for (int i = 0; i < 2000; ++i) d.push_back(15.0 + 1.0 * std::sin(i * 0.01) + 0.4 * std::sin(i * 1.7));
  const Edges hover = edges(d);
  CHECK(hover.onsets == 1);
  CHECK(hover.releases == 0);
  // Without hysteresis (release = threshold) the same distances chatter.
  hand::PinchTracker plain(hand::PinchRule{15.0, 15.0, 40.0});
  int onsets = 0;
  bool was = false;
  for (double v : d) {
    const bool on = plain.update({v, 100, 100, 100}).pinching[0];
    onsets += on && !was;
    was = on;
  }
  CHECK(onsets > 10);
}

TEST_CASE("pinch: a non-finite distance reads no pinch and the pair starts over") {
  hand::PinchTracker tracker;
  CHECK(tracker.update({10.0, 10.0, 50, 50}).pinching == hand::PinchFlags{true, true, false, false});
  const hand::PinchState s = tracker.update({NAN, 16.0, 50, 50});
  CHECK(s.pinching == hand::PinchFlags{false, true, false, false});
  CHECK(s.strength[0] == 0.0f);
  CHECK_FALSE(tracker.update({16.0, 16.0, 50, 50}).pinching[0]);  // 16 mm does not start a pinch
}

TEST_CASE("aim: the aim pose is the straight index's proximal joint, fixed in the wrist frame") {
  for (hand::Handedness side : {hand::Handedness::Right, hand::Handedness::Left}) {
    CAPTURE(static_cast<int>(side));
    const hand::XrHandLocator locator(hand::HandModel::reference(), side);
    hand::XrHandJoints rest;
    locator.locate(hand::Angles{}, nullptr, 0, rest);
    const hand::XrPose expected = rest.locations.at(static_cast<std::size_t>(hand::XrJoint::IndexProximal)).pose;
    hand::XrAimTracker tracker(locator.mapper());
    const hand::XrHandAim& before = tracker.aim();
    CHECK_FALSE(before.active);
    CHECK(before.status == 0);
    const hand::XrHandAim& aim = tracker.update(sim::gallery_pose("pinch_index").angles, true, 2.5, 7);
    CHECK(aim.active);
    CHECK(aim.side == side);
    CHECK(aim.sequence == 7);
    CHECK(aim.timestamp == 2.5);
    CHECK(aim.status == (hand::kXrAimValid | hand::kXrAimIndexPinching));
    CHECK(aim.pinch_strength[0] == 1.0f);
    CHECK(aim.aim_pose.position.x == expected.position.x);
    CHECK(aim.aim_pose.position.y == expected.position.y);
    CHECK(aim.aim_pose.position.z == expected.position.z);
    CHECK(aim.aim_pose.orientation.w == expected.orientation.w);
    CHECK(aim.aim_pose.orientation.x == expected.orientation.x);
    // -Z of the aim points from the knuckle along the straight index to its tip; +Y is the back of the hand.
    const hand::XrQuaternion& q = aim.aim_pose.orientation;
    const Eigen::Quaterniond rotation(q.w, q.x, q.y, q.z);
    const auto& tip = rest.locations[static_cast<std::size_t>(hand::XrJoint::IndexTip)].pose.position;
    const Eigen::Vector3d along = Eigen::Vector3d(tip.x - expected.position.x, tip.y - expected.position.y, tip.z - expected.position.z);
    CHECK((rotation * Eigen::Vector3d(0, 0, -1)).dot(along.normalized()) > 0.999);
    CHECK((rotation * Eigen::Vector3d(0, 1, 0)).y() > 0.9);  // the wrist frame's +Y is the back of the hand
    // The pose moves nothing of it; an untrusted pose is not valid; the flags keep their hysteresis.
    const hand::XrHandAim& flat = tracker.update(sim::gallery_pose("flat").angles, false, 2.6, 8);
    CHECK(flat.status == 0);
    CHECK(flat.aim_pose.position.x == expected.position.x);
    CHECK(flat.aim_pose.orientation.y == expected.orientation.y);
  }
}

TEST_CASE("aim: per-frame updates allocate nothing") {
  const hand::XrHandLocator locator(hand::HandModel::reference(), hand::Handedness::Right);
  hand::XrAimTracker tracker(locator.mapper());
  hand::PinchTracker pinch;
  const hand::Angles& a = sim::gallery_pose("pinch_index").angles;
  const hand::Angles& b = sim::gallery_pose("flat").angles;
  hand::LatestAim latest;
  hand::XrHandAim read;
  std::uint64_t status = 0;
  const std::size_t allocations = test::allocations_during([&] {
    for (int i = 0; i < 100; ++i) {
      status |= tracker.update(i % 2 ? a : b, true, 0.01 * i, static_cast<std::uint64_t>(i + 1)).status;
      status |= pinch.update(hand::pinch_distances(locator.mapper().kinematics(), i % 3 ? a : b)).pinching[0];
      latest.publish(tracker.aim());
      (void)latest.read(read);
    }
  });
  CHECK(allocations == 0);
  CHECK((status & hand::kXrAimIndexPinching) != 0);
  CHECK(read.sequence == 100);
}

TEST_CASE("aim: the estimator keeps the pinch state of its poses") {
  const sim::CorpusConfig config = sim::CorpusConfig::one_session(31, 6.0, 3.0);
  const io::Dataset data = sim::to_dataset(sim::simulate_corpus(config), config);
  GlovePoseEstimator estimator(PoseModel::load(std::string(GLOVEPOSE_SOURCE_DIR) + "/models/glovepose_fcn512.safetensors"));
  CHECK_FALSE(estimator.aim().active);
  estimator.start_calibration();
  const hand::Kinematics fk;
  const hand::XrHandLocator& locator = estimator.locator();
  hand::PinchTracker reference;  // the same rule followed here, pose by pose
  std::size_t poses = 0, pinching = 0;
  std::vector<double> cells(data.cell_count);
  const std::size_t recording = data.first_session_frame();
  for (std::size_t f = 0; f < data.frames(); ++f) {
    if (f == recording) estimator.finish_calibration();
    for (std::size_t c = 0; c < cells.size(); ++c) cells[c] = data.cells[f * data.cell_count + c];
    if (estimator.push_cells(cells.data(), static_cast<int>(cells.size()), data.timestamps[f]) != Status::Solved) continue;
    ++poses;
    const hand::XrHandAim& aim = estimator.aim();
    const Pose& pose = estimator.pose();
    const hand::PinchState expected = reference.update(fk, pose.angles);
    REQUIRE(aim.active);
    CHECK(aim.sequence == pose.sequence);
    CHECK(aim.timestamp == pose.timestamp);
    CHECK(((aim.status & hand::kXrAimValid) != 0) == pose.trusted());
    pinching += (aim.status & 0x3Cu) != 0;
    for (std::size_t k = 0; k < hand::kPinchPairCount; ++k) {
      CHECK(((aim.status & xr_aim_pinching_bit(k)) != 0) == expected.pinching[k]);
      CHECK(aim.pinch_strength[k] == doctest::Approx(expected.strength[k]).epsilon(1e-6));
    }
    CHECK(aim.aim_pose.position.x == hand::XrAimTracker(locator.mapper()).aim_pose().position.x);
  }
  MESSAGE(poses << " poses, " << pinching << " of them pinching");
  CHECK(poses > 100);
}

TEST_CASE("aim: hand::XrAimFlag and the C ABI's glovepose_xr_aim_state are laid out as openxr.h's") {
  static_assert(hand::kXrAimComputed == XR_HAND_TRACKING_AIM_COMPUTED_BIT_FB);
  static_assert(hand::kXrAimValid == XR_HAND_TRACKING_AIM_VALID_BIT_FB);
  static_assert(hand::kXrAimIndexPinching == XR_HAND_TRACKING_AIM_INDEX_PINCHING_BIT_FB);
  static_assert(hand::kXrAimMiddlePinching == XR_HAND_TRACKING_AIM_MIDDLE_PINCHING_BIT_FB);
  static_assert(hand::kXrAimRingPinching == XR_HAND_TRACKING_AIM_RING_PINCHING_BIT_FB);
  static_assert(hand::kXrAimLittlePinching == XR_HAND_TRACKING_AIM_LITTLE_PINCHING_BIT_FB);
  static_assert(hand::kXrAimSystemGesture == XR_HAND_TRACKING_AIM_SYSTEM_GESTURE_BIT_FB);
  static_assert(hand::kXrAimDominantHand == XR_HAND_TRACKING_AIM_DOMINANT_HAND_BIT_FB);
  static_assert(hand::kXrAimMenuPressed == XR_HAND_TRACKING_AIM_MENU_PRESSED_BIT_FB);
  static_assert(xr_aim_pinching_bit(3) == XR_HAND_TRACKING_AIM_LITTLE_PINCHING_BIT_FB);
  static_assert(GLOVEPOSE_XR_AIM_COMPUTED == XR_HAND_TRACKING_AIM_COMPUTED_BIT_FB);
  static_assert(GLOVEPOSE_XR_AIM_VALID == XR_HAND_TRACKING_AIM_VALID_BIT_FB);
  static_assert(GLOVEPOSE_XR_AIM_INDEX_PINCHING == XR_HAND_TRACKING_AIM_INDEX_PINCHING_BIT_FB);
  static_assert(GLOVEPOSE_XR_AIM_MIDDLE_PINCHING == XR_HAND_TRACKING_AIM_MIDDLE_PINCHING_BIT_FB);
  static_assert(GLOVEPOSE_XR_AIM_RING_PINCHING == XR_HAND_TRACKING_AIM_RING_PINCHING_BIT_FB);
  static_assert(GLOVEPOSE_XR_AIM_LITTLE_PINCHING == XR_HAND_TRACKING_AIM_LITTLE_PINCHING_BIT_FB);
  static_assert(GLOVEPOSE_XR_AIM_SYSTEM_GESTURE == XR_HAND_TRACKING_AIM_SYSTEM_GESTURE_BIT_FB);
  static_assert(GLOVEPOSE_XR_AIM_DOMINANT_HAND == XR_HAND_TRACKING_AIM_DOMINANT_HAND_BIT_FB);
  static_assert(GLOVEPOSE_XR_AIM_MENU_PRESSED == XR_HAND_TRACKING_AIM_MENU_PRESSED_BIT_FB);
  static_assert(GLOVEPOSE_XR_TYPE_HAND_TRACKING_AIM_STATE_FB == XR_TYPE_HAND_TRACKING_AIM_STATE_FB);
  using C = glovepose_xr_aim_state;
  using X = XrHandTrackingAimStateFB;
  static_assert(sizeof(C) == sizeof(X) && alignof(C) == alignof(X));
  static_assert(sizeof(C::type) == sizeof(X::type) && offsetof(C, type) == offsetof(X, type));
  static_assert(sizeof(C::next) == sizeof(X::next) && offsetof(C, next) == offsetof(X, next));
  static_assert(sizeof(C::status) == sizeof(X::status) && offsetof(C, status) == offsetof(X, status));
  static_assert(offsetof(C, aim_orientation) == offsetof(X, aimPose) + offsetof(XrPosef, orientation));
  static_assert(sizeof(C::aim_orientation) == sizeof(XrQuaternionf));
  static_assert(offsetof(C, aim_position) == offsetof(X, aimPose) + offsetof(XrPosef, position));
  static_assert(sizeof(C::aim_position) == sizeof(XrVector3f));
  static_assert(offsetof(C, pinch_strength_index) == offsetof(X, pinchStrengthIndex));
  static_assert(offsetof(C, pinch_strength_middle) == offsetof(X, pinchStrengthMiddle));
  static_assert(offsetof(C, pinch_strength_ring) == offsetof(X, pinchStrengthRing));
  static_assert(offsetof(C, pinch_strength_little) == offsetof(X, pinchStrengthLittle));
  // The C++ aim pose and strengths copy as they are.
  static_assert(sizeof(hand::XrPose) == sizeof(XrPosef));
  static_assert(sizeof(hand::XrHandAim::pinch_strength) == 4 * sizeof(float));
  CHECK(sizeof(C) == sizeof(X));
}
