#include <glovepose/sensor/layout.hpp>

#include <doctest/doctest.h>

#include <set>

using namespace glovepose;
using namespace glovepose::sensor;

namespace {
std::set<int> cells_where(const TraceLayout& layout, bool (*pred)(const Cell&)) {
  std::set<int> out;
  for (int c = 0; c < layout.cell_count(); ++c)
    if (pred(layout.cells()[static_cast<std::size_t>(c)])) out.insert(c);
  return out;
}
}  // namespace

TEST_CASE("layout: the paper's glove has 15 x 12 traces, 44 cells, each trace pair at most once") {
  const TraceLayout layout = TraceLayout::glauser2019();
  CHECK(layout.bottom_traces() == 15);
  CHECK(layout.top_traces() == 12);
  CHECK(layout.row_count() == 180);
  CHECK(layout.cell_count() == 44);
  std::set<std::pair<int, int>> pairs;
  for (const Cell& c : layout.cells()) pairs.insert({c.bottom, c.top});
  CHECK(pairs.size() == 44);
  // Every trace carries at least one cell (27 leads, as the paper counts).
  std::set<int> bottoms, tops;
  for (const Cell& c : layout.cells()) {
    bottoms.insert(c.bottom);
    tops.insert(c.top);
  }
  CHECK(bottoms.size() == 15);
  CHECK(tops.size() == 12);
}

TEST_CASE("layout: cell categories and places follow the paper's Sec. 3.1 and Fig. 4") {
  const TraceLayout layout = TraceLayout::glauser2019();
  using S = std::set<int>;
  CHECK(cells_where(layout, [](const Cell& c) { return c.category == Category::MainJoint; }) ==
        S{0, 20, 21, 22, 23, 24, 32, 33, 34, 35, 36, 40, 41, 42});
  CHECK(cells_where(layout, [](const Cell& c) { return c.category == Category::Abduction; }) == S{16, 25, 26, 27});
  CHECK(cells_where(layout, [](const Cell& c) { return c.category == Category::Perpendicular; }) ==
        S{1, 8, 9, 28, 29, 30, 31, 37, 38, 39, 43});
  CHECK(cells_where(layout, [](const Cell& c) { return c.category == Category::BackOfHandGrid && c.direction == Direction::Across; }) ==
        S{2, 4, 7, 10, 17, 18, 19});
  CHECK(cells_where(layout, [](const Cell& c) { return c.category == Category::BackOfHandGrid && c.direction == Direction::Along; }) ==
        S{3, 5, 6, 11, 12, 13, 14, 15});
  // Main-joint cells sense stretch along the finger; perpendicular and abduction cells across.
  for (const Cell& c : layout.cells()) {
    if (c.category == Category::MainJoint) CHECK(c.direction == Direction::Along);
    if (c.category == Category::Perpendicular || c.category == Category::Abduction) CHECK(c.direction == Direction::Across);
  }
  // The thumb group (Sec. 4.2) and the index finger's joint and girth cells (Sec. 3.1, Fig. 15).
  CHECK(cells_where(layout, [](const Cell& c) { return c.digit == Finger::Thumb; }) == S{0, 1, 2, 11, 16, 20, 28});
  for (int c : {21, 33, 40, 29, 37, 43}) CHECK(layout.cells()[static_cast<std::size_t>(c)].digit == Finger::Index);
  CHECK(layout.cell_name(21) == "cell 21 (index proximal, along, main-joint)");
}

TEST_CASE("layout: M follows the source/ground model of the readout") {
  const TraceLayout layout = TraceLayout::glauser2019();
  const Eigen::MatrixXd m = layout.measurement_matrix();
  REQUIRE(m.rows() == 180);
  REQUIRE(m.cols() == 44);
  // Independent restatement: put 1 V on the two source traces and 0 V on the others; a cell adds
  // its capacitance to the measurement when the voltage across it is 1 V.
  for (int i = 0; i < 15; ++i)
    for (int j = 0; j < 12; ++j)
      for (int c = 0; c < 44; ++c) {
        const Cell& cell = layout.cells()[static_cast<std::size_t>(c)];
        const double v_bottom = cell.bottom == i ? 1.0 : 0.0;
        const double v_top = cell.top == j ? 1.0 : 0.0;
        CHECK(m(i * 12 + j, c) == std::abs(v_bottom - v_top));
      }
  // Each cell is seen by (12 - 1) + (15 - 1) = 25 measurements.
  for (int c = 0; c < 44; ++c) CHECK(m.col(c).sum() == 25.0);
}

TEST_CASE("layout: invalid descriptions are rejected with the cell named") {
  const Cell a{0, 0, Finger::Index, Segment::Proximal, Direction::Along, Category::MainJoint};
  Cell out_of_range = a;
  out_of_range.bottom = 3;
  CHECK_THROWS_WITH_AS(TraceLayout(3, 2, {a, out_of_range}), doctest::Contains("cell 1 uses bottom trace 3, expected 0..2"), Error);
  Cell bad_top = a;
  bad_top.top = -1;
  CHECK_THROWS_WITH_AS(TraceLayout(3, 2, {bad_top}), doctest::Contains("cell 0 uses top trace -1"), Error);
  CHECK_THROWS_WITH_AS(TraceLayout(3, 2, {a, a}), doctest::Contains("cell 1 reuses the trace pair (bottom 0, top 0)"), Error);
  CHECK_THROWS_WITH_AS(TraceLayout(0, 2, {a}), doctest::Contains("expected at least one of each"), Error);
  CHECK_THROWS_WITH_AS(TraceLayout(3, 2, {}), doctest::Contains("no cells"), Error);
  CHECK_THROWS_AS((void)TraceLayout::glauser2019().cell_name(44), Error);
}
