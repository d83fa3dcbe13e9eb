// The OpenXR joint layout (hand/openxr_joints.hpp, hand/xr_hand.hpp): enum order, joint count, struct
// layout and flag values against <openxr/openxr.h>; the spec's joint conventions checked
// geometrically; radii against the template's spheres; a left hand as the mirrored right hand;
// velocities as the derivative of the located joints.
#include <openxr/openxr.h>

#include <glovepose/hand/joint_list.hpp>
#include <glovepose/hand/xr_hand.hpp>

#include <doctest/doctest.h>

#include <cctype>
#include <cstddef>
#include <cstring>
#include <random>
#include <string>

#include "alloc_counter.hpp"
#include "reference/hmodel_template.hpp"

using namespace glovepose;
using namespace glovepose::hand;

namespace {

Eigen::Vector3d position(const XrJointLocation& j) { return {j.pose.position.x, j.pose.position.y, j.pose.position.z}; }
Eigen::Matrix3d rotation(const XrJointLocation& j) {
  const XrQuaternion& q = j.pose.orientation;
  return Eigen::Quaterniond(q.w, q.x, q.y, q.z).toRotationMatrix();
}
std::size_t at(XrJoint j) { return static_cast<std::size_t>(j); }

// Angles drawn uniformly within the joint limits.
Angles random_pose(std::mt19937& rng) {
  Angles a{};
  for (std::size_t d = 0; d < kDofCount; ++d) a[d] = std::uniform_real_distribution<double>(kDofs[d].min, kDofs[d].max)(rng);
  return a;
}

XrJointLocations located(const hand::XrHandLocator& locator, const Angles& angles) {
  hand::XrHandJoints out;
  locator.locate(angles, nullptr, kXrPositionValid, out);
  return out.locations;
}

// The joint after j along its digit (-1 for the palm, the wrist and tips).
int next_on_digit(std::size_t j) {
  if (j < 2) return -1;
  const std::size_t tip = at(XrJoint::ThumbTip);
  if (j <= tip) return j == tip ? -1 : static_cast<int>(j + 1);
  return (j - at(XrJoint::IndexMetacarpal)) % 5 == 4 ? -1 : static_cast<int>(j + 1);
}

// The conventions every located hand must meet: +Z of each joint runs along its bone away from
// the tip, a tip is oriented like its distal joint, the wrist is the identity pose, the palm lies
// half-way along the middle metacarpal and is oriented like the wrist.
void check_conventions(const XrJointLocations& joints) {
  double worst_bone = 0.0;
  for (std::size_t j = 0; j < kXrJointCount; ++j) {
    const int next = next_on_digit(j);
    if (next < 0) continue;
    const Eigen::Vector3d bone = position(joints[static_cast<std::size_t>(next)]) - position(joints[j]);
    const Eigen::Vector3d z = rotation(joints[j]).col(2);
    worst_bone = std::max(worst_bone, (z + bone.normalized()).norm());
    if (next_on_digit(static_cast<std::size_t>(next)) < 0)  // the tip
      CHECK((rotation(joints[static_cast<std::size_t>(next)]) - rotation(joints[j])).cwiseAbs().maxCoeff() < 1e-6);
  }
  CHECK(worst_bone < 1e-5);
  const XrJointLocation& wrist = joints[at(XrJoint::Wrist)];
  CHECK(position(wrist).norm() < 1e-7);
  CHECK((rotation(wrist) - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff() < 1e-6);
  const Eigen::Vector3d metacarpal = position(joints[at(XrJoint::MiddleMetacarpal)]);
  const Eigen::Vector3d knuckle = position(joints[at(XrJoint::MiddleProximal)]);
  CHECK((position(joints[at(XrJoint::Palm)]) - 0.5 * (metacarpal + knuckle)).norm() < 1e-7);
  // Wrist, middle metacarpal and knuckle on one line along -Z: the palm between wrist and knuckle.
  CHECK(knuckle.normalized().z() < -0.999);
  CHECK(metacarpal.normalized().z() < -0.999);
  CHECK((rotation(joints[at(XrJoint::Palm)]) - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff() < 1e-6);
}

}  // namespace

TEST_CASE("openxr joints: order, count, struct layout and flags are those of openxr.h") {
  CHECK(kXrJointCount == XR_HAND_JOINT_COUNT_EXT);
#define GLOVEPOSE_XR(name) \
  { XR_HAND_JOINT_##name##_EXT, #name }
  const struct {
    XrHandJointEXT value;
    const char* name;
  } spec[] = {GLOVEPOSE_XR(PALM),
              GLOVEPOSE_XR(WRIST),
              GLOVEPOSE_XR(THUMB_METACARPAL),
              GLOVEPOSE_XR(THUMB_PROXIMAL),
              GLOVEPOSE_XR(THUMB_DISTAL),
              GLOVEPOSE_XR(THUMB_TIP),
              GLOVEPOSE_XR(INDEX_METACARPAL),
              GLOVEPOSE_XR(INDEX_PROXIMAL),
              GLOVEPOSE_XR(INDEX_INTERMEDIATE),
              GLOVEPOSE_XR(INDEX_DISTAL),
              GLOVEPOSE_XR(INDEX_TIP),
              GLOVEPOSE_XR(MIDDLE_METACARPAL),
              GLOVEPOSE_XR(MIDDLE_PROXIMAL),
              GLOVEPOSE_XR(MIDDLE_INTERMEDIATE),
              GLOVEPOSE_XR(MIDDLE_DISTAL),
              GLOVEPOSE_XR(MIDDLE_TIP),
              GLOVEPOSE_XR(RING_METACARPAL),
              GLOVEPOSE_XR(RING_PROXIMAL),
              GLOVEPOSE_XR(RING_INTERMEDIATE),
              GLOVEPOSE_XR(RING_DISTAL),
              GLOVEPOSE_XR(RING_TIP),
              GLOVEPOSE_XR(LITTLE_METACARPAL),
              GLOVEPOSE_XR(LITTLE_PROXIMAL),
              GLOVEPOSE_XR(LITTLE_INTERMEDIATE),
              GLOVEPOSE_XR(LITTLE_DISTAL),
              GLOVEPOSE_XR(LITTLE_TIP)};
#undef GLOVEPOSE_XR
  static_assert(sizeof(spec) / sizeof(spec[0]) == kXrJointCount);
  for (std::size_t j = 0; j < kXrJointCount; ++j) {
    std::string name = spec[j].name;
    for (char& c : name) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    CHECK(static_cast<int>(spec[j].value) == static_cast<int>(j));
    CHECK(name == kXrJointNames[j]);
  }
  static_assert(sizeof(XrJointLocation) == sizeof(XrHandJointLocationEXT));
  static_assert(alignof(XrJointLocation) == alignof(XrHandJointLocationEXT));
  static_assert(offsetof(XrJointLocation, location_flags) == offsetof(XrHandJointLocationEXT, locationFlags));
  static_assert(offsetof(XrJointLocation, pose) == offsetof(XrHandJointLocationEXT, pose));
  static_assert(offsetof(XrJointLocation, radius) == offsetof(XrHandJointLocationEXT, radius));
  static_assert(sizeof(XrPose) == sizeof(XrPosef) && offsetof(XrPose, position) == offsetof(XrPosef, position));
  static_assert(sizeof(XrQuaternion) == sizeof(XrQuaternionf) && offsetof(XrQuaternion, w) == offsetof(XrQuaternionf, w));
  static_assert(sizeof(XrVector3) == sizeof(XrVector3f) && offsetof(XrVector3, z) == offsetof(XrVector3f, z));
  static_assert(sizeof(XrJointVelocity) == sizeof(XrHandJointVelocityEXT));
  static_assert(offsetof(XrJointVelocity, velocity_flags) == offsetof(XrHandJointVelocityEXT, velocityFlags));
  static_assert(offsetof(XrJointVelocity, linear_velocity) == offsetof(XrHandJointVelocityEXT, linearVelocity));
  static_assert(offsetof(XrJointVelocity, angular_velocity) == offsetof(XrHandJointVelocityEXT, angularVelocity));
  static_assert(sizeof(XrJointLocations) == kXrJointCount * sizeof(XrHandJointLocationEXT));
  CHECK(kXrOrientationValid == XR_SPACE_LOCATION_ORIENTATION_VALID_BIT);
  CHECK(kXrPositionValid == XR_SPACE_LOCATION_POSITION_VALID_BIT);
  CHECK(kXrOrientationTracked == XR_SPACE_LOCATION_ORIENTATION_TRACKED_BIT);
  CHECK(kXrPositionTracked == XR_SPACE_LOCATION_POSITION_TRACKED_BIT);
  CHECK(kXrLinearVelocityValid == XR_SPACE_VELOCITY_LINEAR_VALID_BIT);
  CHECK(kXrAngularVelocityValid == XR_SPACE_VELOCITY_ANGULAR_VALID_BIT);

  // What an engine does: copy the joints as they are into OpenXR's own structs.
  const hand::XrHandLocator locator(HandModel::reference(), Handedness::Right);
  std::mt19937 rng(5);
  hand::XrHandJoints joints;
  const Angles rate = random_pose(rng);
  locator.locate(random_pose(rng), &rate, kXrPositionValid | kXrOrientationTracked, joints);
  XrHandJointLocationEXT locations[XR_HAND_JOINT_COUNT_EXT];
  XrHandJointVelocityEXT velocities[XR_HAND_JOINT_COUNT_EXT];
  std::memcpy(locations, joints.locations.data(), sizeof(locations));
  std::memcpy(velocities, joints.velocities.data(), sizeof(velocities));
  for (std::size_t j = 0; j < kXrJointCount; ++j) {
    CHECK(locations[j].locationFlags == (XR_SPACE_LOCATION_POSITION_VALID_BIT | XR_SPACE_LOCATION_ORIENTATION_TRACKED_BIT));
    CHECK(locations[j].pose.orientation.w == joints.locations[j].pose.orientation.w);
    CHECK(locations[j].pose.position.y == joints.locations[j].pose.position.y);
    CHECK(locations[j].radius == joints.locations[j].radius);
    CHECK(velocities[j].angularVelocity.z == joints.velocities[j].angular_velocity.z);
  }
}

TEST_CASE("openxr joints: the spec's conventions hold on the rest pose and on random poses") {
  const hand::XrHandLocator locator(HandModel::reference(), Handedness::Right);
  const XrJointLocations rest = located(locator, Angles{});
  check_conventions(rest);
  // The open hand: every finger joint's +Y points out of the back of the hand (+Y of the wrist),
  // the fingers run towards -Z, the thumb lies towards +X on a right hand, the little finger -X.
  for (std::size_t j = at(XrJoint::IndexMetacarpal); j < kXrJointCount; ++j) {
    INFO(std::string(kXrJointNames[j]));
    CHECK(rotation(rest[j]).col(1).y() > 0.95);
  }
  CHECK(position(rest[at(XrJoint::MiddleTip)]).z() < -0.12);
  CHECK(position(rest[at(XrJoint::ThumbTip)]).x() > 0.01);
  CHECK(position(rest[at(XrJoint::LittleTip)]).x() < -0.01);
  CHECK(position(rest[at(XrJoint::ThumbTip)]).x() > position(rest[at(XrJoint::LittleTip)]).x() + 0.04);
  // The thumb's nail side: flexing its tip joint moves the tip along -Y of the thumb's distal joint.
  Angles bent_thumb{};
  bent_thumb[dof_of(Finger::Thumb, Motion::TipFlexion)] = 0.5;
  const Eigen::Vector3d thumb_move = position(located(locator, bent_thumb)[at(XrJoint::ThumbTip)]) - position(rest[at(XrJoint::ThumbTip)]);
  CHECK(thumb_move.dot(rotation(rest[at(XrJoint::ThumbDistal)]).col(1)) < -0.9 * thumb_move.norm());
  // Flexing the middle finger's knuckle moves its tip towards the palm (-Y).
  Angles bent{};
  bent[dof_of(Finger::Middle, Motion::BaseFlexion)] = 1.0;
  CHECK(position(located(locator, bent)[at(XrJoint::MiddleTip)]).y() < position(rest[at(XrJoint::MiddleTip)]).y() - 0.03);

  // Random poses: the conventions, metres, and a rigid change of frame from the 21-joint list.
  const Kinematics& fk = locator.mapper().kinematics();
  std::mt19937 rng(11);
  const std::size_t list_of_xr[] = {2, 3, 4, 5, 7, 8, 9, 10, 12, 13, 14, 15, 17, 18, 19, 20, 22, 23, 24, 25};
  for (int trial = 0; trial < 20; ++trial) {
    const Angles angles = random_pose(rng);
    const XrJointLocations joints = located(locator, angles);
    check_conventions(joints);
    Skeleton skeleton;
    fk.pose(angles, skeleton);
    JointList list{};
    to_joint_list(fk, skeleton, list);
    double worst = 0.0;
    for (std::size_t a = 0; a < 20; ++a)
      for (std::size_t b = a + 1; b < 20; ++b) {
        const auto& pa = list[a + 1].position;
        const auto& pb = list[b + 1].position;
        const double d_list = (Eigen::Vector3d(pa[0], pa[1], pa[2]) - Eigen::Vector3d(pb[0], pb[1], pb[2])).norm();
        const double d_xr = (position(joints[list_of_xr[a]]) - position(joints[list_of_xr[b]])).norm();
        worst = std::max(worst, std::abs(d_list - d_xr));
      }
    CHECK(worst < 1e-6);
    // Bone lengths in metres: the middle finger's intermediate bone ends where the model's Middle3 starts.
    const double middle3 = fk.model().rest[static_cast<std::size_t>(Phalanx::Middle3)].translation().norm() * 1e-3;
    CHECK((position(joints[at(XrJoint::MiddleDistal)]) - position(joints[at(XrJoint::MiddleIntermediate)])).norm() ==
          doctest::Approx(middle3).epsilon(1e-5));
  }
}

TEST_CASE("openxr joints: radii are the template's spheres at the joints, scaled with the hand") {
  const hand::XrHandLocator locator(HandModel::reference(), Handedness::Right);
  const Kinematics& fk = locator.mapper().kinematics();
  Skeleton skeleton;
  fk.pose(Angles{}, skeleton);
  JointList list{};
  to_joint_list(fk, skeleton, list);
  // Each digit joint's radius is that of the template sphere nearest to it at rest (C.txt, R.txt).
  const std::size_t list_of_xr[] = {2, 3, 4, 5, 7, 8, 9, 10, 12, 13, 14, 15, 17, 18, 19, 20, 22, 23, 24, 25};
  const auto& centres = test::hmodel::kSphereCentres;
  for (std::size_t k = 0; k < 20; ++k) {
    const auto& p = list[k + 1].position;
    const Eigen::Vector3d joint_mm = Eigen::Vector3d(p[0], p[1], p[2]) * 1e3;
    std::size_t nearest = 0;
    double best = 1e9;
    for (std::size_t s = 0; s < 20; ++s) {
      const double d = (joint_mm - Eigen::Vector3d(centres[3 * s], centres[3 * s + 1], centres[3 * s + 2])).norm();
      if (d < best) best = d, nearest = s;
    }
    INFO(std::string(kXrJointNames[list_of_xr[k]]));
    CHECK(best < 2.0);  // mm: the sphere sits on the joint (a tip's about 5 degrees off the bone)
    CHECK(locator.mapper().radii()[list_of_xr[k]] * 1e3 == doctest::Approx(test::hmodel::kSphereRadii[nearest]).epsilon(1e-3));
  }
  // A hand 1.2 times the template's size has joints 1.2 times as thick.
  HandModel big = HandModel::reference();
  for (auto& rest : big.rest) rest.translation() *= 1.2;
  for (double& l : big.tip_length) l *= 1.2;
  const hand::XrHandLocator big_locator(big, Handedness::Right);
  for (std::size_t j = 0; j < kXrJointCount; ++j)
    CHECK(big_locator.mapper().radii()[j] == doctest::Approx(1.2 * locator.mapper().radii()[j]).epsilon(1e-6));
  hand::XrHandJoints joints;
  big_locator.locate(Angles{}, nullptr, 0, joints);
  CHECK(joints.locations[at(XrJoint::Wrist)].radius == doctest::Approx(1.2 * 12.943e-3).epsilon(1e-4));
}

TEST_CASE("openxr joints: a left hand is the right hand mirrored through the wrist's YZ plane") {
  const hand::XrHandLocator right(HandModel::reference(), Handedness::Right);
  const hand::XrHandLocator left(HandModel::reference(), Handedness::Left);
  CHECK(left.side() == Handedness::Left);
  std::mt19937 rng(23);
  for (int trial = 0; trial < 20; ++trial) {
    const Angles angles = trial == 0 ? Angles{} : random_pose(rng);
    const XrJointLocations r = located(right, angles), l = located(left, angles);
    check_conventions(l);
    double worst = 0.0;
    for (std::size_t j = 0; j < kXrJointCount; ++j) {
      const XrPose& a = r[j].pose;
      const XrPose& b = l[j].pose;
      const float diffs[] = {b.position.x + a.position.x,       b.position.y - a.position.y,       b.position.z - a.position.z,
                             b.orientation.x - a.orientation.x, b.orientation.y + a.orientation.y, b.orientation.z + a.orientation.z,
                             b.orientation.w - a.orientation.w, l[j].radius - r[j].radius};
      for (float d : diffs) worst = std::max(worst, static_cast<double>(std::abs(d)));
    }
    CHECK(worst < 1e-6);
    if (trial == 0) {
      CHECK(position(l[at(XrJoint::ThumbTip)]).x() < -0.01);  // the thumb on the -X side
      CHECK(position(l[at(XrJoint::LittleTip)]).x() > 0.01);
      for (std::size_t j = at(XrJoint::IndexMetacarpal); j < kXrJointCount; ++j) CHECK(rotation(l[j]).col(1).y() > 0.95);
    }
  }
}

TEST_CASE("openxr joints: velocities are the derivative of the located joints along the angles' rate") {
  const hand::XrHandLocator locator(HandModel::reference(), Handedness::Left);
  std::mt19937 rng(31);
  for (int trial = 0; trial < 10; ++trial) {
    Angles angles = random_pose(rng), rate{};
    for (std::size_t d = 0; d < kDofCount; ++d) {
      angles[d] = 0.5 * (angles[d] + 0.5 * (kDofs[d].min + kDofs[d].max));  // away from the limits
      rate[d] = std::uniform_real_distribution<double>(-3.0, 3.0)(rng);
    }
    hand::XrHandJoints joints;
    CHECK(test::allocations_during([&] { locator.locate(angles, &rate, kXrPositionValid, joints); }) == 0);
    // The reference: joints 0.1 ms before and after, in the test's own difference.
    constexpr double h = 1e-4;
    Angles before{}, after{};
    for (std::size_t d = 0; d < kDofCount; ++d) before[d] = angles[d] - rate[d] * h, after[d] = angles[d] + rate[d] * h;
    const XrJointLocations b = located(locator, before), a = located(locator, after);
    double worst_linear = 0.0, worst_angular = 0.0, fastest = 0.0;
    for (std::size_t j = 0; j < kXrJointCount; ++j) {
      const XrJointVelocity& v = joints.velocities[j];
      CHECK(v.velocity_flags == (kXrLinearVelocityValid | kXrAngularVelocityValid));
      const Eigen::Vector3d linear = (position(a[j]) - position(b[j])) / (2 * h);
      worst_linear =
          std::max(worst_linear, (Eigen::Vector3d(v.linear_velocity.x, v.linear_velocity.y, v.linear_velocity.z) - linear).norm());
      fastest = std::max(fastest, linear.norm());
      // Turning the joint by the angular velocity for h takes it from its orientation to the next.
      const Eigen::Vector3d w(v.angular_velocity.x, v.angular_velocity.y, v.angular_velocity.z);
      const Eigen::Matrix3d predicted =
          (w.norm() > 0 ? Eigen::AngleAxisd(w.norm() * 2 * h, w.normalized()).toRotationMatrix() : Eigen::Matrix3d::Identity()) *
          rotation(b[j]);
      worst_angular = std::max(worst_angular, (predicted - rotation(a[j])).cwiseAbs().maxCoeff() / (2 * h));
    }
    INFO("fastest joint " << fastest << " m/s");
    CHECK(fastest > 0.1);
    CHECK(worst_linear < 0.01 * fastest);
    CHECK(worst_angular < 0.05);  // rad/s
  }
  hand::XrHandJoints still;
  locator.locate(Angles{}, nullptr, kXrPositionValid, still);
  for (const auto& v : still.velocities) CHECK(v.velocity_flags == 0);
}
