// The tests' own thumb-to-fingertip distance: from the posed skeleton's tip points directly
// (Kinematics::fingertip), the reference hand/pinch.hpp's distances are checked against.
#pragma once

#include <glovepose/hand/dofs.hpp>
#include <glovepose/hand/kinematics.hpp>

namespace glovepose::test {

/// Thumb tip to the tip of `finger` (mm) for `angles` on `fk`'s hand.
inline double tip_distance(const hand::Kinematics& fk, const hand::Angles& angles, hand::Finger finger) {
  hand::Skeleton s;
  fk.pose(angles, s);
  return (fk.fingertip(s, hand::Finger::Thumb) - fk.fingertip(s, finger)).norm();
}

/// The same on the reference hand.
inline double tip_distance(const hand::Angles& angles, hand::Finger finger) { return tip_distance(hand::Kinematics(), angles, finger); }

}  // namespace glovepose::test
