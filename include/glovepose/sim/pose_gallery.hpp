/// @file pose_gallery.hpp
/// @brief The gallery of named key poses the simulated subjects perform (the paper shows its
/// participants "a printed gallery of example poses", Sec. 5.1).
///
/// Finger poses are written as base / middle flexion and abduction; tip flexion follows middle
/// flexion (the coupling of the distal joint through the extensor mechanism, DIP ~ 2/3 PIP in
/// grasping: Rijpkema & Girard 1991, Lin, Wu & Huang 2000). Every designed pose is settled on the
/// reference chain (`settle_pose`): the thumb and the abductions give way where capsules would
/// interpenetrate, and in the poses where the thumb meets a fingertip (pinches, OK) the thumb is
/// solved to contact. Signs of the reference model: positive flexion curls, positive abduction turns
/// a finger towards the thumb.
#pragma once

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "../config.hpp"
#include "../hand/collision.hpp"
#include "../hand/dofs.hpp"
#include "../hand/kinematics.hpp"

namespace glovepose::sim {

/// @brief Ratio of tip flexion to middle flexion in natural motion (DIP ~ 2/3 PIP).
inline constexpr double kTipCoupling = 2.0 / 3.0;

/// @brief A named pose.
struct KeyPose {
  std::string name;     ///< e.g. "fist", "pinch_index".
  hand::Angles angles;  ///< Radians, kDofs order, inside the reference joint limits.
};

/// @brief One long finger's shape: abduction, base flexion, middle flexion (tip follows).
struct FingerShape {
  double abduction, base, middle;
};

/// @brief The thumb's five angles (abduction, base, middle, tip flexion, twist).
struct ThumbShape {
  double abduction, base, middle, tip, twist;
};

/// @brief A pose from a thumb shape and four finger shapes (index, middle, ring, pinky), tip flexion
/// coupled to middle flexion, clamped to the joint limits.
inline hand::Angles make_pose(const ThumbShape& t, const FingerShape& index, const FingerShape& middle, const FingerShape& ring,
                              const FingerShape& pinky) {
  using hand::dof_from_theta;
  hand::Angles a{};
  a[dof_from_theta(9)] = t.abduction;
  a[dof_from_theta(10)] = t.base;
  a[dof_from_theta(11)] = t.middle;
  a[dof_from_theta(12)] = t.tip;
  a[dof_from_theta(29)] = t.twist;
  const FingerShape* fingers[] = {&index, &middle, &ring, &pinky};
  for (int f = 0; f < 4; ++f) {
    a[dof_from_theta(13 + 4 * f)] = fingers[f]->abduction;
    a[dof_from_theta(14 + 4 * f)] = fingers[f]->base;
    a[dof_from_theta(15 + 4 * f)] = fingers[f]->middle;
    a[dof_from_theta(16 + 4 * f)] = kTipCoupling * fingers[f]->middle;
  }
  return hand::JointLimits().clamp(a);
}

/// @brief The reference template's kinematics, shared.
inline const hand::Kinematics& reference_kinematics() {
  static const hand::Kinematics fk;
  return fk;
}

/// @brief Settles a designed pose the way the tracker behind the paper's data would have seen it:
/// coordinate descent on the thumb's five angles and the four finger abductions (within the limits),
/// minimising collision energy + stiffness x squared departure from the design (radians) and, when
/// `target` is a finger other than the thumb, the squared gap of the thumb tip beyond contact with
/// that fingertip (contact: the two tips' radii apart). Writes the final thumb-to-target gap (mm).
/// `fk` and `radius` give the hand (default: the reference template), `first_step` the largest
/// change tried (rad; small for poses that are already nearly settled).
inline hand::Angles settle_pose(const hand::Angles& design, const hand::Finger target = hand::Finger::Thumb, double* gap = nullptr,
                                const hand::Kinematics& fk = reference_kinematics(),
                                const std::array<double, 16>& radius = hand::kReferenceDistalRadius, double first_step = 0.4) {
  const hand::JointLimits limits;
  hand::Skeleton s;
  constexpr double kStiffness = 200.0;  // mm^2 per rad^2: a 0.1 rad change costs as much as a 1.4 mm penetration
  const bool oppose = target != hand::Finger::Thumb;
  const double contact = radius[3] + radius[static_cast<std::size_t>(hand::kFingerBase[static_cast<std::size_t>(target)]) + 2];
  const auto tip_gap = [&]() { return (fk.fingertip(s, hand::Finger::Thumb) - fk.fingertip(s, target)).norm(); };
  const auto cost = [&](const hand::Angles& a) {
    fk.pose(a, s);
    double c = hand::collision_energy(fk, s, radius);
    for (std::size_t d = 0; d < hand::kDofCount; ++d) c += kStiffness * (a[d] - design[d]) * (a[d] - design[d]);
    if (oppose) {
      const double beyond = std::max(0.0, tip_gap() - contact);
      c += 10.0 * beyond * beyond;
    }
    return c;
  };
  const int free_thetas[] = {9, 10, 11, 12, 29, 13, 17, 21, 25};
  hand::Angles pose = design;
  double best = cost(pose);
  for (double step = first_step; step > 1e-3; step *= 0.5) {
    for (bool improved = true; improved;) {
      improved = false;
      for (int theta : free_thetas) {
        const std::size_t d = hand::dof_from_theta(theta);
        for (double sign : {1.0, -1.0}) {
          hand::Angles trial = pose;
          trial[d] = std::clamp(trial[d] + sign * step, limits.min()[d], limits.max()[d]);
          const double c = cost(trial);
          if (c < best - 1e-9) {
            best = c;
            pose = trial;
            improved = true;
          }
        }
      }
    }
  }
  if (gap) {
    fk.pose(pose, s);
    *gap = oppose ? tip_gap() : 0.0;
  }
  return pose;
}

/// @brief The gallery: 26 key poses, each inside the joint limits.
inline std::vector<KeyPose> pose_gallery() {
  // Shorthands: a finger straight, half-curled, hooked (claw), flat-bent (base only). Fully curled
  // fingers converge on the reference chain (their base frames tilt towards each other), so in a
  // fist they turn to the ulnar side and the pinky curls a little less, as the tracker that made the
  // paper's data would have had them (it penalises the collision energy): `curled` is per finger.
  const FingerShape straight{0.0, 0.0, 0.0}, half{0.0, 0.7, 0.8}, hook{0.0, 0.1, 1.6}, flat_bent{0.0, 1.3, 0.05};
  const FingerShape curled_index{0.2, 1.35, 1.5}, curled_middle{0.05, 1.35, 1.5}, curled_ring{-0.1, 1.3, 1.45},
      curled_pinky{-0.2, 1.15, 1.35};
  const ThumbShape thumb_out{0.1, 0.0, 0.0, 0.0, 0.0}, thumb_tucked{0.8, 0.8, 0.5, 0.5, 0.2}, thumb_up{0.0, -0.3, -0.2, -0.3, 0.0},
      thumb_across{0.9, 0.6, 0.4, 0.4, 0.3};
  const auto spread = [](FingerShape f, double abduction) {
    f.abduction = abduction;
    return f;
  };
  std::vector<KeyPose> g;
  const auto add = [&](const char* name, const hand::Angles& a) { g.push_back({name, settle_pose(a)}); };
  add("flat", make_pose(thumb_out, straight, straight, straight, straight));
  add("spread", make_pose({0.9, -0.2, 0.0, -0.2, -0.1}, spread(straight, 0.3), straight, spread(straight, -0.1), spread(straight, -0.2)));
  add("fist", make_pose(thumb_across, curled_index, curled_middle, curled_ring, curled_pinky));
  add("loose_fist", make_pose(thumb_tucked, half, half, half, half));
  add("point", make_pose(thumb_across, straight, curled_middle, curled_ring, curled_pinky));
  add("two_fingers", make_pose(thumb_across, spread(straight, 0.15), spread(straight, -0.1), curled_ring, curled_pinky));
  add("three_fingers", make_pose(thumb_across, straight, straight, straight, curled_pinky));
  add("four_fingers", make_pose(thumb_across, straight, straight, straight, straight));
  add("count_one_thumb", make_pose(thumb_out, curled_index, curled_middle, curled_ring, curled_pinky));
  add("thumbs_up", make_pose(thumb_up, curled_index, curled_middle, curled_ring, curled_pinky));
  add("pinky_up", make_pose(thumb_across, curled_index, curled_middle, curled_ring, spread(straight, -0.2)));
  add("rock", make_pose(thumb_across, spread(straight, 0.1), curled_middle, curled_ring, spread(straight, -0.2)));
  add("call_me", make_pose(thumb_out, curled_index, curled_middle, curled_ring, spread(straight, -0.2)));
  add("claw", make_pose(thumb_tucked, hook, hook, hook, hook));
  add("flat_bent",
      make_pose(thumb_out, spread(flat_bent, 0.15), spread(flat_bent, 0.05), spread(flat_bent, -0.1), spread(flat_bent, -0.2)));
  add("power_grasp", make_pose(thumb_across, {0.0, 1.0, 1.1}, {0.0, 1.05, 1.15}, {0.0, 1.1, 1.2}, {0.0, 1.15, 1.25}));
  add("cylinder_grasp", make_pose(thumb_tucked, {0.0, 0.8, 0.9}, {0.0, 0.85, 0.95}, {0.0, 0.9, 1.0}, {0.0, 0.95, 1.05}));
  add("ball_grasp", make_pose({0.7, 0.3, 0.3, 0.3, 0.2}, {0.2, 0.6, 0.6}, {0.0, 0.6, 0.6}, {-0.05, 0.65, 0.65}, {-0.15, 0.7, 0.7}));
  add("wave", make_pose(thumb_out, {0.0, -0.3, 0.0}, {0.0, -0.3, 0.0}, {0.0, -0.3, 0.0}, {0.0, -0.3, 0.0}));
  add("tap_index", make_pose(thumb_out, {0.0, 0.9, 0.3}, straight, straight, straight));
  // Poses where the thumb meets a fingertip: finger shapes typed in, thumb solved to contact.
  const auto opposition = [&](const char* name, hand::Finger target, const hand::Angles& fingers) {
    g.push_back({name, settle_pose(fingers, target)});
  };
  opposition("pinch_index", hand::Finger::Index, make_pose(thumb_tucked, {0.0, 0.7, 0.6}, half, half, half));
  opposition("pinch_middle", hand::Finger::Middle, make_pose(thumb_tucked, half, {0.0, 0.75, 0.6}, half, half));
  opposition("pinch_ring", hand::Finger::Ring,
             make_pose(thumb_tucked, spread(straight, 0.1), straight, {0.0, 0.85, 0.6}, {-0.2, 0.5, 0.4}));
  opposition("pinch_pinky", hand::Finger::Pinky,
             make_pose(thumb_tucked, spread(straight, 0.1), straight, spread(straight, 0.1), {0.0, 0.95, 0.6}));
  opposition("ok", hand::Finger::Index,
             make_pose(thumb_tucked, {0.0, 0.75, 0.7}, spread(straight, -0.05), spread(straight, -0.1), spread(straight, -0.15)));
  opposition("key_grip", hand::Finger::Index, make_pose(thumb_tucked, {0.2, 0.9, 1.2}, curled_middle, curled_ring, curled_pinky));
  return g;
}

/// @brief The gallery's pose named `name` (e.g. "pinch_index"). Throws glovepose::Error naming the
/// gallery's poses when there is none of that name.
inline const KeyPose& gallery_pose(const std::string& name) {
  static const std::vector<KeyPose> gallery = pose_gallery();
  for (const KeyPose& p : gallery)
    if (p.name == name) return p;
  std::string names;
  for (const KeyPose& p : gallery) names += (names.empty() ? "" : ", ") + p.name;
  throw Error("pose gallery: no pose '" + name + "', expected one of " + names);
}

}  // namespace glovepose::sim
