/// @file readout_config.hpp
/// @brief The streaming readout's settings and the health it reports per frame (readout.hpp), apart
/// from the readout so that a unit configuring an estimator needs no solver.
#pragma once

#include <cstdint>

namespace glovepose::sensor {

/// @brief Settings of the streaming readout, including how it meets faults of the stream.
struct ReadoutConfig {
  int mean_window = 5;   ///< Readings per row averaged before solving (paper: last 5 frames).
  int solve_every = 16;  ///< Solve after this many accepted row updates (paper: 16).
  /// A pause longer than this (s) between two accepted readings (glove unplugged, link stalled)
  /// makes every held reading stale: the readout forgets them and starts over, as reset() does.
  double gap_seconds = 0.1;
  /// This many consecutive readings with timestamps before the last accepted one mean the glove's
  /// clock restarted (firmware reboot): the readout starts over on the new clock. Fewer are rejected
  /// as out of order. 0: the number of rows (a whole cycle on the new clock).
  int clock_restart_readings = 0;
  /// A row that repeats exactly the same value this many readings in a row is stuck: real readings
  /// carry noise (the paper's timer-based measurement jitters by far more than a float's last bit).
  int stuck_readings = 30;
  /// A row whose newest reading is older than this many readout cycles is stale (its readings are
  /// being lost). The cycle is estimated per frame as twice the median age of the rows' newest
  /// readings (rows are read one after another), so no rate needs configuring.
  double stale_cycles = 2.5;
  /// A row whose mean reading is below this (pF) reads through a disconnected trace: the paper's
  /// compound capacitances are tens of pF, an open trace leaves only stray capacitance.
  double disconnected_below = 1.0;
  /// Disconnected rows are left out of the solve, which the rest of the rows then solve alone
  /// (least squares without them), when they are at most this share of the rows and the rest still
  /// determine every cell: the frame stays trustworthy (the paper's readout is overdetermined "for
  /// better robustness", Sec. 3.1: without any one trace's rows the paper glove's M keeps full rank).
  /// Otherwise they stay in and the frame is flagged. 0: never left out.
  double max_excluded_share = 0.25;
  /// A row whose least-squares residual |M C_c - C_m| exceeds this (pF) divided by the square root
  /// of the readings it holds disagrees with the others: a spike or a failing cell. Averaging n
  /// readings divides the noise by sqrt(n), so the bound keeps the same distance from the noise at
  /// every mean window (and while a row fills). 2.25 pF is about 8 times the residual of one reading
  /// under the readout noise assumed in docs/simulator.md (0.3 pF per reading); 1 pF at the paper's
  /// mean of 5.
  double max_reading_residual = 2.25;
};

/// @brief Health of a solved frame: what the readout saw that makes it less trustworthy.
struct ReadoutHealth {
  std::uint16_t filling_rows = 0;       ///< Rows holding fewer readings than the mean window (after a start or restart).
  std::uint16_t stale_rows = 0;         ///< Rows in the solve whose newest reading is older than ReadoutConfig::stale_cycles cycles.
  std::uint16_t stuck_rows = 0;         ///< Rows repeating one value (ReadoutConfig::stuck_readings).
  std::uint16_t disconnected_rows = 0;  ///< Rows reading below ReadoutConfig::disconnected_below.
  std::uint16_t excluded_rows = 0;      ///< Of those, rows left out of the solve (ReadoutConfig::max_excluded_share).
  std::uint16_t outlier_rows = 0;       ///< Rows whose residual exceeds ReadoutConfig::max_reading_residual / sqrt(readings held).
  double max_residual = 0.0;            ///< Largest |M C_c - C_m| over the rows, pF.
  std::uint64_t restarts = 0;           ///< Times the readout started over (gaps, clock restarts) since construction.
};

}  // namespace glovepose::sensor
