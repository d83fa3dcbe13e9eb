/// @file recorder.hpp
/// @brief The time-multiplexed readout of a simulated glove: the 180 compound rows of M measured one
/// after another (each at the hand pose of its own instant), with measurement noise and rare
/// glitches, fed through the real-time sensor::Readout (5-frame mean, a solve every 16 rows, paper
/// Sec. 3.1); one frame of solved C_c, ground-truth angles and outlier flag per 60 Hz cycle.
///
/// The textile composite relaxes: a cell's reading lags partly behind its stretch (a share of
/// kCreepShare follows a first-order lag of kCreepTime), the "material hysteresis" the paper names
/// among its error sources (Sec. 6); share and time are assumptions.
///
/// Noise figures are assumptions (the paper gives none): a compound reading's SD of 0.3 pF against
/// compound values of 20-80 pF (charging-time jitter of the micro-controller's timer); spikes
/// (+5..50 pF, e.g. a touch or a contact bounce) in 1 of 50,000 readings; dropped readings (a row
/// lost on the serial link, delivered as NaN and rejected by the readout) in 1 of 10,000; a
/// per-session common gain with 0.5% SD (skin temperature and humidity change the dielectric).
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "../hand/collision.hpp"
#include "../sensor/layout.hpp"
#include "../sensor/readout.hpp"
#include "../sensor/solver.hpp"
#include "glove.hpp"
#include "motion.hpp"
#include "../core/random.hpp"
#include "../core/units.hpp"

namespace glovepose::sim {

/// @brief Rows of the simulated glove's readout.
inline constexpr int kRows = sensor::kGlauser2019Rows;

/// @brief Share of a cell's reading that follows the lagging (relaxing) stretch.
inline constexpr double kCreepShare = 0.15;
/// @brief Time constant (s) of the textile's relaxation.
inline constexpr double kCreepTime = 1.0;

/// @brief How the sensor material answers beyond its physics: relaxation, rate-independent hysteresis
/// and slow drift of its gain. The material effects of a simulated world (sim/world.hpp); the
/// defaults are the clean world's.
struct GloveMaterial {
  double creep_share = kCreepShare;  ///< Share of a reading that follows the relaxing stretch.
  double creep_time = kCreepTime;    ///< Its time constant (s).
  /// Share of a reading that goes through a play (backlash) operator of half-width hysteresis_width
  /// in C / C0: the textile composite's friction between its layers, a loop whatever the speed.
  double hysteresis_share = 0.0;
  double hysteresis_width = 0.0;  ///< Half-width of the play, in units of C0.
  double drift_rate = 0.0;        ///< Each cell's gain: a random walk, relative SD per square root of a minute worn.
  double warmup_gain = 0.0;       ///< Common gain reached as the skin warms the silicone (relative).
  double warmup_time = 300.0;     ///< Its time constant (s) from the donning.
};

/// @brief A play (backlash) operator: the output stays put until the input is more than `width` away,
/// then is dragged along at that distance. Its loop, driven between a and b, encloses
/// 2 width (b - a - 2 width).
GLOVEPOSE_REALTIME inline double play(double output, double input, double width) noexcept {
  return std::clamp(output, input - width, input + width);
}

/// @brief The slow changes of one worn glove, as functions of the time since it was put on: the
/// slip of the whole glove along the fingers (mm, an Ornstein-Uhlenbeck process) and every cell's
/// gain (a random walk times the warm-up). Sampled once a second from its seed and interpolated, so
/// that the recordings of one donning see one continuous path whichever thread records them.
class WearDrift {
 public:
  /// @brief No drift: slip 0, gains 1.
  WearDrift() = default;
  /// @brief The path of a donning up to `seconds` after it (slip SD and time constant already scaled
  /// for the hand's fit), its recordings starting `start` seconds after the donning.
  WearDrift(double slip_sd, double slip_time, const GloveMaterial& material, double seconds, double start, std::uint64_t seed)
      : start_(start), warmup_gain_(material.warmup_gain), warmup_time_(material.warmup_time) {
    const int knots = static_cast<int>(std::ceil(std::max(0.0, seconds))) + 2;
    core::Rng rng(seed);
    const double keep = std::exp(-kStep / std::max(1e-9, slip_time));
    const double kick = slip_sd * std::sqrt(1.0 - keep * keep);
    const double step = material.drift_rate * std::sqrt(kStep / 60.0);
    slip_.assign(static_cast<std::size_t>(knots), 0.0);
    gain_.assign(static_cast<std::size_t>(knots) * kCells, 0.0);
    for (int k = 1; k < knots; ++k) {
      const auto i = static_cast<std::size_t>(k);
      slip_[i] = keep * slip_[i - 1] + kick * rng.normal();
      for (std::size_t c = 0; c < kCells; ++c) gain_[i * kCells + c] = gain_[(i - 1) * kCells + c] + step * rng.normal();
    }
  }

  /// @brief Slip (mm) at `t` seconds into the recording.
  GLOVEPOSE_REALTIME double slip(double t) const noexcept { return sample(slip_, 1, 0, t); }
  /// @brief Cell `c`'s gain at `t` seconds into the recording.
  GLOVEPOSE_REALTIME double gain(std::size_t c, double t) const noexcept { return warmup(t) * (1.0 + sample(gain_, kCells, c, t)); }
  /// @brief Every cell's gain at `t` (the warm-up computed once).
  GLOVEPOSE_REALTIME void gains(double t, CellArray& out) const noexcept {
    const double common = warmup(t);
    for (std::size_t c = 0; c < out.size(); ++c) out[c] = common * (1.0 + sample(gain_, kCells, c, t));
  }

 private:
  static constexpr double kStep = 1.0;  // s between samples
  double warmup(double t) const noexcept {
    return 1.0 + warmup_gain_ * (1.0 - std::exp(-std::max(0.0, start_ + t) / std::max(1e-9, warmup_time_)));
  }
  double sample(const std::vector<double>& v, std::size_t stride, std::size_t offset, double t) const noexcept {
    const std::size_t knots = v.size() / stride;
    if (knots == 0) return 0.0;
    const double x = std::clamp((start_ + t) / kStep, 0.0, static_cast<double>(knots - 1));
    const auto k = std::min(knots - 1, static_cast<std::size_t>(x));
    const std::size_t next = std::min(knots - 1, k + 1);
    const double w = x - static_cast<double>(k);
    return v[k * stride + offset] + w * (v[next * stride + offset] - v[k * stride + offset]);
  }
  double start_ = 0.0, warmup_gain_ = 0.0, warmup_time_ = 300.0;
  std::vector<double> slip_, gain_;
};

/// @brief Measurement imperfections of the readout (see the file comment for the sources).
struct ReadoutNoise {
  double row_sd = 0.3;              ///< SD (pF) of one compound reading.
  double spike_probability = 2e-5;  ///< Per reading.
  double spike_min = 5.0;           ///< pF.
  double spike_max = 50.0;          ///< pF.
  double drop_probability = 1e-4;   ///< Per reading.
  double session_gain_sd = 0.005;   ///< Relative SD of the session's common gain.
};

/// @brief A trace of the glove torn during the recording. The physics (an assumption; the paper
/// reports no tear): a trace is a conductive strip from the glove's connector at the wrist out to
/// its farthest cell; torn, the part beyond the break is connected to nothing, so the cells it
/// forms float: each is in series with a floating electrode and leaves every compound measurement
/// (its column of M is 0 from then on). The cells before the break, and the rows that drive the
/// trace, measure as before. Which cells lie beyond: cells_beyond_tear().
struct TraceTear {
  int trace = -1;            ///< The torn trace: bottom traces 0 .. B-1, then top traces B .. B+T-1; -1: none.
  int cells_kept = 0;        ///< Cells of the trace still connected, nearest the connector first.
  double at_seconds = 0.0;   ///< Recording time at which it tears.
};

/// @brief The cells a tear leaves floating, in the layout's order. A trace's cells are ordered by
/// their distance from the connector at the wrist along the digit (an assumption, our reading of
/// Fig. 4: back of the hand wrist side, knuckle side, web, proximal, middle, distal; then thumb
/// first); the first `cells_kept` stay connected. Throws glovepose::Error for a trace that does
/// not exist.
inline std::vector<int> cells_beyond_tear(const sensor::TraceLayout& layout, const std::array<CellSite, kCells>& sites, const TraceTear& tear) {
  const int traces = layout.bottom_traces() + layout.top_traces();
  if (tear.trace < 0 || tear.trace >= traces)
    throw Error("TraceTear: trace " + std::to_string(tear.trace) + ", expected 0.." + std::to_string(traces - 1) + " (bottom traces, then top)");
  std::vector<int> on_trace;
  for (int c = 0; c < layout.cell_count(); ++c) {
    const sensor::Cell& cell = layout.cells()[static_cast<std::size_t>(c)];
    if (cell.bottom == tear.trace || layout.bottom_traces() + cell.top == tear.trace) on_trace.push_back(c);
  }
  const auto from_wrist = [&](int c) {
    const CellSite& s = sites[static_cast<std::size_t>(c)];
    const double along = s.segment == sensor::Segment::Metacarpal ? (s.knuckle_distance > 20.0 ? 0.0 : 1.0) : 1.0 + static_cast<double>(s.segment);
    return std::make_pair(along, s.thumb_distance);
  };
  std::stable_sort(on_trace.begin(), on_trace.end(), [&](int a, int b) { return from_wrist(a) < from_wrist(b); });
  const auto kept = static_cast<std::size_t>(std::clamp(tear.cells_kept, 0, static_cast<int>(on_trace.size())));
  std::vector<int> beyond(on_trace.begin() + static_cast<std::ptrdiff_t>(kept), on_trace.end());
  std::sort(beyond.begin(), beyond.end());
  return beyond;
}

/// @brief What to record.
struct RecordingConfig {
  double cycle_rate = 60.0;         ///< Full 180-row cycles per second (paper: about 60 Hz).
  sensor::ReadoutConfig readout{};  ///< Mean window 5, solve every 16 (paper Sec. 3.1).
  ReadoutNoise noise{};             ///< Imperfections.
  bool raw_rows = false;            ///< Keep each cycle's 180 readings.
  int warmup_cycles = 5;            ///< Cycles read before t = 0 so the mean window is full.
  /// Poses per cycle at which the physics is evaluated; the rows between two of them take C_c
  /// linearly interpolated (12: every 1.4 ms, where a hand at human speed moves by far less than
  /// the readout noise; tests/test_sim.cpp bounds the difference to the exact evaluation). kRows
  /// evaluates at every row's own instant.
  int physics_steps = 12;
  std::vector<TraceTear> tears;  ///< Traces that tear during the recording (none by default; a corpus tears its sessions only).
};

/// @brief One recording, frames at the ends of the readout cycles.
struct Recording {
  int frames = 0;                     ///< Number of frames.
  std::vector<float> cells;           ///< frames x 44: solved C_c (pF) of the latest solve.
  std::vector<float> raw_rows;        ///< frames x 180: the cycle's readings (NaN: dropped); empty unless asked.
  std::vector<float> angles;          ///< frames x 25: ground truth at the frame's time (rad).
  std::vector<float> labels;          ///< frames x 25: the reference tracker's angles (rad, sim/tracker.hpp); empty until labelled.
  std::vector<double> timestamps;     ///< Seconds since the recording started (cycle ends).
  std::vector<double> oldest_age;     ///< Age (s) at the frame's time of the oldest reading behind its C_c.
  /// 1 when the pose's collision energy exceeds hand::kCollisionOutlierThreshold: the true pose's from
  /// record(), the labels' once label_recording() has run.
  std::vector<std::uint8_t> outlier;
};

namespace detail {

/// @brief Reads a glove out through the real-time readout: `physical(t, out)` gives every cell's
/// capacitance (pF) at time t before the material's response, `gains(t, out)` the slow gains that
/// multiply it, `truth(t, angles, outlier)` the frame's true angles and outlier flag. The material,
/// the noise, the tears and the frames as record() describes them.
template <typename Physical, typename Gains, typename Truth>
Recording read_out(double seconds, const CellArray& c0, std::uint64_t seed, const RecordingConfig& config, const GloveMaterial& material,
                   Physical&& physical, Gains&& gains, Truth&& truth) {
  static const std::shared_ptr<const sensor::CapacitanceSolver> solver =
      std::make_shared<const sensor::CapacitanceSolver>(sensor::TraceLayout::glauser2019());
  // Cells each row sums (M's ones).
  static const std::vector<std::vector<int>> row_cells = [] {
    const Eigen::MatrixXd m = sensor::TraceLayout::glauser2019().measurement_matrix();
    std::vector<std::vector<int>> rows(static_cast<std::size_t>(m.rows()));
    for (int r = 0; r < m.rows(); ++r)
      for (int c = 0; c < m.cols(); ++c)
        if (m(r, c) != 0.0) rows[static_cast<std::size_t>(r)].push_back(c);
    return rows;
  }();
  // When each cell starts to float (beyond a tear: out of every row from then on); never: infinity.
  std::array<double, kCells> floating_from;
  floating_from.fill(std::numeric_limits<double>::infinity());
  for (const TraceTear& tear : config.tears)
    if (tear.trace >= 0)  // -1: none
      for (int c : cells_beyond_tear(solver->layout(), glauser2019_sites(), tear))
        floating_from[static_cast<std::size_t>(c)] = std::min(floating_from[static_cast<std::size_t>(c)], tear.at_seconds);
  core::Rng rng(seed);
  const ReadoutNoise& noise = config.noise;
  const double gain = rng.normal(1.0, noise.session_gain_sd);
  sensor::Readout readout(solver, config.readout);
  const int cycles = static_cast<int>(std::floor(seconds * config.cycle_rate));

  Recording rec;
  rec.frames = cycles;
  rec.cells.reserve(static_cast<std::size_t>(cycles) * kCells);
  rec.angles.reserve(static_cast<std::size_t>(cycles) * hand::kDofCount);
  if (config.raw_rows) rec.raw_rows.reserve(static_cast<std::size_t>(cycles) * kRows);
  std::array<float, kRows> cycle_rows{};
  const int steps = std::clamp(config.physics_steps, 1, kRows);
  std::vector<CellArray> knots(static_cast<std::size_t>(steps) + 1);  // C_c at the cycle's step boundaries
  const auto cycle_time = [&](int k, double fraction) { return (static_cast<double>(k) + fraction) / config.cycle_rate; };
  const double t0 = cycle_time(-config.warmup_cycles, 0.0);
  physical(t0, knots[0]);
  CellArray relaxed = knots[0];  // the lagging part of each cell's reading
  CellArray played = knots[0];   // the hysteretic part
  CellArray drift_gain{};        // the slow gains at the step
  const double relax = 1.0 - std::exp(-1.0 / (config.cycle_rate * steps * material.creep_time));
  hand::Angles angles{};
  bool solved = false;
  for (int k = -config.warmup_cycles; k < cycles; ++k) {
    if (k > -config.warmup_cycles) knots[0] = knots[static_cast<std::size_t>(steps)];
    for (int j = 1; j <= steps; ++j) {
      CellArray& knot = knots[static_cast<std::size_t>(j)];
      const double t = cycle_time(k, static_cast<double>(j) / steps);
      physical(t, knot);
      gains(t, drift_gain);
      for (std::size_t c = 0; c < knot.size(); ++c) {
        relaxed[c] += relax * (knot[c] - relaxed[c]);
        played[c] = play(played[c], knot[c], material.hysteresis_width * c0[c]);
        const double physical_value = knot[c];
        knot[c] += material.creep_share * (relaxed[c] - physical_value) + material.hysteresis_share * (played[c] - physical_value);
        knot[c] *= drift_gain[c];
      }
    }
    for (int r = 0; r < kRows; ++r) {
      // Row r of cycle k completes at the end of its slot.
      const double fraction = static_cast<double>(r + 1) / kRows;
      const double t = cycle_time(k, fraction);
      const int j = std::min(steps - 1, static_cast<int>(fraction * steps));
      const double w = fraction * steps - j;
      const CellArray& lo = knots[static_cast<std::size_t>(j)];
      const CellArray& hi = knots[static_cast<std::size_t>(j) + 1];
      double value = 0.0;
      for (int c : row_cells[static_cast<std::size_t>(r)]) {
        const auto i = static_cast<std::size_t>(c);
        if (t >= floating_from[i]) continue;
        value += lo[i] + w * (hi[i] - lo[i]);
      }
      value = value * gain + rng.normal(0.0, noise.row_sd);
      if (rng.bernoulli(noise.spike_probability)) value += rng.uniform(noise.spike_min, noise.spike_max);
      if (rng.bernoulli(noise.drop_probability)) value = std::numeric_limits<double>::quiet_NaN();
      cycle_rows[static_cast<std::size_t>(r)] = static_cast<float>(value);
      if (readout.push_row(r, value, t) == Status::Solved) solved = true;
    }
    if (k < 0) continue;
    const double t_end = (static_cast<double>(k) + 1.0) / config.cycle_rate;
    const auto& frame = readout.frame();
    for (int c = 0; c < kCells; ++c) rec.cells.push_back(solved ? static_cast<float>(frame.cells(c)) : 0.0f);
    std::uint8_t outlier = 0;
    truth(t_end, angles, outlier);
    for (double a : angles) rec.angles.push_back(static_cast<float>(a));
    rec.timestamps.push_back(t_end);
    rec.oldest_age.push_back(t_end - frame.timestamp + frame.oldest_age);
    rec.outlier.push_back(outlier);
    if (config.raw_rows) rec.raw_rows.insert(rec.raw_rows.end(), cycle_rows.begin(), cycle_rows.end());
  }
  return rec;
}

}  // namespace detail

/// @brief Records `motion` through the glove physics, the glove's material and its slow drift.
/// Deterministic in `seed`.
inline Recording record(const GlovePhysics& physics, const MotionSequence& motion, const std::array<double, 16>& radii, std::uint64_t seed,
                        const RecordingConfig& config = {}, const GloveMaterial& material = {}, const WearDrift& drift = {}) {
  hand::Skeleton skeleton;
  return detail::read_out(
      motion.duration(), physics.glove().base_capacitance, seed, config, material,
      [&](double t, CellArray& out) { physics.capacitances(motion.at(t), out, drift.slip(t)); },
      [&](double t, CellArray& out) { drift.gains(t, out); },
      [&](double t, hand::Angles& angles, std::uint8_t& outlier) {
        angles = motion.at(t);
        physics.kinematics().pose(angles, skeleton);
        outlier = hand::collision_energy(physics.kinematics(), skeleton, radii) > hand::kCollisionOutlierThreshold ? 1 : 0;
      });
}

/// @brief Taking the glove off and putting it on again. The physics is an assumption throughout (the
/// paper's subjects took the glove off between sessions, Sec. 5.1, but it shows no reading of a
/// glove off the hand): pulled off, each cell goes from its worn reading to the relaxed sheet's
/// over `doff_seconds`, dragged over the knuckles on the way (a strain along the fingers that rises
/// and falls, up to `pull_strain` times a uniform draw per cell); off the hand the sheet lies with
/// folds (each cell's own strain, SD `fold_sd`), its gains going from the old donning's to the new
/// one's; pulled on, the reverse over `don_seconds` into the new donning.
struct RemovalConfig {
  double doff_seconds = 2.0;  ///< Pulling the glove off.
  double off_seconds = 10.0;  ///< Off the hand.
  double don_seconds = 3.0;   ///< Pulling it on.
  double pull_strain = 0.15;  ///< Largest strain along a cell while it is dragged over the knuckles.
  double fold_sd = 0.02;      ///< SD of each cell's strain from the folds of the sheet lying off the hand.

  /// @brief The whole removal's seconds.
  double seconds() const noexcept { return doff_seconds + off_seconds + don_seconds; }
  /// @brief Throws glovepose::Error naming the first setting out of range.
  void validate() const {
    if (!(doff_seconds > 0.0) || !(off_seconds >= 0.0) || !(don_seconds > 0.0) || !std::isfinite(seconds()) || !(pull_strain >= 0.0) ||
        !(pull_strain < 1.0) || !(fold_sd >= 0.0) || !(fold_sd < 0.5))
      throw Error("RemovalConfig: doff " + std::to_string(doff_seconds) + " s, off " + std::to_string(off_seconds) + " s, don " +
                  std::to_string(don_seconds) + " s, pull strain " + std::to_string(pull_strain) + ", fold SD " + std::to_string(fold_sd) +
                  ", expected finite times (doff and don > 0, off >= 0), a pull strain in [0, 1) and a fold SD in [0, 0.5)");
  }
};

/// @brief Records a removal (RemovalConfig): the hand moves as `motion` says while it pulls the glove
/// off `before` (worn `before_worn` seconds on the path `before_drift` starts at the donning) and
/// into `after` (whose drift `after_drift` starts at the donning, the end of the removal). The
/// frames carry no pose (angles NaN: nothing of the hand is in the glove for part of it).
/// Deterministic in `seed`.
inline Recording record_removal(const GlovePhysics& before, const WearDrift& before_drift, double before_worn, const GlovePhysics& after,
                                const WearDrift& after_drift, const MotionSequence& motion, const RemovalConfig& removal, std::uint64_t seed,
                                const RecordingConfig& config = {}, const GloveMaterial& material = {}) {
  removal.validate();
  if (before.glove().id != after.glove().id) throw Error("record_removal: gloves " + std::to_string(before.glove().id) + " and " +
                                                         std::to_string(after.glove().id) + ", expected one glove taken off and put on");
  core::Rng rng(core::derive_seed(seed, {1}));  // the removal's own draws: the readout's stream is `seed`'s
  CellArray fold{}, pull{};
  for (double& f : fold) f = rng.normal(0.0, removal.fold_sd);
  for (double& p : pull) p = rng.uniform(0.0, removal.pull_strain);
  CellArray off{}, worn{};
  after.off_hand_capacitances(fold, off);
  const double doffed = removal.doff_seconds, donning = removal.doff_seconds + removal.off_seconds;
  // From a (worn) to b (off) or back as w goes 0 -> 1, the pull's area factor peaking half-way.
  const auto blend = [&](const CellArray& a, const CellArray& b, double w, CellArray& out) {
    for (std::size_t c = 0; c < out.size(); ++c) {
      const double area = 1.0 + pull[c] * std::sin(core::kPi * w);
      out[c] = ((1.0 - w) * a[c] + w * b[c]) * area * area;
    }
  };
  CellArray gains_before{}, gains_after{};
  before_drift.gains(before_worn + doffed, gains_before);
  after_drift.gains(0.0, gains_after);
  return detail::read_out(
      removal.seconds(), after.glove().base_capacitance, seed, config, material,
      [&](double t, CellArray& out) {
        if (t < doffed) {
          before.capacitances(motion.at(t), worn, before_drift.slip(before_worn + std::max(0.0, t)));
          blend(worn, off, std::max(0.0, t) / removal.doff_seconds, out);
        } else if (t < donning) {
          out = off;
        } else {
          after.capacitances(motion.at(t), worn, after_drift.slip(0.0));
          blend(worn, off, 1.0 - (t - donning) / removal.don_seconds, out);
        }
      },
      [&](double t, CellArray& out) {
        if (t < doffed) {
          before_drift.gains(before_worn + std::max(0.0, t), out);
          return;
        }
        const double w = removal.off_seconds > 0.0 ? std::min(1.0, (t - doffed) / removal.off_seconds) : 1.0;
        for (std::size_t c = 0; c < out.size(); ++c) out[c] = (1.0 - w) * gains_before[c] + w * gains_after[c];
      },
      [&](double, hand::Angles& angles, std::uint8_t& outlier) {
        angles.fill(std::numeric_limits<double>::quiet_NaN());
        outlier = 0;
      });
}

}  // namespace glovepose::sim
