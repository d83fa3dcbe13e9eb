#include <glovepose/sim/pose_gallery.hpp>

#include <doctest/doctest.h>

#include <set>

using namespace glovepose;
using namespace glovepose::sim;

TEST_CASE("pose gallery: at least 24 named poses, all inside the joint limits, tip coupled to middle") {
  const std::vector<KeyPose> gallery = pose_gallery();
  CHECK(gallery.size() >= 24);
  std::set<std::string> names;
  const hand::JointLimits limits;
  const hand::Kinematics fk;
  hand::Skeleton s;
  for (const KeyPose& p : gallery) {
    INFO(p.name);
    names.insert(p.name);
    for (std::size_t d = 0; d < hand::kDofCount; ++d) {
      CHECK(p.angles[d] >= limits.min()[d]);
      CHECK(p.angles[d] <= limits.max()[d]);
    }
    for (int f = 0; f < 4; ++f)  // index..pinky: tip = 2/3 middle (settling moves thumb and abductions only)
      CHECK(p.angles[hand::dof_from_theta(16 + 4 * f)] == doctest::Approx(kTipCoupling * p.angles[hand::dof_from_theta(15 + 4 * f)]));
    fk.pose(p.angles, s);
    const double energy = hand::collision_energy(fk, s);
    MESSAGE(p.name << ": collision energy " << energy);
    CHECK(energy < hand::kCollisionOutlierThreshold);  // key poses are feasible hands
  }
  CHECK(names.size() == gallery.size());
  for (const char* required : {"fist", "flat", "spread", "point", "pinch_index", "ok", "thumbs_up", "claw", "power_grasp"})
    CHECK(names.count(required) == 1);
}

TEST_CASE("pose gallery: in pinches and OK the thumb tip meets the fingertip (solved on the chain)") {
  const hand::Kinematics fk;
  hand::Skeleton s;
  const std::pair<const char*, hand::Finger> pinches[] = {{"pinch_index", hand::Finger::Index},
                                                          {"pinch_middle", hand::Finger::Middle},
                                                          {"pinch_ring", hand::Finger::Ring},
                                                          {"pinch_pinky", hand::Finger::Pinky},
                                                          {"ok", hand::Finger::Index}};
  for (const auto& [name, finger] : pinches) {
    fk.pose(gallery_pose(name).angles, s);
    const double gap = (fk.fingertip(s, hand::Finger::Thumb) - fk.fingertip(s, finger)).norm();
    MESSAGE(std::string(name) << ": thumb tip to fingertip " << gap << " mm");
    CHECK(gap < 16.0);  // contact is the two tip radii apart (11-12 mm); a few mm of slack for the joint limits
  }
  CHECK_THROWS_WITH_AS(gallery_pose("pinch_thumb"), doctest::Contains("pose gallery: no pose 'pinch_thumb', expected one of "), Error);
}
