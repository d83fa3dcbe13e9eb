#include <glovepose/hand/finger_curls.hpp>
#include <glovepose/hand/kinematics.hpp>

#include <doctest/doctest.h>

#include <cmath>

using namespace glovepose;
using namespace glovepose::hand;

namespace {
// The DoF of `finger` doing `motion`, found by name (hand/dofs.hpp's names), not through dof_of.
std::size_t curl_dof(const char* finger, const char* motion) { return dof_from_name(std::string(finger) + "_" + motion); }
const char* const kCurlFingerNames[kFingerCount] = {"thumb", "index", "middle", "ring", "pinky"};
}  // namespace

TEST_CASE("finger curls: a flexion at its upper limit curls 1, straight or bent back 0, linear between") {
  const JointLimits limits;
  for (std::size_t f = 0; f < kFingerCount; ++f) {
    INFO(kCurlFingerNames[f]);
    const std::size_t base = curl_dof(kCurlFingerNames[f], "base_flexion"), middle = curl_dof(kCurlFingerNames[f], "middle_flexion"),
                      tip = curl_dof(kCurlFingerNames[f], "tip_flexion");
    Angles a{};
    a[base] = kDofs[base].max;          // fully bent: 1
    a[middle] = 0.25 * kDofs[middle].max;  // a quarter of the way
    a[tip] = -0.05;                     // bent back: 0
    const FingerCurls c = finger_curls(a, limits);
    const std::size_t first = f == 0 ? 0 : 1;  // OpenGloves: a finger's joint 0 is its metacarpal
    CHECK(c.joints[f][first] == doctest::Approx(1.0));
    CHECK(c.joints[f][first + 1] == doctest::Approx(0.25));
    CHECK(c.joints[f][first + 2] == 0.0);
    CHECK(c.joints[f][f == 0 ? 3 : 0] == (f == 0 ? c.joints[f][2] : 0.0));
    CHECK(c.curl[f] == doctest::Approx((1.0 + 0.25 + 0.0) / 3.0));
    CHECK(c.splay[f] == 0.0);
    a[base] = 3.0;  // beyond the limit: clamped
    CHECK(finger_curls(a, limits).joints[f][first] == 1.0);
  }
}

TEST_CASE("finger curls: splay is the abduction over 20 degrees, clamped, its sign toward the thumb") {
  const double degree = 3.14159265358979323846 / 180.0;
  for (std::size_t f = 0; f < kFingerCount; ++f) {
    INFO(kCurlFingerNames[f]);
    Angles a{};
    const std::size_t abduction = curl_dof(kCurlFingerNames[f], "base_abduction");
    a[abduction] = 10.0 * degree;
    CHECK(finger_curls(a).splay[f] == doctest::Approx(0.5));
    a[abduction] = -5.0 * degree;
    CHECK(finger_curls(a).splay[f] == doctest::Approx(-0.25));
    a[abduction] = 30.0 * degree;
    CHECK(finger_curls(a).splay[f] == 1.0);
    a[abduction] = -30.0 * degree;
    CHECK(finger_curls(a).splay[f] == -1.0);
  }
  // Toward the thumb: a positive abduction moves a finger's tip across the hand toward the thumb's side.
  const Kinematics kinematics;
  Skeleton rest, turned;
  kinematics.pose(Angles{}, rest);
  const Eigen::Vector3d across = kinematics.fingertip(rest, Finger::Index) - kinematics.fingertip(rest, Finger::Pinky);  // pinky to index
  for (std::size_t f = 1; f < kFingerCount; ++f) {
    INFO(kCurlFingerNames[f]);
    Angles a{};
    a[curl_dof(kCurlFingerNames[f], "base_abduction")] = 10.0 * degree;
    kinematics.pose(a, turned);
    const auto finger = static_cast<Finger>(f);
    CHECK((kinematics.fingertip(turned, finger) - kinematics.fingertip(rest, finger)).dot(across) > 0.0);
    CHECK(finger_curls(a).splay[f] > 0.0);
  }
}

TEST_CASE("finger curls: a model's own limits set what fully bent means") {
  Angles min{}, max{};
  for (std::size_t d = 0; d < kDofCount; ++d) {
    min[d] = -1.0;
    max[d] = 2.0;
  }
  Angles a{};
  a[curl_dof("ring", "tip_flexion")] = 1.0;
  CHECK(finger_curls(a, JointLimits(min, max)).joints[3][3] == doctest::Approx(0.5));
  CHECK(finger_curls(a).joints[3][3] == doctest::Approx(1.0 / kDofs[curl_dof("ring", "tip_flexion")].max));
}
