/// @file report.hpp
/// @brief The realism report of a simulated corpus (`glovepose simulate --report`): per-cell signal
/// range and SNR, per-DoF coverage of the joint range, how much re-donning the glove changes the
/// readings against how much a pose change does, the age of the oldest reading behind each frame,
/// the outlier share, and the difficulty check: a linear least-squares map from the 44 calibrated
/// cells to the 25 angles, across people (leave one subject out; also from the raw cells) against
/// within one session and on Table 1's personal splits, fitted to and scored against the labels (the
/// reference tracker's angles); and how far those labels are from the truth.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <limits>
#include <string>
#include <vector>

#include <Eigen/Dense>

#include "../core/units.hpp"
#include "../core/statistics.hpp"
#include "../sensor/calibration.hpp"
#include "../sensor/layout.hpp"
#include "corpus.hpp"

namespace glovepose::sim {

/// @brief Figures of the realism report.
struct RealismReport {
  /// @brief One cell's signal.
  struct Cell {
    double p1 = 0, p99 = 0;  ///< 1st and 99th percentile of C_c over the sessions (pF).
    double noise_sd = 0;     ///< SD (pF) of C_c against the same recording without readout noise.
    double snr = 0;          ///< (p99 - p1) / noise_sd.
  };
  /// @brief One DoF's coverage.
  struct Dof {
    double p1 = 0, p99 = 0;  ///< Percentiles of the angle (rad).
    double coverage = 0;     ///< (p99 - p1) / (limit max - limit min).
    int bins_used = 0;       ///< Of 10 equal bins over the limits, those holding >= 0.5% of frames.
  };
  CorpusConfig config;                              ///< What was simulated.
  long frames = 0;                                  ///< Session frames (glove 0, calibration sequences excluded).
  std::array<Cell, kCells> cells{};                 ///< By cell id.
  std::array<Dof, hand::kDofCount> dofs{};          ///< kDofs order.
  double redonning_change = 0;                      ///< Mean |C(donning 1) - C(donning 0)| at the same poses, / cell range.
  double pose_change = 0;                           ///< Mean |C(pose a) - C(pose b)| in one donning, / cell range.
  double age_min = 0, age_median = 0, age_max = 0;  ///< Oldest reading's age (s) per frame.
  double outlier_share = 0;                         ///< Frames flagged by the collision-energy filter (on the labels).
  double label_mean_deg = 0;                        ///< Mean |label - truth| over every DoF of the session frames (deg).
  double label_thumb_deg = 0;                       ///< The same over the thumb's DoFs.
  double label_p95_deg = 0;                         ///< 95th percentile of |label - truth| (deg).
  double linear_cross_deg = 0;                      ///< Linear map, leave-one-subject-out: mean abs error (deg).
  double linear_uncalibrated_deg = 0;               ///< The same from the raw cells, no calibration (Table 1 (3)'s split).
  double linear_same_deg = 0;                       ///< Linear map fitted on a session's first 2/3, tested on its last 1/3.
  /// Linear personal maps on Table 1's splits (NaN without 5 sessions, 3 of them in one donning):
  /// intra, sessions 0 and 1 -> session 2 (one donning); inter, sessions 0-3 -> session 4 (re-donned).
  double linear_intra_deg = std::numeric_limits<double>::quiet_NaN();
  double linear_inter_deg = std::numeric_limits<double>::quiet_NaN();
};

namespace detail {

// A session's frames calibrated by the on-the-fly min-max of its calibration sequence (paper
// Sec. 4.3, 20-frame median), plus a bias column, the raw cells with a bias column, and the labels;
// outlier frames dropped. Rows: frames.
inline void calibrated(const Recording& calibration, const Recording& session, Eigen::MatrixXd& x, Eigen::MatrixXd& raw, Eigen::MatrixXd& y) {
  sensor::OnTheFlyCalibrator calibrator(sensor::TraceLayout::glauser2019().cell_names());
  Eigen::VectorXd frame(kCells), out(kCells);
  for (int f = 0; f < calibration.frames; ++f) {
    for (int c = 0; c < kCells; ++c) frame(c) = calibration.cells[static_cast<std::size_t>(f * kCells + c)];
    calibrator.add(frame);
  }
  const sensor::CalibrationRange range = calibrator.finish();
  long kept = 0;
  for (std::uint8_t o : session.outlier) kept += o ? 0 : 1;
  x.resize(kept, kCells + 1);
  raw.resize(kept, kCells + 1);
  y.resize(kept, hand::kDofCount);
  long row = 0;
  for (int f = 0; f < session.frames; ++f) {
    if (session.outlier[static_cast<std::size_t>(f)]) continue;
    for (int c = 0; c < kCells; ++c) frame(c) = session.cells[static_cast<std::size_t>(f * kCells + c)];
    range.normalize(frame, out);
    x.row(row).head(kCells) = out.transpose();
    x(row, kCells) = 1.0;
    raw.row(row).head(kCells) = frame.transpose();
    raw(row, kCells) = 1.0;
    for (std::size_t d = 0; d < hand::kDofCount; ++d)
      y(row, static_cast<Eigen::Index>(d)) = session.labels[static_cast<std::size_t>(f) * hand::kDofCount + d];
    ++row;
  }
}

inline Eigen::MatrixXd fit_linear(const Eigen::MatrixXd& xtx, const Eigen::MatrixXd& xty) {
  // A tiny ridge keeps flat (all-zero) calibrated cells from making the system singular.
  return (xtx + 1e-6 * Eigen::MatrixXd::Identity(xtx.rows(), xtx.cols())).ldlt().solve(xty);
}

inline double mean_abs_deg(const Eigen::MatrixXd& x, const Eigen::MatrixXd& y, const Eigen::MatrixXd& w) {
  return (x * w - y).cwiseAbs().mean() * core::kDegreesPerRadian;
}

}  // namespace detail

/// @brief Simulates `config` and measures it. Needs calibration sequences and at least 2 subjects.
inline RealismReport make_report(const CorpusConfig& config) {
  if (config.subjects < 2)
    throw Error("simulate --report: " + std::to_string(config.subjects) + " subjects, expected at least 2 (leave-one-out)");
  if (config.calibration_seconds <= 0.0) throw Error("simulate --report: needs calibration sequences, expected calibration seconds > 0");
  RealismReport report;
  report.config = config;
  const std::vector<SessionRecording> corpus = simulate_corpus(config);
  const CorpusWorld world(config);

  // Signal, coverage, ages, outliers over glove 0's sessions.
  std::array<std::vector<double>, kCells> values;
  std::array<std::vector<double>, hand::kDofCount> angles;
  std::vector<double> ages, label_errors;
  double thumb_error = 0.0;
  long thumb_count = 0;
  long outliers = 0;
  for (const SessionRecording& s : corpus) {
    if (s.glove != 0 || s.kind != RecordingKind::Session) continue;
    const Recording& r = s.recording;
    report.frames += r.frames;
    for (int f = 0; f < r.frames; ++f) {
      for (int c = 0; c < kCells; ++c) values[static_cast<std::size_t>(c)].push_back(r.cells[static_cast<std::size_t>(f * kCells + c)]);
      for (std::size_t d = 0; d < hand::kDofCount; ++d) {
        const std::size_t i = static_cast<std::size_t>(f) * hand::kDofCount + d;
        angles[d].push_back(r.angles[i]);
        label_errors.push_back(std::abs(static_cast<double>(r.labels[i]) - r.angles[i]) * core::kDegreesPerRadian);
        if (hand::kDofs[d].finger == hand::Finger::Thumb) thumb_error += label_errors.back(), ++thumb_count;
      }
      ages.push_back(r.oldest_age[static_cast<std::size_t>(f)]);
      outliers += r.outlier[static_cast<std::size_t>(f)];
    }
  }
  report.outlier_share = static_cast<double>(outliers) / static_cast<double>(std::max<long>(1, report.frames));
  for (double e : label_errors) report.label_mean_deg += e;
  report.label_mean_deg /= static_cast<double>(std::max<std::size_t>(1, label_errors.size()));
  report.label_thumb_deg = thumb_error / static_cast<double>(std::max<long>(1, thumb_count));
  report.label_p95_deg = core::percentile(label_errors, 0.95);
  report.age_min = *std::min_element(ages.begin(), ages.end());
  report.age_max = *std::max_element(ages.begin(), ages.end());
  report.age_median = core::percentile(ages, 0.5);
  const hand::JointLimits limits;
  for (std::size_t d = 0; d < hand::kDofCount; ++d) {
    auto& out = report.dofs[d];
    out.p1 = core::percentile(angles[d], 0.01);
    out.p99 = core::percentile(angles[d], 0.99);
    out.coverage = (out.p99 - out.p1) / (limits.max()[d] - limits.min()[d]);
    std::array<long, 10> bins{};
    for (double a : angles[d]) {
      const double u = (a - limits.min()[d]) / (limits.max()[d] - limits.min()[d]);
      ++bins[static_cast<std::size_t>(std::clamp(static_cast<int>(u * 10.0), 0, 9))];
    }
    for (long b : bins) out.bins_used += static_cast<double>(b) >= 0.005 * static_cast<double>(angles[d].size()) ? 1 : 0;
  }

  // Noise: the first session again without readout imperfections, same motion.
  const SessionRecording* first = nullptr;
  for (const SessionRecording& s : corpus)
    if (s.glove == 0 && s.kind == RecordingKind::Session) {
      first = &s;
      break;
    }
  {
    const SessionSetup setup = setup_session(config, world, *first);
    RecordingConfig quiet = config.recording;
    quiet.noise = ReadoutNoise{0.0, 0.0, 0.0, 0.0, 0.0, 0.0};
    const Recording clean = setup.record(world.subjects[static_cast<std::size_t>(first->subject)].distal_radius(), config, quiet);
    const Recording& noisy = first->recording;
    for (int c = 0; c < kCells; ++c) {
      double sum = 0.0, sq = 0.0;
      for (int f = 0; f < noisy.frames; ++f) {
        const double e =
            double(noisy.cells[static_cast<std::size_t>(f * kCells + c)]) - clean.cells[static_cast<std::size_t>(f * kCells + c)];
        sum += e;
        sq += e * e;
      }
      const double mean = sum / noisy.frames;
      auto& out = report.cells[static_cast<std::size_t>(c)];
      out.noise_sd = std::sqrt(std::max(0.0, sq / noisy.frames - mean * mean));
      out.p1 = core::percentile(values[static_cast<std::size_t>(c)], 0.01);
      out.p99 = core::percentile(values[static_cast<std::size_t>(c)], 0.99);
      out.snr = (out.p99 - out.p1) / std::max(1e-12, out.noise_sd);
    }
  }

  // Re-donning against pose change, noise-free, over the gallery, every subject, donnings 0 and 1.
  {
    double redon = 0.0, pose = 0.0;
    long redon_n = 0, pose_n = 0;
    for (const Subject& subject : world.subjects) {
      std::array<std::vector<CellArray>, 2> readings;
      for (int donning = 0; donning < 2; ++donning) {
        const GlovePhysics physics(subject, world.gloves[0], donning_fit(config, subject, world.gloves[0], donning));
        for (const KeyPose& k : world.gallery) {
          CellArray c{};
          physics.capacitances(k.angles, c);
          readings[static_cast<std::size_t>(donning)].push_back(c);
        }
      }
      for (int c = 0; c < kCells; ++c) {
        const auto i = static_cast<std::size_t>(c);
        double lo = 1e300, hi = -1e300;
        for (const CellArray& r : readings[0]) {
          lo = std::min(lo, r[i]);
          hi = std::max(hi, r[i]);
        }
        const double range = std::max(1e-9, hi - lo);
        for (std::size_t p = 0; p < readings[0].size(); ++p) {
          redon += std::abs(readings[1][p][i] - readings[0][p][i]) / range;
          ++redon_n;
          for (std::size_t q = p + 1; q < readings[0].size(); ++q) {
            pose += std::abs(readings[0][q][i] - readings[0][p][i]) / range;
            ++pose_n;
          }
        }
      }
    }
    report.redonning_change = redon / static_cast<double>(redon_n);
    report.pose_change = pose / static_cast<double>(pose_n);
  }

  // Difficulty: linear maps on on-the-fly calibrated cells, glove 0.
  {
    struct Part {
      int subject, session;
      Eigen::MatrixXd x, raw, y;
    };
    std::vector<Part> parts;
    for (std::size_t i = 0; i + 1 < corpus.size(); ++i)
      if (corpus[i].glove == 0 && corpus[i].kind == RecordingKind::Calibration) {
        Part part{corpus[i].subject, corpus[i].session, {}, {}, {}};
        detail::calibrated(corpus[i].recording, corpus[i + 1].recording, part.x, part.raw, part.y);
        parts.push_back(std::move(part));
      }
    const Eigen::Index features = kCells + 1;
    // Leave one subject out, from the calibrated or the raw cells (a common per-cell scaling, as
    // training-data min-max calibration is, changes nothing for a linear map with a bias).
    const auto cross = [&](Eigen::MatrixXd Part::*cells) {
      double sum = 0.0;
      for (int held = 0; held < config.subjects; ++held) {
        Eigen::MatrixXd xtx = Eigen::MatrixXd::Zero(features, features), xty = Eigen::MatrixXd::Zero(features, hand::kDofCount);
        for (const Part& p : parts)
          if (p.subject != held) {
            xtx += (p.*cells).transpose() * (p.*cells);
            xty += (p.*cells).transpose() * p.y;
          }
        const Eigen::MatrixXd w = detail::fit_linear(xtx, xty);
        double err = 0.0;
        long n = 0;
        for (const Part& p : parts)
          if (p.subject == held) {
            err += detail::mean_abs_deg(p.*cells, p.y, w) * static_cast<double>(p.y.rows());
            n += p.y.rows();
          }
        sum += err / static_cast<double>(n);
      }
      return sum / config.subjects;
    };
    double same = 0.0;
    for (const Part& p : parts) {
      const Eigen::Index train = p.x.rows() * 2 / 3, test = p.x.rows() - train;
      const Eigen::MatrixXd w =
          detail::fit_linear(p.x.topRows(train).transpose() * p.x.topRows(train), p.x.topRows(train).transpose() * p.y.topRows(train));
      same += detail::mean_abs_deg(p.x.bottomRows(test), p.y.bottomRows(test), w);
    }
    report.linear_cross_deg = cross(&Part::x);
    report.linear_uncalibrated_deg = cross(&Part::raw);
    report.linear_same_deg = same / static_cast<double>(parts.size());
    // Table 1's personal splits: fit on `train` sessions, mean abs error on `test`, averaged over subjects.
    const auto personal = [&](int first, int last, int test) {
      double sum = 0.0;
      for (int subject = 0; subject < config.subjects; ++subject) {
        Eigen::MatrixXd xtx = Eigen::MatrixXd::Zero(features, features), xty = Eigen::MatrixXd::Zero(features, hand::kDofCount);
        for (const Part& p : parts)
          if (p.subject == subject && p.session >= first && p.session <= last) {
            xtx += p.x.transpose() * p.x;
            xty += p.x.transpose() * p.y;
          }
        const Eigen::MatrixXd w = detail::fit_linear(xtx, xty);
        for (const Part& p : parts)
          if (p.subject == subject && p.session == test) sum += detail::mean_abs_deg(p.x, p.y, w);
      }
      return sum / config.subjects;
    };
    if (config.sessions >= 5 && config.intra_sessions == 3) {
      report.linear_intra_deg = personal(0, 1, 2);
      report.linear_inter_deg = personal(0, 3, 4);
    }
  }
  return report;
}

/// @brief The report as text.
inline std::string format_report(const RealismReport& r) {
  std::string out;
  char line[256];
  const auto add = [&](const char* fmt, auto... args) {
    std::snprintf(line, sizeof line, fmt, args...);
    out += line;
  };
  add("glovepose simulated corpus: world %s%s%s, seed %llu, %d subjects x %d sessions x %.2f min (glove 0), %d glove(s), calibration %.0f s\n",
      r.config.world.name, r.config.world.ablated.empty() ? "" : " without ", r.config.world.ablated.c_str(),
      static_cast<unsigned long long>(r.config.seed), r.config.subjects, r.config.sessions, r.config.minutes, r.config.gloves,
      r.config.calibration_seconds);
  if (!r.config.world.settings.empty()) out += "world parameters set: " + r.config.world.settings + "\n";
  add("frames analysed: %ld (glove 0 sessions)\n\n", r.frames);
  out += "Per-cell signal (C_c, pF): 1st..99th percentile, noise SD against the noise-free recording, SNR\n";
  const sensor::TraceLayout layout = sensor::TraceLayout::glauser2019();
  for (int c = 0; c < kCells; ++c) {
    const auto& s = r.cells[static_cast<std::size_t>(c)];
    add("  %-52s %7.2f..%7.2f  noise %.3f  SNR %6.1f\n", layout.cell_name(c).c_str(), s.p1, s.p99, s.noise_sd, s.snr);
  }
  out += "\nPer-DoF coverage of the joint range: 1st..99th percentile (deg), share of the range, bins of 10 used\n";
  const hand::JointLimits limits;
  for (std::size_t d = 0; d < hand::kDofCount; ++d) {
    const auto& s = r.dofs[d];
    add("  %-24s %7.1f..%6.1f of %7.1f..%6.1f  %5.1f%%  %2d/10\n", hand::kDofs[d].name, s.p1 * core::kDegreesPerRadian, s.p99 * core::kDegreesPerRadian,
        limits.min()[d] * core::kDegreesPerRadian, limits.max()[d] * core::kDegreesPerRadian, 100.0 * s.coverage, s.bins_used);
  }
  add("\nRe-donning vs pose change (gallery poses, noise-free, mean |dC| / cell range): re-donning %.3f, pose change %.3f (ratio %.2f)\n",
      r.redonning_change, r.pose_change, r.redonning_change / r.pose_change);
  add("Oldest reading behind each frame: min %.1f ms, median %.1f ms, max %.1f ms (paper: 45-90 ms)\n", 1e3 * r.age_min, 1e3 * r.age_median,
      1e3 * r.age_max);
  add("Outlier frames (collision energy of the labels > 80): %.2f%% (paper: about 2%%)\n", 100.0 * r.outlier_share);
  add("Labels against the truth (the reference tracker's error): mean %.2f deg, thumb %.2f deg, p95 %.1f deg\n", r.label_mean_deg,
      r.label_thumb_deg, r.label_p95_deg);
  add("Difficulty, linear least squares from on-the-fly calibrated cells to the labels: leave-one-subject-out %.2f deg, same session %.2f deg (ratio "
      "%.2f)\n",
      r.linear_cross_deg, r.linear_same_deg, r.linear_cross_deg / r.linear_same_deg);
  add("Linear least squares leaving one subject out without calibration (raw cells): %.2f deg (paper's U-Net without and with calibration: 8.3 vs "
      "7.6)\n",
      r.linear_uncalibrated_deg);
  if (!std::isnan(r.linear_intra_deg))
    add("Personal linear maps on Table 1's splits: intra (sessions 0, 1 -> 2, one donning) %.2f deg, inter (0-3 -> 4, re-donned) %.2f deg "
        "(paper's U-Net: 5.8 vs 6.2)\n",
        r.linear_intra_deg, r.linear_inter_deg);
  return out;
}

}  // namespace glovepose::sim
