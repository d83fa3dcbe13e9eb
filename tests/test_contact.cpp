// The contact stage (hand/contact.hpp): a known gap between thumb and index tips closed to the
// contact distance (the two distal radii of collision.hpp, summed here), only the two chains' angles
// moved and within the joint limits, the other pairs kept apart, an adjustment past the collision
// limit refused, the detection's hysteresis, poses without contact (the gallery's non-pinches, a
// pose between threshold and release) left bit for bit, no allocation per frame; in the estimator
// (EstimatorConfig::contact), the poses of a simulated stream equal the stage-off estimator's
// except where the stage closed a pair.
#include <glovepose/hand/contact.hpp>

#include <doctest/doctest.h>

#include <cmath>
#include <cstddef>
#include <string>
#include <vector>

#include <glovepose/estimator.hpp>
#include <glovepose/sim/corpus_dataset.hpp>
#include <glovepose/sim/pose_gallery.hpp>

#include "alloc_counter.hpp"
#include "tip_distance.hpp"

using namespace glovepose;
using glovepose::test::tip_distance;

namespace {

// pinch_index with the index's base flexion opened by `open` rad: the tips part as it grows.
hand::Angles contact_opened_pinch(double open) {
  hand::Angles q = sim::gallery_pose("pinch_index").angles;
  q[hand::dof_of(hand::Finger::Index, hand::Motion::BaseFlexion)] -= open;
  return q;
}

// The opening of pinch_index whose tips are `target` mm apart (bisection on the distance, which grows with the opening).
hand::Angles contact_pinch_at(const hand::Kinematics& fk, double target) {
  double lo = -0.3, hi = 0.6;
  for (int i = 0; i < 60; ++i) {
    const double mid = 0.5 * (lo + hi);
    (tip_distance(fk, contact_opened_pinch(mid), hand::Finger::Index) < target ? lo : hi) = mid;
  }
  return contact_opened_pinch(0.5 * (lo + hi));
}

// The index's tip and the thumb's radius sum from collision.hpp's table by phalanx id: thumb distal 3, index distal 15.
constexpr double kThumbIndexContactMm = 7.03 + 5.17;

}  // namespace

TEST_CASE("contact stage: a known thumb-index gap is closed to the two tips' radii, only the two chains move") {
  const hand::Kinematics fk;
  hand::ContactStage stage(fk, hand::JointLimits{});
  CHECK(stage.contact_distance(0) == doctest::Approx(kThumbIndexContactMm));
  for (const double start : {14.9, 14.2, 13.9}) {
    CAPTURE(start);
    stage.reset();
    hand::Angles q = contact_pinch_at(fk, start);
    REQUIRE(tip_distance(fk, q, hand::Finger::Index) == doctest::Approx(start).epsilon(1e-6));
    const hand::Angles before = q;
    hand::Skeleton skeleton;
    fk.pose(q, skeleton);
    const hand::ContactResult r = stage.apply(q, skeleton);
    CHECK(r.contact[0]);
    CHECK_FALSE(r.refused);
    CHECK(r.closed == 0);
    CHECK(r.gap_before_mm == doctest::Approx(start - kThumbIndexContactMm).epsilon(1e-6));
    CHECK(std::abs(tip_distance(fk, q, hand::Finger::Index) - kThumbIndexContactMm) < 0.1);
    CHECK(std::abs(r.gap_after_mm) < 0.1);
    for (std::size_t d = 0; d < hand::kDofCount; ++d) {
      const hand::Finger f = hand::kDofs[d].finger;
      if (f != hand::Finger::Thumb && f != hand::Finger::Index) CHECK(q[d] == before[d]);
    }
    // The skeleton is the adjusted pose's.
    hand::Skeleton expected;
    fk.pose(q, expected);
    for (std::size_t p = 0; p < hand::kPhalanxCount; ++p) CHECK((skeleton[p].matrix() - expected[p].matrix()).norm() < 1e-9);
    // The other pairs not brought closer than the release distance (pinch_index's are far beyond it).
    for (hand::Finger f : {hand::Finger::Middle, hand::Finger::Ring, hand::Finger::Pinky})
      CHECK(tip_distance(fk, q, f) >= std::min(18.0, tip_distance(fk, before, f)) - 1e-6);
  }
}

TEST_CASE("contact stage: the adjusted angles stay within the joint limits") {
  const hand::Kinematics fk;
  const hand::Angles q0 = contact_pinch_at(fk, 14.5);
  // Limits that leave the thumb and index chains 0.01 rad of room about the estimate: too little
  // to close a 2.3 mm gap, so the solve presses against them.
  hand::Angles lo = hand::JointLimits{}.min(), hi = hand::JointLimits{}.max();
  for (std::size_t m = 0; m < hand::kFingerCount; ++m)
    for (hand::Finger f : {hand::Finger::Thumb, hand::Finger::Index}) {
      const std::size_t d = hand::kDofIndex[static_cast<std::size_t>(f)][m];
      lo[d] = q0[d] - 0.01;
      hi[d] = q0[d] + 0.01;
    }
  const hand::JointLimits tight(lo, hi);
  hand::ContactStage stage(fk, tight);
  hand::Angles q = q0;
  hand::Skeleton skeleton;
  fk.pose(q, skeleton);
  const hand::ContactResult r = stage.apply(q, skeleton);
  REQUIRE(r.closed == 0);
  bool moved = false;
  for (std::size_t d = 0; d < hand::kDofCount; ++d) {
    CHECK(q[d] >= lo[d]);
    CHECK(q[d] <= hi[d]);
    moved = moved || q[d] != q0[d];
  }
  CHECK(moved);
  const double after = tip_distance(fk, q, hand::Finger::Index);
  CHECK(after < 14.5);                       // closer ...
  CHECK(after > kThumbIndexContactMm + 0.1);  // ... but not closed: the limits hold
  // The unconstrained stage closes the same gap.
  hand::ContactStage free_stage(fk, hand::JointLimits{});
  hand::Angles q2 = q0;
  fk.pose(q2, skeleton);
  (void)free_stage.apply(q2, skeleton);
  CHECK(std::abs(tip_distance(fk, q2, hand::Finger::Index) - kThumbIndexContactMm) < 0.1);
}

TEST_CASE("contact stage: no contact detected, nothing changes") {
  const hand::Kinematics fk;
  hand::ContactStage stage(fk, hand::JointLimits{});
  const auto unchanged = [&](const hand::Angles& pose) {
    hand::Angles q = pose;
    hand::Skeleton skeleton, expected;
    fk.pose(q, skeleton);
    expected = skeleton;
    const hand::ContactResult r = stage.apply(q, skeleton);
    CHECK(r.closed == -1);
    for (std::size_t d = 0; d < hand::kDofCount; ++d) CHECK(q[d] == pose[d]);  // bit for bit
    for (std::size_t p = 0; p < hand::kPhalanxCount; ++p) CHECK(skeleton[p].matrix() == expected[p].matrix());
    return r;
  };
  for (const sim::KeyPose& k : sim::pose_gallery()) {
    bool pinch = false;
    for (hand::Finger f : {hand::Finger::Index, hand::Finger::Middle, hand::Finger::Ring, hand::Finger::Pinky})
      pinch = pinch || tip_distance(fk, k.angles, f) < 15.0;
    if (pinch) continue;
    CAPTURE(k.name);
    stage.reset();
    const hand::ContactResult r = unchanged(k.angles);
    for (bool on : r.contact) CHECK_FALSE(on);
  }
  // Between the threshold and the release, coming from apart: still apart.
  stage.reset();
  (void)unchanged(contact_pinch_at(fk, 30.0));
  (void)unchanged(contact_pinch_at(fk, 16.5));
  // A non-finite angle: left as it came, and the contact state forgotten.
  hand::Angles q = contact_pinch_at(fk, 14.0);
  hand::Skeleton skeleton;
  fk.pose(q, skeleton);
  CHECK(stage.apply(q, skeleton).contact[0]);
  q[0] = NAN;
  const hand::ContactResult r = stage.apply(q, skeleton);
  CHECK(r.closed == -1);
  CHECK_FALSE(r.contact[0]);
  CHECK(std::isnan(q[0]));
}

TEST_CASE("contact stage: the detection's hysteresis, 15 mm on and 18 mm off") {
  const hand::Kinematics fk;
  hand::ContactStage stage(fk, hand::JointLimits{});
  const auto step = [&](double distance) {
    hand::Angles q = contact_pinch_at(fk, distance);
    hand::Skeleton skeleton;
    fk.pose(q, skeleton);
    const hand::ContactResult r = stage.apply(q, skeleton);
    return r.closed == 0 && std::abs(tip_distance(fk, q, hand::Finger::Index) - kThumbIndexContactMm) < 0.1;
  };
  CHECK_FALSE(step(16.0));
  CHECK(step(14.0));
  CHECK(step(17.5));  // on: held until beyond 18 mm
  CHECK_FALSE(step(18.5));
  CHECK_FALSE(step(17.0));  // off again: needs 15 mm
}

TEST_CASE("contact stage: apply allocates nothing, bad settings are refused at set-up") {
  const hand::Kinematics fk;
  hand::ContactStage stage(fk, hand::JointLimits{});
  hand::Angles q = contact_pinch_at(fk, 14.0), open = sim::gallery_pose("spread").angles;
  hand::Skeleton skeleton, open_skeleton;
  fk.pose(q, skeleton);
  fk.pose(open, open_skeleton);
  const std::size_t allocations = test::allocations_during([&] {
    for (int i = 0; i < 10; ++i) {
      (void)stage.apply(q, skeleton);
      (void)stage.apply(open, open_skeleton);
    }
  });
  CHECK(allocations == 0);
  hand::ContactConfig bad;
  bad.max_iterations = 0;
  CHECK_THROWS_WITH_AS(hand::ContactStage(fk, hand::JointLimits{}, bad), doctest::Contains("max_iterations"), Error);
  bad = {};
  bad.detection.release_mm = 10.0;
  CHECK_THROWS_WITH_AS(hand::ContactStage(fk, hand::JointLimits{}, bad), doctest::Contains("release_mm"), Error);
  bad = {};
  bad.change_weight = 0.0;
  CHECK_THROWS_WITH_AS(hand::ContactStage(fk, hand::JointLimits{}, bad), doctest::Contains("change_weight"), Error);
}

TEST_CASE("contact stage in the estimator: off by default, when on only the poses it closes change, without allocating") {
  CHECK_FALSE(EstimatorConfig{}.contact.has_value());
  const sim::CorpusConfig config = sim::CorpusConfig::one_session(31, 40.0, 3.0);
  const io::Dataset data = sim::to_dataset(sim::simulate_corpus(config), config);
  const auto model = PoseModel::load(std::string(GLOVEPOSE_SOURCE_DIR) + "/models/glovepose_fcn512.safetensors");
  EstimatorConfig with;
  with.contact = hand::ContactConfig{};
  GlovePoseEstimator off(model), on(model, with);
  off.start_calibration();
  on.start_calibration();
  const hand::Kinematics fk;
  std::size_t poses = 0, adjusted = 0, allocations = 0;
  std::vector<double> cells(data.cell_count);
  const std::size_t recording = data.first_session_frame();
  for (std::size_t f = 0; f < data.frames(); ++f) {
    if (f == recording) {
      off.finish_calibration();
      on.finish_calibration();
    }
    for (std::size_t c = 0; c < cells.size(); ++c) cells[c] = data.cells[f * data.cell_count + c];
    const Status status = off.push_cells(cells.data(), static_cast<int>(cells.size()), data.timestamps[f]);
    Status status_on = Status::Ok;
    allocations += test::allocations_during([&] { status_on = on.push_cells(cells.data(), static_cast<int>(cells.size()), data.timestamps[f]); });
    REQUIRE(status == status_on);
    if (status != Status::Solved) continue;
    ++poses;
    const hand::Angles &a = off.pose().angles, &b = on.pose().angles;
    const hand::ContactResult& r = on.contact();
    if (r.closed < 0) {
      for (std::size_t d = 0; d < hand::kDofCount; ++d) CHECK(b[d] == a[d]);
      continue;
    }
    ++adjusted;
    const auto finger = static_cast<hand::Finger>(r.closed + 1);
    for (std::size_t d = 0; d < hand::kDofCount; ++d)
      if (hand::kDofs[d].finger != hand::Finger::Thumb && hand::kDofs[d].finger != finger) CHECK(b[d] == a[d]);
    CHECK(tip_distance(fk, a, finger) < 18.0);  // the evidence: the stage-off pose's tips were close
    // Closed to the two distal radii (collision.hpp's table: the thumb's distal phalanx is id 3).
    const double touch = hand::kReferenceDistalRadius[3] + hand::kReferenceDistalRadius[static_cast<std::size_t>(hand::kFingerBase[static_cast<std::size_t>(finger)]) + 2];
    CHECK(std::abs(tip_distance(fk, b, finger) - touch) < 0.1);
  }
  MESSAGE(poses << " poses, " << adjusted << " adjusted by the contact stage");
  CHECK(poses > 1000);
  CHECK(adjusted > 0);
  CHECK(allocations == 0);
}

TEST_CASE("contact stage: closing one pair does not bring the thumb closer to the other fingers than apart_mm") {
  // pinch_index with the middle finger curled as the index is, its base flexion 0.2 rad more: its
  // tip lies near the thumb's path, so closing thumb-index pulls the thumb toward it.
  const hand::Kinematics fk;
  hand::Angles pose = contact_pinch_at(fk, 14.8);
  for (std::size_t m = 0; m < hand::kFingerCount; ++m)
    pose[hand::kDofIndex[2][m]] = sim::gallery_pose("pinch_index").angles[hand::kDofIndex[1][m]];
  pose[hand::dof_of(hand::Finger::Middle, hand::Motion::BaseFlexion)] += 0.2;
  const double middle_before = tip_distance(fk, pose, hand::Finger::Middle);
  REQUIRE(middle_before > 18.0);
  REQUIRE(middle_before < 25.0);
  const auto closed = [&](double apart_mm) {
    hand::ContactConfig config;
    config.apart_mm = apart_mm;
    hand::ContactStage stage(fk, hand::JointLimits{}, config);
    hand::Angles q = pose;
    hand::Skeleton skeleton;
    fk.pose(q, skeleton);
    REQUIRE(stage.apply(q, skeleton).closed == 0);
    CHECK(std::abs(tip_distance(fk, q, hand::Finger::Index) - kThumbIndexContactMm) < 0.1);
    return tip_distance(fk, q, hand::Finger::Middle);
  };
  // No floor: the thumb passes closer to the middle tip. A floor of 25 mm (above the estimate's
  // distance): the middle tip is kept where the estimate had it.
  CHECK(closed(0.0) < middle_before - 1.0);
  CHECK(closed(25.0) > middle_before - 0.05);
}

TEST_CASE("contact stage: an adjustment whose collision energy passes max_collision is refused, the pose kept") {
  // Closing pinch_index from 14.1 mm presses the neighbouring capsules: the collision energy rises
  // from the estimate's 0.01 mm^2 to about 1.3 (collision.hpp, computed here on both poses).
  const hand::Kinematics fk;
  const hand::Angles pose = contact_pinch_at(fk, 14.1);
  hand::Skeleton before;
  fk.pose(pose, before);
  hand::ContactStage free_stage(fk, hand::JointLimits{});
  hand::Angles closed = pose;
  hand::Skeleton skeleton = before;
  REQUIRE(free_stage.apply(closed, skeleton).closed == 0);
  const double energy_before = hand::collision_energy(fk, before), energy_after = hand::collision_energy(fk, skeleton);
  REQUIRE(energy_after > energy_before + 0.1);
  // A limit between the two: refused, angles and skeleton as they came.
  hand::ContactConfig config;
  config.max_collision = 0.5 * (energy_before + energy_after);
  hand::ContactStage stage(fk, hand::JointLimits{}, config);
  hand::Angles q = pose;
  skeleton = before;
  const hand::ContactResult r = stage.apply(q, skeleton);
  CHECK(r.refused);
  CHECK(r.closed == -1);
  CHECK(r.contact[0]);  // still in contact by the evidence
  for (std::size_t d = 0; d < hand::kDofCount; ++d) CHECK(q[d] == pose[d]);
  for (std::size_t p = 0; p < hand::kPhalanxCount; ++p) CHECK(skeleton[p].matrix() == before[p].matrix());
  // A limit above the adjusted pose's energy: accepted.
  config.max_collision = energy_after + 0.01;
  hand::ContactStage lenient(fk, hand::JointLimits{}, config);
  q = pose;
  skeleton = before;
  CHECK(lenient.apply(q, skeleton).closed == 0);
}
