/// @file grid_map.hpp
/// @brief The paper's 2D data layout (Sec. 4.2, Fig. 8): sensor cells -> two 5x5 stretch maps, and
/// the 25 DoFs <-> one 5x5 pose map.
///
/// A glove's inputs that are not stretch cells (an IMU angle, a bend sensor over the wrist) have no
/// slot (kOffMaps): the networks that take the inputs as a vector (FCN, linear map) read them beside
/// the cells; the stretch maps do not hold them, and the U-Net reads each as one more input plane
/// of constant value (to_input_planes()).
///
/// Pose map: rows are the fingers (thumb, index, middle, ring, pinky), columns (abduction, base
/// flexion, middle flexion, tip flexion, twist), so the thumb's row holds theta 9, 10, 11, 12, 29 as
/// the paper groups them. Stretch maps: channel 0 holds the cells that sense stretch along the
/// fingers, channel 1 those across; rows are the digits, columns run from the wrist towards the
/// fingertip. Both tables are data: a glove with another layout supplies its own.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <string>
#include <vector>

#include "../config.hpp"
#include "../hand/dofs.hpp"
#include "../status.hpp"

namespace glovepose::grid {

/// @brief Side of the square maps.
inline constexpr int kGridSize = 5;
/// @brief Slots in one map.
inline constexpr int kMapSlots = kGridSize * kGridSize;
/// @brief Channels of the stretch-map input (along / across).
inline constexpr int kStretchChannels = 2;
/// @brief Values in the network input (2 x 5 x 5).
inline constexpr int kStretchValues = kStretchChannels * kMapSlots;

/// @brief A position in a stack of 5x5 maps.
struct Slot {
  int channel;  ///< Map index.
  int row;      ///< 0..4.
  int col;      ///< 0..4.
  /// @brief Flat index channel * 25 + row * 5 + col (channel-major, row-major: the tensor layout).
  constexpr int flat() const noexcept { return (channel * kGridSize + row) * kGridSize + col; }
  /// @brief False for an input that is not on the maps (kOffMaps).
  constexpr bool on_maps() const noexcept { return channel >= 0; }
};

/// @brief The "slot" of an input that is not on the stretch maps (an extra input).
inline constexpr Slot kOffMaps{-1, -1, -1};

/// @brief The two tables: where each sensor cell goes in the stretch maps and where each DoF goes in
/// the pose map. Validated on construction; the per-frame mappings never allocate.
class GridMap {
 public:
  /// @brief Custom tables; a cell at kOffMaps is an extra input. Throws glovepose::Error naming the
  /// cell or DoF when a slot is out of range or taken twice.
  GridMap(std::vector<Slot> cell_slots, std::array<Slot, hand::kDofCount> dof_slots)
      : cell_slots_(std::move(cell_slots)), dof_slots_(dof_slots) {
    if (cell_slots_.empty()) throw Error("GridMap: no cells, expected at least one");
    std::array<int, kStretchValues> owner{};
    owner.fill(-1);
    for (std::size_t c = 0; c < cell_slots_.size(); ++c) {
      const Slot& s = cell_slots_[c];
      if (s.channel == kOffMaps.channel && s.row == kOffMaps.row && s.col == kOffMaps.col) {
        ++extra_inputs_;
        continue;
      }
      check_slot(s, kStretchChannels, "cell " + std::to_string(c));
      if (owner[static_cast<std::size_t>(s.flat())] >= 0)
        throw Error("GridMap: cell " + std::to_string(c) + " is placed on the slot of cell " +
                    std::to_string(owner[static_cast<std::size_t>(s.flat())]) + ", expected one cell per slot");
      owner[static_cast<std::size_t>(s.flat())] = static_cast<int>(c);
    }
    std::array<int, kMapSlots> dof_owner{};
    dof_owner.fill(-1);
    for (std::size_t d = 0; d < hand::kDofCount; ++d) {
      const Slot& s = dof_slots_[d];
      check_slot(s, 1, std::string("DoF ") + hand::kDofs[d].name);
      if (dof_owner[static_cast<std::size_t>(s.flat())] >= 0)
        throw Error(std::string("GridMap: DoF ") + hand::kDofs[d].name + " is placed on the slot of DoF " +
                    hand::kDofs[static_cast<std::size_t>(dof_owner[static_cast<std::size_t>(s.flat())])].name +
                    ", expected one DoF per slot");
      dof_owner[static_cast<std::size_t>(s.flat())] = static_cast<int>(d);
    }
  }

  /// @brief The tables of the paper's 44-cell glove (see docs/sensor_layout.md for the reasoning).
  static GridMap glauser2019() {
    // Rows: thumb, index, middle, ring, pinky; -1: empty slot.
    // Along (ch 0), columns: metacarpal wrist side, metacarpal knuckle side, proximal, middle, distal.
    constexpr int along[kGridSize][kGridSize] = {
        {-1, 11, 0, 20, -1}, {3, 12, 21, 33, 40}, {5, 13, 22, 34, 41}, {6, 14, 23, 35, 42}, {-1, 15, 24, 36, 32}};
    // Across (ch 1), columns: web (abduction), metacarpal, proximal, middle, distal. Cell 17 (a
    // second back-of-hand cell of the middle finger) takes the middle finger's free distal slot.
    constexpr int across[kGridSize][kGridSize] = {
        {16, 2, 1, 28, -1}, {25, 4, 29, 37, 43}, {26, 7, 30, 38, 17}, {27, 19, 31, 39, -1}, {18, 10, 8, 9, -1}};
    std::vector<Slot> cells(44, Slot{-1, -1, -1});
    for (int r = 0; r < kGridSize; ++r)
      for (int c = 0; c < kGridSize; ++c) {
        if (along[r][c] >= 0) cells[static_cast<std::size_t>(along[r][c])] = Slot{0, r, c};
        if (across[r][c] >= 0) cells[static_cast<std::size_t>(across[r][c])] = Slot{1, r, c};
      }
    return GridMap(std::move(cells), paper_pose_slots());
  }

  /// @brief The pose-map table of the paper: row = finger, column = motion (hand::Motion).
  static std::array<Slot, hand::kDofCount> paper_pose_slots() noexcept {
    std::array<Slot, hand::kDofCount> slots{};
    for (std::size_t d = 0; d < hand::kDofCount; ++d)
      slots[d] = Slot{0, static_cast<int>(hand::kDofs[d].finger), static_cast<int>(hand::kDofs[d].motion)};
    return slots;
  }

  /// @brief Number of inputs a frame holds: the cells on the maps and the extra inputs.
  int cell_count() const noexcept { return static_cast<int>(cell_slots_.size()); }
  /// @brief Number of inputs that are not on the stretch maps (slot kOffMaps).
  int extra_input_count() const noexcept { return extra_inputs_; }
  /// @brief Planes of the U-Net's input: the two stretch maps, then one plane per extra input.
  int input_plane_count() const noexcept { return kStretchChannels + extra_inputs_; }
  /// @brief Slot of each cell in the stretch maps (kOffMaps for an extra input).
  const std::vector<Slot>& cell_slots() const noexcept { return cell_slots_; }
  /// @brief Slot of each DoF in the pose map.
  const std::array<Slot, hand::kDofCount>& dof_slots() const noexcept { return dof_slots_; }

  /// @brief Scatters `cell_count()` normalised cell values into the 2x5x5 stretch maps (channel,
  /// row, column order); empty slots become 0, extra inputs are not placed. Returns
  /// Status::NonFinite (maps untouched) if a value is NaN or infinite.
  template <typename Scalar>
  GLOVEPOSE_REALTIME Status to_stretch_maps(const Scalar* cells, std::array<float, kStretchValues>& maps) const noexcept {
    for (std::size_t c = 0; c < cell_slots_.size(); ++c)
      if (!std::isfinite(cells[c])) return Status::NonFinite;
    maps.fill(0.0f);
    for (std::size_t c = 0; c < cell_slots_.size(); ++c)
      if (cell_slots_[c].on_maps()) maps[static_cast<std::size_t>(cell_slots_[c].flat())] = static_cast<float>(cells[c]);
    return Status::Ok;
  }

  /// @brief The U-Net's input: the two stretch maps (as to_stretch_maps()) followed by one 5x5 plane
  /// per extra input, in input order, filled with that input's value, input_plane_count() x 25
  /// floats at `planes`. Returns Status::NonFinite (planes untouched) if a value is NaN or infinite.
  template <typename Scalar>
  GLOVEPOSE_REALTIME Status to_input_planes(const Scalar* cells, float* planes) const noexcept {
    for (std::size_t c = 0; c < cell_slots_.size(); ++c)
      if (!std::isfinite(cells[c])) return Status::NonFinite;
    std::fill(planes, planes + kStretchValues, 0.0f);
    float* extra = planes + kStretchValues;
    for (std::size_t c = 0; c < cell_slots_.size(); ++c) {
      const float value = static_cast<float>(cells[c]);
      if (cell_slots_[c].on_maps())
        planes[cell_slots_[c].flat()] = value;
      else
        extra = std::fill_n(extra, kMapSlots, value);
    }
    return Status::Ok;
  }

  /// @brief Places normalised DoF values into the 5x5 pose map (row-major); unused slots become 0.
  GLOVEPOSE_REALTIME void to_pose_map(const hand::Angles& normalized, std::array<float, kMapSlots>& map) const noexcept {
    map.fill(0.0f);
    for (std::size_t d = 0; d < hand::kDofCount; ++d)
      map[static_cast<std::size_t>(dof_slots_[d].flat())] = static_cast<float>(normalized[d]);
  }

  /// @brief Reads the normalised DoF values back out of a 5x5 pose map.
  GLOVEPOSE_REALTIME void from_pose_map(const std::array<float, kMapSlots>& map, hand::Angles& normalized) const noexcept {
    for (std::size_t d = 0; d < hand::kDofCount; ++d)
      normalized[d] = static_cast<double>(map[static_cast<std::size_t>(dof_slots_[d].flat())]);
  }

 private:
  static void check_slot(const Slot& s, int channels, const std::string& what) {
    if (s.channel < 0 || s.channel >= channels || s.row < 0 || s.row >= kGridSize || s.col < 0 || s.col >= kGridSize)
      throw Error("GridMap: " + what + " is placed at (channel " + std::to_string(s.channel) + ", row " + std::to_string(s.row) +
                  ", column " + std::to_string(s.col) + "), expected channel 0.." + std::to_string(channels - 1) + " and row, column 0.." +
                  std::to_string(kGridSize - 1));
  }

  std::vector<Slot> cell_slots_;
  std::array<Slot, hand::kDofCount> dof_slots_;
  int extra_inputs_ = 0;
};

}  // namespace glovepose::grid
