#include <glovepose/hand/collision.hpp>

#include <doctest/doctest.h>

#include <random>

using namespace glovepose;
using namespace glovepose::hand;

namespace {
double energy_of(const Angles& a) {
  static const Kinematics fk;
  Skeleton s;
  fk.pose(a, s);
  return collision_energy(fk, s);
}
}  // namespace

TEST_CASE("collision: closest distance between segments matches brute-force sampling") {
  std::mt19937 rng(4);
  std::uniform_real_distribution<double> u(-10.0, 10.0);
  for (int trial = 0; trial < 300; ++trial) {
    const Eigen::Vector3d p0(u(rng), u(rng), u(rng)), p1(u(rng), u(rng), u(rng)), q0(u(rng), u(rng), u(rng));
    Eigen::Vector3d q1(u(rng), u(rng), u(rng));
    if (trial % 10 == 0) q1 = q0 + (p1 - p0);  // parallel segments
    double best = 1e300;
    for (int i = 0; i <= 400; ++i)
      for (int j = 0; j <= 400; j += 1) {
        const double s = i / 400.0, t = j / 400.0;
        best = std::min(best, ((p0 + s * (p1 - p0)) - (q0 + t * (q1 - q0))).squaredNorm());
      }
    const double exact = segment_distance_squared(p0, p1, q0, q1);
    CHECK(exact <= best + 1e-9);
    CHECK(std::sqrt(best) - std::sqrt(exact) < 0.06);  // sampling at 1/400 of a ~20 mm segment
  }
  CHECK(segment_distance_squared({0, 0, 0}, {0, 0, 0}, {3, 4, 0}, {3, 4, 0}) == doctest::Approx(25.0));
}

TEST_CASE("collision: the rest pose and a spread hand are collision-free, fingers pushed into each other are outliers") {
  // At rest two capsules graze by about 0.1 mm (the template's 6-digit rest pose): far below 80.
  CHECK(energy_of(Angles{}) < 0.1);
  // Positive abduction turns every finger towards the thumb (+x: the base frames' x axis is
  // flipped), so a spread hand is index +, ring and pinky -.
  Angles spread{};
  spread[dof_from_name("index_base_abduction")] = 0.3;
  spread[dof_from_name("ring_base_abduction")] = -0.1;
  spread[dof_from_name("pinky_base_abduction")] = -0.2;
  CHECK(energy_of(spread) < 0.1);
  // A pinky turned fully towards the ring finger (its upper limit) collides.
  Angles pinky_in{};
  pinky_in[dof_from_name("pinky_base_abduction")] = 0.65;
  CHECK(energy_of(pinky_in) > kCollisionOutlierThreshold);
  // Index swung over the middle finger and middle over the index: their capsules interpenetrate.
  Angles crossed{};
  crossed[dof_from_name("index_base_abduction")] = -0.30;
  crossed[dof_from_name("middle_base_abduction")] = 0.40;
  const double e = energy_of(crossed);
  MESSAGE("crossed index and middle: collision energy " << e << " mm^2");
  CHECK(e > kCollisionOutlierThreshold);
  // Energy grows as the fingers cross further.
  Angles half{};
  half[dof_from_name("index_base_abduction")] = -0.15;
  half[dof_from_name("middle_base_abduction")] = 0.20;
  CHECK(energy_of(half) < e);
}
