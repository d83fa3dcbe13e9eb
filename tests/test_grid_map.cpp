#include <glovepose/grid/grid_map.hpp>
#include <glovepose/sensor/layout.hpp>

#include <doctest/doctest.h>

#include <limits>
#include <set>

#include "alloc_counter.hpp"

using namespace glovepose;
using namespace glovepose::grid;

TEST_CASE("grid: the pose map has fingers as rows and (abduction, base, middle, tip, twist) as columns") {
  const GridMap map = GridMap::glauser2019();
  // The paper groups the thumb as theta 9, 10, 11, 12, 29 (Sec. 4.2): its row, in column order.
  const int thumb[] = {9, 10, 11, 12, 29};
  const int index[] = {13, 14, 15, 16, 30};
  const int pinky[] = {25, 26, 27, 28, 33};
  for (int col = 0; col < 5; ++col) {
    CHECK(map.dof_slots()[hand::dof_from_theta(thumb[col])].flat() == 0 * 5 + col);
    CHECK(map.dof_slots()[hand::dof_from_theta(index[col])].flat() == 1 * 5 + col);
    CHECK(map.dof_slots()[hand::dof_from_theta(pinky[col])].flat() == 4 * 5 + col);
  }
  hand::Angles normalized{};
  for (std::size_t d = 0; d < hand::kDofCount; ++d) normalized[d] = -1.0 + 0.08 * static_cast<double>(d);
  std::array<float, kMapSlots> pose{};
  map.to_pose_map(normalized, pose);
  hand::Angles back{};
  map.from_pose_map(pose, back);
  for (std::size_t d = 0; d < hand::kDofCount; ++d) CHECK(back[d] == doctest::Approx(normalized[d]).epsilon(1e-6));
  CHECK(pose[1 * 5 + 1] == doctest::Approx(normalized[hand::dof_from_name("index_base_flexion")]));
}

TEST_CASE("grid: every cell of the paper's glove has its own stretch-map slot, consistent with its place") {
  const GridMap map = GridMap::glauser2019();
  const auto layout = sensor::TraceLayout::glauser2019();
  REQUIRE(map.cell_count() == layout.cell_count());
  std::set<int> used;
  for (int c = 0; c < 44; ++c) {
    const Slot s = map.cell_slots()[static_cast<std::size_t>(c)];
    const sensor::Cell& cell = layout.cells()[static_cast<std::size_t>(c)];
    INFO(layout.cell_name(c));
    used.insert(s.flat());
    CHECK(s.channel == (cell.direction == sensor::Direction::Along ? 0 : 1));  // along / across maps
    CHECK(s.row == static_cast<int>(cell.digit));                              // digit rows
    if (cell.category == sensor::Category::MainJoint) {                        // joints: proximal..distal columns
      const int expected_col = cell.segment == sensor::Segment::Proximal ? 2 : (cell.segment == sensor::Segment::Middle ? 3 : 4);
      CHECK(s.col == expected_col);
    }
  }
  CHECK(used.size() == 44);  // 50 slots, 6 empty
}

TEST_CASE("grid: cells scatter into the stretch maps, empty slots are zero, NaN is refused") {
  const GridMap map = GridMap::glauser2019();
  std::array<double, 44> cells{};
  for (int c = 0; c < 44; ++c) cells[static_cast<std::size_t>(c)] = 0.01 * (c + 1);
  std::array<float, kStretchValues> maps{};
  maps.fill(7.0f);
  REQUIRE(map.to_stretch_maps(cells.data(), maps) == Status::Ok);
  int nonzero = 0;
  for (float v : maps) nonzero += v != 0.0f;
  CHECK(nonzero == 44);
  CHECK(maps[static_cast<std::size_t>(Slot{0, 1, 2}.flat())] == doctest::Approx(0.22f));  // cell 21: index proximal, along
  CHECK(maps[static_cast<std::size_t>(Slot{1, 1, 4}.flat())] == doctest::Approx(0.44f));  // cell 43: index distal, across
  cells[5] = std::numeric_limits<double>::infinity();
  maps.fill(7.0f);
  CHECK(map.to_stretch_maps(cells.data(), maps) == Status::NonFinite);
  CHECK(maps[0] == 7.0f);  // untouched
  cells[5] = 0.0;
  CHECK(test::allocations_during([&] { (void)map.to_stretch_maps(cells.data(), maps); }) == 0);
}

TEST_CASE("grid: invalid tables are rejected, naming the cell or DoF") {
  const auto poses = GridMap::paper_pose_slots();
  CHECK_THROWS_WITH_AS(GridMap({{0, 0, 0}, {0, 0, 0}}, poses), doctest::Contains("cell 1 is placed on the slot of cell 0"), Error);
  CHECK_THROWS_WITH_AS(GridMap({{2, 0, 0}}, poses), doctest::Contains("cell 0 is placed at (channel 2, row 0, column 0)"), Error);
  CHECK_THROWS_WITH_AS(GridMap({{0, 5, 0}}, poses), doctest::Contains("expected channel 0..1 and row, column 0..4"), Error);
  auto bad = poses;
  bad[hand::dof_from_name("ring_base_twist")] = bad[hand::dof_from_name("ring_tip_flexion")];
  CHECK_THROWS_WITH_AS(GridMap({{0, 0, 0}}, bad), doctest::Contains("DoF ring_base_twist is placed on the slot of DoF ring_tip_flexion"),
                       Error);
}
