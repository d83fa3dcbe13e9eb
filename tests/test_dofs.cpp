#include <glovepose/hand/dofs.hpp>

#include <doctest/doctest.h>

#include <set>
#include <string>

#include "reference/hmodel_template.hpp"

using namespace glovepose;
using namespace glovepose::hand;

TEST_CASE("dofs: the 25 DoFs are theta 9..33 in order, with unique names") {
  std::set<std::string> names;
  for (std::size_t i = 0; i < kDofCount; ++i) {
    CHECK(kDofs[i].theta == static_cast<int>(i) + 9);
    CHECK(dof_from_theta(kDofs[i].theta) == i);
    CHECK(dof_from_name(kDofs[i].name) == i);
    names.insert(kDofs[i].name);
    CHECK(kDofs[i].min < kDofs[i].max);
  }
  CHECK(names.size() == kDofCount);
  CHECK_THROWS_WITH_AS(dof_from_theta(8), doctest::Contains("expected 9..33"), Error);
  CHECK_THROWS_WITH_AS(dof_from_name("wrist_flexion"), doctest::Contains("unknown DoF 'wrist_flexion'"), Error);
}

TEST_CASE("dofs: limits, axes and phalanxes equal the hand model's published parameters") {
  for (const test::hmodel::FingerParameter& reference : test::hmodel::kFingerParameters) {
    const Dof& dof = kDofs[dof_from_theta(reference.theta)];
    INFO("theta " << reference.theta << " (" << reference.name << ")");
    CHECK(std::string(reference.name) == dof.name);
    CHECK(reference.phalanx == dof.phalanx);
    const char axis = dof.axis == Axis::X ? 'X' : (dof.axis == Axis::Y ? 'Y' : 'Z');
    CHECK(axis == reference.axis);
    CHECK(reference.min == doctest::Approx(dof.min).epsilon(1e-12));
    CHECK(reference.max == doctest::Approx(dof.max).epsilon(1e-12));
  }
}

TEST_CASE("dofs: normalisation maps the limits to -1 and +1 and back") {
  const JointLimits limits;
  Angles at_min = limits.min(), at_max = limits.max(), mid{};
  for (std::size_t i = 0; i < kDofCount; ++i) mid[i] = 0.5 * (at_min[i] + at_max[i]);
  const Angles n_min = limits.normalize(at_min), n_max = limits.normalize(at_max), n_mid = limits.normalize(mid);
  for (std::size_t i = 0; i < kDofCount; ++i) {
    CHECK(n_min[i] == doctest::Approx(-1.0));
    CHECK(n_max[i] == doctest::Approx(1.0));
    CHECK(n_mid[i] == doctest::Approx(0.0));
  }
  // Round trip, including values beyond the limits (not clamped).
  Angles a{};
  for (std::size_t i = 0; i < kDofCount; ++i) a[i] = -2.0 + 0.17 * static_cast<double>(i);
  const Angles back = limits.denormalize(limits.normalize(a));
  for (std::size_t i = 0; i < kDofCount; ++i) CHECK(back[i] == doctest::Approx(a[i]).epsilon(1e-12));
  // Index base flexion, [-1.3, 1.6]: 0 rad -> 2 * 1.3 / 2.9 - 1.
  CHECK(limits.normalize(Angles{})[dof_from_name("index_base_flexion")] == doctest::Approx(2.0 * 1.3 / 2.9 - 1.0));
  const Angles clamped = limits.clamp(a);
  for (std::size_t i = 0; i < kDofCount; ++i) {
    CHECK(clamped[i] >= limits.min()[i]);
    CHECK(clamped[i] <= limits.max()[i]);
  }
}

TEST_CASE("dofs: custom limits are validated and name the DoF") {
  Angles lo = JointLimits().min(), hi = JointLimits().max();
  hi[dof_from_name("ring_tip_flexion")] = lo[dof_from_name("ring_tip_flexion")];
  CHECK_THROWS_WITH_AS(JointLimits(lo, hi), doctest::Contains("ring_tip_flexion"), Error);
  hi = JointLimits().max();
  lo[0] = std::numeric_limits<double>::quiet_NaN();
  CHECK_THROWS_WITH_AS(JointLimits(lo, hi), doctest::Contains("thumb_base_abduction"), Error);
}
