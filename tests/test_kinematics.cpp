#include <glovepose/hand/kinematics.hpp>

#include <doctest/doctest.h>

#include "alloc_counter.hpp"
#include "reference/hmodel_template.hpp"

using namespace glovepose;
using namespace glovepose::hand;

namespace {
Eigen::Vector3d origin(const Skeleton& s, Phalanx p) { return s[static_cast<std::size_t>(p)].translation(); }
}  // namespace

TEST_CASE("kinematics: the typed-in rest matrices equal the template's I.txt") {
  static_assert(test::hmodel::kRestPose.size() == 16 * kPhalanxCount);
  const HandModel model = HandModel::reference();
  for (std::size_t p = 0; p < kPhalanxCount; ++p) {
    const Eigen::Map<const Eigen::Matrix4d> reference(&test::hmodel::kRestPose[16 * p]);  // column-major, like Eigen
    INFO("phalanx " << p);
    CHECK((model.rest[p].matrix() - reference).cwiseAbs().maxCoeff() < 1e-12);
  }
}

TEST_CASE("kinematics: the zero pose reproduces the rest pose and the template's sphere centres") {
  const Kinematics fk;
  Skeleton skeleton;
  fk.pose(Angles{}, skeleton);
  // Zero pose == chained rest transforms.
  const HandModel& model = fk.model();
  for (int p : kChainOrder) {
    const auto i = static_cast<std::size_t>(p);
    const Eigen::Affine3d expected = kParent[i] < 0 ? model.rest[i] : skeleton[static_cast<std::size_t>(kParent[i])] * model.rest[i];
    CHECK((skeleton[i].matrix() - expected.matrix()).cwiseAbs().maxCoeff() < 1e-12);
  }
  // Finger base positions of the template's rest pose (I.txt).
  CHECK((origin(skeleton, Phalanx::Index1) - Eigen::Vector3d(25.396, 50.819, 5.287)).norm() < 1e-3);
  CHECK((origin(skeleton, Phalanx::Thumb1) - Eigen::Vector3d(9.726, 3.872, -7.160)).norm() < 1e-3);

  // Independent check: the template's sphere centres (C.txt) sit on the joints of the rest pose.
  // Per finger, C lists tip end, tip joint, middle joint, base joint; fingers pinky, ring, middle,
  // index, thumb (centres 0..19). The tip-end sphere lies at the distal length from the tip joint
  // but about 5 degrees off the bone's +Y axis, so for it only the distance is compared.
  const auto& c = test::hmodel::kSphereCentres;
  const Finger order[] = {Finger::Pinky, Finger::Ring, Finger::Middle, Finger::Index, Finger::Thumb};
  for (int k = 0; k < 5; ++k) {
    const auto base = static_cast<std::size_t>(kFingerBase[static_cast<std::size_t>(order[k])]);
    const Eigen::Vector3d points[4] = {fk.fingertip(skeleton, order[k]), skeleton[base + 2].translation(), skeleton[base + 1].translation(),
                                       skeleton[base].translation()};
    Eigen::Vector3d centres[4];
    for (int j = 0; j < 4; ++j) {
      const auto at = static_cast<std::size_t>(3 * (4 * k + j));
      centres[j] = Eigen::Vector3d(c[at], c[at + 1], c[at + 2]);
    }
    INFO("finger row " << k);
    for (int j = 1; j < 4; ++j) CHECK((points[j] - centres[j]).norm() < 0.01);  // mm; the file has 6 digits
    CHECK((centres[0] - centres[1]).norm() == doctest::Approx((points[0] - points[1]).norm()).epsilon(1e-3));
  }
}

TEST_CASE("kinematics: a flexion moves exactly that joint's descendants") {
  const Kinematics fk;
  Skeleton rest, bent;
  fk.pose(Angles{}, rest);
  Angles angles{};
  angles[dof_from_name("index_middle_flexion")] = 1.2;
  fk.pose(angles, bent);
  for (std::size_t p = 0; p < kPhalanxCount; ++p) {
    const double moved = (bent[p].matrix() - rest[p].matrix()).cwiseAbs().maxCoeff();
    INFO("phalanx " << p);
    if (p == static_cast<std::size_t>(Phalanx::Index2) || p == static_cast<std::size_t>(Phalanx::Index3))
      CHECK(moved > 0.1);
    else
      CHECK(moved == 0.0);
  }
  // The joint's own position stays; its bone swings by the angle about the local X axis.
  CHECK((origin(bent, Phalanx::Index2) - origin(rest, Phalanx::Index2)).norm() == doctest::Approx(0.0));
  const Eigen::Vector3d bone_rest = rest[static_cast<std::size_t>(Phalanx::Index2)].linear().col(1);
  const Eigen::Vector3d bone_bent = bent[static_cast<std::size_t>(Phalanx::Index2)].linear().col(1);
  CHECK(std::acos(bone_rest.dot(bone_bent)) == doctest::Approx(1.2).epsilon(1e-6));
  // Flexion shortens the tip's distance to the palm origin (the finger curls).
  CHECK(fk.fingertip(bent, Finger::Index).norm() < fk.fingertip(rest, Finger::Index).norm());
}

TEST_CASE("kinematics: rotation order is flexion, then abduction, then twist (reference tracker)") {
  const Kinematics fk;
  Angles a{};
  a[dof_from_name("index_base_flexion")] = 0.7;
  a[dof_from_name("index_base_abduction")] = 0.3;
  a[dof_from_name("index_base_twist")] = -0.4;
  Skeleton s;
  fk.pose(a, s);
  const Eigen::Affine3d expected = fk.model().rest[static_cast<std::size_t>(Phalanx::Index1)] *
                                   Eigen::AngleAxisd(0.7, Eigen::Vector3d::UnitX()) * Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitZ()) *
                                   Eigen::AngleAxisd(-0.4, Eigen::Vector3d::UnitY());
  CHECK((s[static_cast<std::size_t>(Phalanx::Index1)].matrix() - expected.matrix()).cwiseAbs().maxCoeff() < 1e-12);
}

TEST_CASE("kinematics: posing allocates nothing") {
  const Kinematics fk;
  Skeleton s;
  Angles a{};
  a.fill(0.3);
  CHECK(test::allocations_during([&] { fk.pose(a, s); }) == 0);
}
