/// @file faults.hpp
/// @brief Faults of a glove's row stream, injected into clean readings: what the tests
/// (tests/test_faults.cpp) and the soak run (tools/soak/soak.hpp, `glovepose soak`) feed the estimator to
/// prove it meets them. sensor/readout.hpp says how the readout detects and survives each one.
///
/// A FaultInjector is one fault of one kind, active for as long as the caller passes readings
/// through it: each clean reading (row, value, timestamp) comes out as zero, one or two readings.
/// Random choices come from a seeded core::Rng, so a seed gives the same faulty stream everywhere.
/// Faults with a rate (drops, spikes, NaN/Inf) hit one reading in every block of N, at a random
/// place in the block: the rate is exact and hits never cluster (at most two in a row), so a test
/// can rely on every readout interval of more than 2N readings seeing one.
/// apply() is noexcept and allocation-free (it runs inside the soak's per-frame loop).
#pragma once

#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <string>

#include "../config.hpp"
#include "../sensor/layout.hpp"
#include "../core/random.hpp"

namespace glovepose::sim {

/// @brief One reading of one measurement row, as the glove delivers it.
struct Reading {
  int row = 0;             ///< Measurement row (sensor::TraceLayout::row_index).
  double value = 0.0;      ///< Compound capacitance C_m, pF.
  double timestamp = 0.0;  ///< Seconds, the glove's clock.
};

/// @brief The faults of a row stream.
enum class FaultKind : std::uint8_t {
  DroppedRows,        ///< One reading in FaultSettings::drop_one_in is lost (packets lost on the link).
  LostTraceBurst,     ///< Every row of one bottom trace is lost (a failing connector or multiplexer channel).
  DuplicatedRows,     ///< Every reading arrives twice.
  OutOfOrderRows,     ///< Readings arrive in swapped pairs, the later one first (the earlier is then out of order).
  StuckSensor,        ///< One row repeats its first finite reading of the fault.
  DisconnectedTrace,  ///< Every row of one top trace reads stray capacitance only (FaultSettings::disconnected_pf).
  Spikes,             ///< One reading in FaultSettings::spike_one_in jumps by FaultSettings::spike_pf.
  NonFiniteValues,    ///< One reading in FaultSettings::non_finite_one_in is NaN or infinite (half each).
  Unplugged,          ///< Nothing arrives: a gap in the stream as long as the fault.
  ClockJumpForward,   ///< The clock runs FaultSettings::clock_jump_seconds ahead: a jump forward at the start, back at the end.
  ClockJumpBack,      ///< The clock runs FaultSettings::clock_jump_seconds behind: a jump back at the start, forward at the end.
};

/// @brief Number of FaultKind values (they are numbered 0 .. kFaultKindCount - 1).
inline constexpr int kFaultKindCount = 11;

/// @brief A short, stable name of a fault kind (for reports).
constexpr const char* to_string(FaultKind kind) noexcept {
  constexpr const char* names[] = {"dropped rows",    "lost trace burst",   "duplicated rows", "out-of-order rows",
                                   "stuck sensor",    "disconnected trace", "spikes",          "NaN/Inf values",
                                   "unplugged (gap)", "clock jump forward", "clock jump back"};  // in the enum's order
  static_assert(sizeof names / sizeof names[0] == kFaultKindCount, "one name per fault kind");
  return name_of(kind, names, "unknown fault");
}

/// @brief The size and target of a fault (only the fields of its kind are used).
struct FaultSettings {
  int drop_one_in = 5;                ///< DroppedRows: one reading in this many is lost.
  int lost_bottom_trace = 2;          ///< LostTraceBurst: the bottom trace whose rows are lost.
  int stuck_row = 50;                 ///< StuckSensor: the row that sticks.
  int disconnected_top_trace = 4;     ///< DisconnectedTrace: the top trace that opens.
  double disconnected_pf = 0.05;      ///< DisconnectedTrace: what its rows read (stray capacitance), pF.
  int spike_one_in = 500;             ///< Spikes: one reading in this many spikes.
  double spike_pf = 30.0;             ///< Spikes: added to a spiking reading, pF.
  int non_finite_one_in = 10;         ///< NonFiniteValues: one reading in this many is NaN or infinite.
  double clock_jump_seconds = 100.0;  ///< ClockJump*: how far the clock is off during the fault, s.
};

/// @brief What one clean reading becomes: zero, one or two readings, in delivery order.
class InjectedReadings {
 public:
  /// @brief The most readings one clean reading can become (a duplicate, or a swapped pair).
  static constexpr std::size_t kCapacity = 2;
  /// @brief Appends a reading (ignored beyond kCapacity, which no fault reaches).
  void push_back(const Reading& reading) noexcept {
    if (size_ < kCapacity) items_[size_++] = reading;
  }
  /// @brief Number of readings.
  std::size_t size() const noexcept { return size_; }
  /// @brief Whether the clean reading was lost.
  bool empty() const noexcept { return size_ == 0; }
  /// @brief The readings, for range-for.
  const Reading* begin() const noexcept { return items_.data(); }
  /// @brief End of the readings.
  const Reading* end() const noexcept { return items_.data() + size_; }

 private:
  std::array<Reading, kCapacity> items_{};
  std::size_t size_ = 0;
};

/// @brief One fault of one kind over a stream of clean readings (see the file comment).
class FaultInjector {
 public:
  /// @brief A fault of `kind` on a glove wired as `layout`, its random choices seeded by `seed`.
  /// Throws glovepose::Error when a rate is below one in one, a target row or trace does not exist
  /// in `layout`, or a size is not finite.
  FaultInjector(FaultKind kind, const sensor::TraceLayout& layout, std::uint64_t seed, FaultSettings settings = {})
      : kind_(kind), settings_(settings), rng_(seed), top_traces_(layout.top_traces()) {
    const auto rate = [](int one_in, const char* name) {
      if (one_in < 1) throw Error(std::string("FaultInjector: ") + name + " " + std::to_string(one_in) + ", expected at least 1");
    };
    rate(settings_.drop_one_in, "drop_one_in");
    rate(settings_.spike_one_in, "spike_one_in");
    rate(settings_.non_finite_one_in, "non_finite_one_in");
    const auto in_range = [](int value, int count, const char* name) {
      if (value < 0 || value >= count)
        throw Error(std::string("FaultInjector: ") + name + " " + std::to_string(value) + ", expected 0.." + std::to_string(count - 1) +
                    " (the glove's wiring)");
    };
    in_range(settings_.lost_bottom_trace, layout.bottom_traces(), "lost_bottom_trace");
    in_range(settings_.stuck_row, layout.row_count(), "stuck_row");
    in_range(settings_.disconnected_top_trace, top_traces_, "disconnected_top_trace");
    if (!std::isfinite(settings_.spike_pf) || !std::isfinite(settings_.clock_jump_seconds) ||
        !(settings_.disconnected_pf >= 0.0 && std::isfinite(settings_.disconnected_pf)))
      throw Error("FaultInjector: spike_pf " + std::to_string(settings_.spike_pf) + ", clock_jump_seconds " +
                  std::to_string(settings_.clock_jump_seconds) + ", disconnected_pf " + std::to_string(settings_.disconnected_pf) +
                  ", expected finite values and disconnected_pf >= 0");
  }

  /// @brief The readings the glove delivers in place of the clean reading `clean`.
  GLOVEPOSE_REALTIME InjectedReadings apply(const Reading& clean) noexcept {
    InjectedReadings out;
    Reading faulty = clean;
    bool altered = true;
    switch (kind_) {
      case FaultKind::DroppedRows:
        if (hit_one_in(settings_.drop_one_in)) break;
        out.push_back(clean);
        altered = false;
        break;
      case FaultKind::LostTraceBurst:
        altered = clean.row / top_traces_ == settings_.lost_bottom_trace;
        if (!altered) out.push_back(clean);
        break;
      case FaultKind::DuplicatedRows:
        out.push_back(clean);
        out.push_back(clean);
        break;
      case FaultKind::OutOfOrderRows:
        // Every other reading waits for the next one and arrives after it; a reading still held
        // when the fault ends is lost.
        if (!holding_) {
          held_ = clean;
          holding_ = true;
          break;
        }
        out.push_back(clean);
        out.push_back(held_);
        holding_ = false;
        break;
      case FaultKind::StuckSensor:
        altered = clean.row == settings_.stuck_row;
        if (altered) {
          if (!std::isfinite(stuck_value_) && std::isfinite(clean.value)) stuck_value_ = clean.value;
          faulty.value = stuck_value_;
        }
        out.push_back(faulty);
        break;
      case FaultKind::DisconnectedTrace:
        altered = clean.row % top_traces_ == settings_.disconnected_top_trace;
        if (altered) faulty.value = settings_.disconnected_pf;
        out.push_back(faulty);
        break;
      case FaultKind::Spikes:
        altered = hit_one_in(settings_.spike_one_in);
        if (altered) faulty.value += settings_.spike_pf;
        out.push_back(faulty);
        break;
      case FaultKind::NonFiniteValues:
        altered = hit_one_in(settings_.non_finite_one_in);
        if (altered)
          faulty.value = rng_.bernoulli(0.5) ? std::numeric_limits<double>::quiet_NaN() : std::numeric_limits<double>::infinity();
        out.push_back(faulty);
        break;
      case FaultKind::Unplugged:
        break;
      case FaultKind::ClockJumpForward:
        faulty.timestamp += settings_.clock_jump_seconds;
        out.push_back(faulty);
        break;
      case FaultKind::ClockJumpBack:
        faulty.timestamp -= settings_.clock_jump_seconds;
        out.push_back(faulty);
        break;
    }
    altered_ += altered ? 1 : 0;
    return out;
  }

  /// @brief The fault's kind.
  FaultKind kind() const noexcept { return kind_; }
  /// @brief The fault's size and target.
  const FaultSettings& settings() const noexcept { return settings_; }
  /// @brief Clean readings so far that were lost, repeated, delayed or changed.
  std::uint64_t altered_readings() const noexcept { return altered_; }

 private:
  // Whether this reading is the one hit in its block of `one_in` (see the file comment).
  bool hit_one_in(int one_in) noexcept {
    if (block_position_ == 0) block_hit_ = rng_.index(one_in);
    const bool hit = block_position_ == block_hit_;
    block_position_ = (block_position_ + 1) % one_in;
    return hit;
  }

  FaultKind kind_;
  FaultSettings settings_;
  core::Rng rng_;
  int top_traces_;
  Reading held_{};
  bool holding_ = false;
  int block_position_ = 0;
  int block_hit_ = 0;
  double stuck_value_ = std::numeric_limits<double>::quiet_NaN();
  std::uint64_t altered_ = 0;
};

}  // namespace glovepose::sim
