/// @file layout.hpp
/// @brief The glove's trace matrix: which pair of traces forms each sensor cell, where each cell
/// sits on the hand, and the measurement matrix M of the time-multiplexed readout.
///
/// The readout model (paper Sec. 3.1, after Glauser et al. 2019 "Deformation Capture via Soft and
/// Stretchable Sensor Arrays"): the sensor has `bottom` traces in one conductive layer and `top`
/// traces in the other; wherever a bottom and a top trace overlap, a capacitor ("cell") forms, and
/// each pair overlaps at most once. Measurement (i, j) connects bottom trace i and top trace j as
/// the source electrode and every other trace to ground, and measures the compound capacitance
/// between source and ground. A cell lies between its two traces, so it contributes exactly when one
/// of its traces is a source and the other is grounded:
///
///     M[(i, j), c] = 1  if (bottom(c) == i) XOR (top(c) == j),  else 0,
///     row index of (i, j) = i * top_traces + j.
///
/// A cell with both traces at the source has no voltage across it; one with both grounded neither.
/// The glove of the paper has 15 bottom and 12 top traces (180 measurements) and 44 cells.
///
/// The paper does not publish its exact layout: Fig. 4 shows the cells and Sec. 3.1 names their
/// categories (main-joint cells 0, 20, 21-24, 32-36, 40-42; abduction 16, 25-27; perpendicular 1,
/// 8-9, 28-31, 37-39, 43; back-of-hand grid, horizontal 2, 4, 7, 10, 17-19 and vertical 3, 5, 6,
/// 11-15), the thumb group (0, 1, 2, 11, 16, 20, 28) and the index finger's joint cells (21, 33, 40)
/// and girth cells (29, 37, 43). Which digit and segment every other cell sits on, and which trace
/// pair forms it, is our reading of Fig. 4, recorded in glauser2019() and in docs/sensor_layout.md;
/// the wiring only has to give M full column rank, which the solver checks. Any other glove is
/// described the same way through the TraceLayout constructor.
#pragma once

#include <algorithm>
#include <cstddef>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include "../config.hpp"
#include "../hand/dofs.hpp"

namespace glovepose::sensor {

using hand::Finger;

/// @brief Where along the digit a cell sits.
enum class Segment : unsigned char {
  Metacarpal,  ///< Back of the hand, over the digit's metacarpal.
  Web,         ///< Between this digit and the next one towards the pinky (abduction).
  Proximal,    ///< Over the base joint and proximal phalanx.
  Middle,      ///< Over the middle joint and middle phalanx.
  Distal,      ///< Over the tip joint and distal phalanx.
};

/// @brief The stretch a cell is most sensitive to (paper Fig. 4: dark / light green).
enum class Direction : unsigned char {
  Along,   ///< Along the finger ("vertical"): flexion.
  Across,  ///< Across the finger ("horizontal"): girth, abduction.
};

/// @brief The paper's Sec. 3.1 design stages.
enum class Category : unsigned char { MainJoint, Abduction, Perpendicular, BackOfHandGrid };

/// @brief One sensor cell: the overlap of one bottom and one top trace.
struct Cell {
  int bottom;           ///< Bottom-layer trace index, 0-based.
  int top;              ///< Top-layer trace index, 0-based.
  Finger digit;         ///< Place on the hand (back-of-hand cells: the digit whose metacarpal they cover).
  Segment segment;      ///< Place along the digit.
  Direction direction;  ///< Stretch direction it senses best.
  Category category;    ///< Design category.
};

/// @brief Lower-case name of a segment.
constexpr const char* to_string(Segment s) noexcept {
  constexpr const char* names[] = {"metacarpal", "web", "proximal", "middle", "distal"};  // in the enum's order
  return name_of(s, names, "unknown segment");
}
/// @brief Lower-case name of a direction.
constexpr const char* to_string(Direction d) noexcept { return d == Direction::Along ? "along" : "across"; }
/// @brief Lower-case name of a category.
constexpr const char* to_string(Category c) noexcept {
  constexpr const char* names[] = {"main-joint", "abduction", "perpendicular", "back-of-hand grid"};  // in the enum's order
  return name_of(c, names, "unknown category");
}

/// @brief A glove's trace matrix: trace counts and cells. Validated on construction.
class TraceLayout {
 public:
  /// @brief Describes a glove. Throws glovepose::Error naming the cell when a trace index is out of
  /// range or a trace pair is used twice, or when the counts are not positive.
  TraceLayout(int bottom_traces, int top_traces, std::vector<Cell> cells, std::string id = "custom")
      : bottom_traces_(bottom_traces), top_traces_(top_traces), cells_(std::move(cells)), id_(std::move(id)) {
    if (bottom_traces_ <= 0 || top_traces_ <= 0)
      throw Error("TraceLayout: " + std::to_string(bottom_traces_) + " bottom and " + std::to_string(top_traces_) +
                  " top traces, expected at least one of each");
    if (cells_.empty()) throw Error("TraceLayout: no cells, expected at least one");
    std::set<std::pair<int, int>> seen;
    for (std::size_t c = 0; c < cells_.size(); ++c) {
      const Cell& cell = cells_[c];
      if (cell.bottom < 0 || cell.bottom >= bottom_traces_)
        throw Error("TraceLayout: cell " + std::to_string(c) + " uses bottom trace " + std::to_string(cell.bottom) + ", expected 0.." +
                    std::to_string(bottom_traces_ - 1));
      if (cell.top < 0 || cell.top >= top_traces_)
        throw Error("TraceLayout: cell " + std::to_string(c) + " uses top trace " + std::to_string(cell.top) + ", expected 0.." +
                    std::to_string(top_traces_ - 1));
      if (!seen.insert({cell.bottom, cell.top}).second)
        throw Error("TraceLayout: cell " + std::to_string(c) + " reuses the trace pair (bottom " + std::to_string(cell.bottom) + ", top " +
                    std::to_string(cell.top) + "), expected each pair of traces to overlap at most once");
    }
  }

  /// @brief The 44-cell glove of Glauser et al. 2019 (15 bottom, 12 top traces), as we read Fig. 4.
  static TraceLayout glauser2019();

  /// @brief Identifier of the layout (stored with calibrations and models).
  const std::string& id() const noexcept { return id_; }
  /// @brief Number of bottom-layer traces.
  int bottom_traces() const noexcept { return bottom_traces_; }
  /// @brief Number of top-layer traces.
  int top_traces() const noexcept { return top_traces_; }
  /// @brief Number of measurements (rows of M): one per (bottom, top) source pair.
  int row_count() const noexcept { return bottom_traces_ * top_traces_; }
  /// @brief Number of cells (columns of M).
  int cell_count() const noexcept { return static_cast<int>(cells_.size()); }
  /// @brief The cells, by cell id.
  const std::vector<Cell>& cells() const noexcept { return cells_; }

  /// @brief Row of M measured with bottom trace `bottom` and top trace `top` as the source.
  int row_index(int bottom, int top) const noexcept { return bottom * top_traces_ + top; }

  /// @brief The measurement matrix M (row_count x cell_count), entries 0 or 1 (see the file comment).
  Eigen::MatrixXd measurement_matrix() const {
    Eigen::MatrixXd m = Eigen::MatrixXd::Zero(row_count(), cell_count());
    for (int i = 0; i < bottom_traces_; ++i)
      for (int j = 0; j < top_traces_; ++j)
        for (int c = 0; c < cell_count(); ++c) {
          const Cell& cell = cells_[static_cast<std::size_t>(c)];
          if ((cell.bottom == i) != (cell.top == j)) m(row_index(i, j), c) = 1.0;
        }
    return m;
  }

  /// @brief Readable name of a cell, e.g. "cell 21 (index proximal, along, main-joint)".
  std::string cell_name(int c) const {
    if (c < 0 || c >= cell_count())
      throw Error("TraceLayout::cell_name: cell " + std::to_string(c) + ", expected 0.." + std::to_string(cell_count() - 1));
    const Cell& cell = cells_[static_cast<std::size_t>(c)];
    return "cell " + std::to_string(c) + " (" + to_string(cell.digit) + " " + to_string(cell.segment) + ", " + to_string(cell.direction) +
           ", " + to_string(cell.category) + ")";
  }

  /// @brief cell_name() of every cell, in cell order.
  std::vector<std::string> cell_names() const {
    std::vector<std::string> names;
    for (int c = 0; c < cell_count(); ++c) names.push_back(cell_name(c));
    return names;
  }

 private:
  int bottom_traces_;
  int top_traces_;
  std::vector<Cell> cells_;
  std::string id_;
};

/// @brief Rows (measurements) of the paper's glove: 15 bottom x 12 top traces.
inline constexpr int kGlauser2019Rows = 180;
/// @brief Cells of the paper's glove.
inline constexpr int kGlauser2019Cells = 44;

inline TraceLayout TraceLayout::glauser2019() {
  // Cell id = the paper's Fig. 4 number. Trace pairs: our wiring (bottom = id mod 15,
  // top = (id + 5 * (id div 15)) mod 12), which uses every trace, no pair twice, 2-3 cells per
  // bottom and 3-4 per top trace, and gives M full rank (condition number: see tests/test_solver.cpp).
  return TraceLayout(15, 12,
                     {
                         {0, 0, Finger::Thumb, Segment::Proximal, Direction::Along, Category::MainJoint},            // 0
                         {1, 1, Finger::Thumb, Segment::Proximal, Direction::Across, Category::Perpendicular},       // 1
                         {2, 2, Finger::Thumb, Segment::Metacarpal, Direction::Across, Category::BackOfHandGrid},    // 2
                         {3, 3, Finger::Index, Segment::Metacarpal, Direction::Along, Category::BackOfHandGrid},     // 3
                         {4, 4, Finger::Index, Segment::Metacarpal, Direction::Across, Category::BackOfHandGrid},    // 4
                         {5, 5, Finger::Middle, Segment::Metacarpal, Direction::Along, Category::BackOfHandGrid},    // 5
                         {6, 6, Finger::Ring, Segment::Metacarpal, Direction::Along, Category::BackOfHandGrid},      // 6
                         {7, 7, Finger::Middle, Segment::Metacarpal, Direction::Across, Category::BackOfHandGrid},   // 7
                         {8, 8, Finger::Pinky, Segment::Proximal, Direction::Across, Category::Perpendicular},       // 8
                         {9, 9, Finger::Pinky, Segment::Middle, Direction::Across, Category::Perpendicular},         // 9
                         {10, 10, Finger::Pinky, Segment::Metacarpal, Direction::Across, Category::BackOfHandGrid},  // 10
                         {11, 11, Finger::Thumb, Segment::Metacarpal, Direction::Along, Category::BackOfHandGrid},   // 11
                         {12, 0, Finger::Index, Segment::Metacarpal, Direction::Along, Category::BackOfHandGrid},    // 12
                         {13, 1, Finger::Middle, Segment::Metacarpal, Direction::Along, Category::BackOfHandGrid},   // 13
                         {14, 2, Finger::Ring, Segment::Metacarpal, Direction::Along, Category::BackOfHandGrid},     // 14
                         {0, 8, Finger::Pinky, Segment::Metacarpal, Direction::Along, Category::BackOfHandGrid},     // 15
                         {1, 9, Finger::Thumb, Segment::Web, Direction::Across, Category::Abduction},                // 16
                         {2, 10, Finger::Middle, Segment::Metacarpal, Direction::Across, Category::BackOfHandGrid},  // 17
                         {3, 11, Finger::Pinky, Segment::Metacarpal, Direction::Across, Category::BackOfHandGrid},   // 18
                         {4, 0, Finger::Ring, Segment::Metacarpal, Direction::Across, Category::BackOfHandGrid},     // 19
                         {5, 1, Finger::Thumb, Segment::Middle, Direction::Along, Category::MainJoint},              // 20
                         {6, 2, Finger::Index, Segment::Proximal, Direction::Along, Category::MainJoint},            // 21
                         {7, 3, Finger::Middle, Segment::Proximal, Direction::Along, Category::MainJoint},           // 22
                         {8, 4, Finger::Ring, Segment::Proximal, Direction::Along, Category::MainJoint},             // 23
                         {9, 5, Finger::Pinky, Segment::Proximal, Direction::Along, Category::MainJoint},            // 24
                         {10, 6, Finger::Index, Segment::Web, Direction::Across, Category::Abduction},               // 25
                         {11, 7, Finger::Middle, Segment::Web, Direction::Across, Category::Abduction},              // 26
                         {12, 8, Finger::Ring, Segment::Web, Direction::Across, Category::Abduction},                // 27
                         {13, 9, Finger::Thumb, Segment::Middle, Direction::Across, Category::Perpendicular},        // 28
                         {14, 10, Finger::Index, Segment::Proximal, Direction::Across, Category::Perpendicular},     // 29
                         {0, 4, Finger::Middle, Segment::Proximal, Direction::Across, Category::Perpendicular},      // 30
                         {1, 5, Finger::Ring, Segment::Proximal, Direction::Across, Category::Perpendicular},        // 31
                         {2, 6, Finger::Pinky, Segment::Distal, Direction::Along, Category::MainJoint},              // 32
                         {3, 7, Finger::Index, Segment::Middle, Direction::Along, Category::MainJoint},              // 33
                         {4, 8, Finger::Middle, Segment::Middle, Direction::Along, Category::MainJoint},             // 34
                         {5, 9, Finger::Ring, Segment::Middle, Direction::Along, Category::MainJoint},               // 35
                         {6, 10, Finger::Pinky, Segment::Middle, Direction::Along, Category::MainJoint},             // 36
                         {7, 11, Finger::Index, Segment::Middle, Direction::Across, Category::Perpendicular},        // 37
                         {8, 0, Finger::Middle, Segment::Middle, Direction::Across, Category::Perpendicular},        // 38
                         {9, 1, Finger::Ring, Segment::Middle, Direction::Across, Category::Perpendicular},          // 39
                         {10, 2, Finger::Index, Segment::Distal, Direction::Along, Category::MainJoint},             // 40
                         {11, 3, Finger::Middle, Segment::Distal, Direction::Along, Category::MainJoint},            // 41
                         {12, 4, Finger::Ring, Segment::Distal, Direction::Along, Category::MainJoint},              // 42
                         {13, 5, Finger::Index, Segment::Distal, Direction::Across, Category::Perpendicular},        // 43
                     },
                     "glauser2019-44");
}

}  // namespace glovepose::sensor
