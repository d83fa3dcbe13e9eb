/// @file soak.hpp
/// @brief A test harness, not part of the installed library (it reads the process's resident
/// memory and reports in the command's terms). The soak run: several estimators, on threads, sharing one loaded model, each fed a long
/// simulated row stream at 60 Hz with random faults (sim/faults.hpp), with every readout cycle
/// accounted for. Used by tests/test_soak.cpp (bounded, in CI) and `glovepose soak` (hours).
///
/// The stream: a simulated session with raw rows (simulate_soak_source). Each estimator first
/// calibrates on the fly on the session's calibration sequence, then plays the session's rows over
/// and over, forward and backward in turn (so the motion stays continuous where it turns), with
/// timestamps on a fresh 60 Hz clock that keeps running forward. Simulating hours of motion costs
/// about 1 s of CPU per 10 s of stream, so a few minutes are looped; the faults differ every pass.
///
/// The faults: clean stretches (clean_seconds_min .. _max) alternate with faults of a random
/// target and length (fault_seconds_min .. _max); the kinds come in shuffled rounds of all eleven.
/// Each estimator draws its own from the seed.
///
/// The accounting: every cycle (the 180 clean readings of one 60 Hz frame, whatever the fault made
/// of them) ends in exactly one of: a new trusted pose, a new flagged pose, or no new pose with the
/// statuses of push_row that explain it (Uncalibrated, NotReady after a restart, rejected
/// readings) or no reading delivered at all (unplugged). Every new pose is checked: sequence one
/// more than the last, 25 finite angles. After each fault the cycles until a cycle ends in a
/// trusted pose again are its recovery, bounded by recovery_bound_cycles. Resident memory is read
/// after a warm-up and at the end; heap allocations in between are counted when a counter is given.
#pragma once

#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <exception>
#include <functional>
#include <memory>
#include <optional>
#include <ostream>
#include <string>
#include <thread>
#include <vector>

#ifdef _WIN32
#  include <windows.h>
#  include <psapi.h>
#else
#  include <sys/resource.h>
#  include <unistd.h>
#endif

#include <glovepose/core/statistics.hpp>
#include <glovepose/estimator.hpp>
#include <glovepose/sim/corpus_dataset.hpp>
#include <glovepose/sim/faults.hpp>

namespace glovepose::sim {

/// @brief Settings of a soak run.
struct SoakConfig {
  double stream_minutes = 3.0;     ///< Simulated stream per estimator after its calibration, minutes.
  int estimators = 3;              ///< Estimators, one thread each, sharing the model.
  std::uint64_t seed = 1;          ///< Faults (kinds, targets, lengths, random readings) derive from it.
  double warmup_seconds = 10.0;    ///< Stream each estimator plays after its calibration before memory is first read.
  double clean_seconds_min = 2.0;  ///< Shortest clean stretch between two faults (longer than any recovery).
  double clean_seconds_max = 6.0;  ///< Longest clean stretch.
  double fault_seconds_min = 0.5;  ///< Shortest fault.
  double fault_seconds_max = 3.0;  ///< Longest fault.
  /// Most cycles after a fault's end before a cycle ends in a trusted pose again. A restart (gap,
  /// clock jump) needs one cycle to see every row and mean_window - 1 more to fill the rows' mean;
  /// tests/test_faults.cpp checks 6-7 frames; 12 (0.2 s) leaves room for the simulator's own rare
  /// spikes, which can flag a frame of the clean stream.
  int recovery_bound_cycles = 12;
  /// Most growth of the resident set from the end of the warm-up to the end of the run, KiB. Nothing
  /// on the per-frame path allocates, so only the odd page (a thread's stack, the C library) may.
  long rss_growth_tolerance_kib = 1024;
  /// Process-wide count of heap allocations (e.g. tests/alloc_counter.hpp); when given, the run
  /// fails on any allocation between the warm-up and the end. Empty: not counted.
  std::function<std::size_t()> allocation_count;
  /// Settings of every estimator (readout window, fault thresholds, smoothing).
  EstimatorConfig estimator{};

  /// @brief Throws glovepose::Error naming the first setting out of range.
  void validate() const {
    const auto need = [](bool ok, const std::string& what) {
      if (!ok) throw Error("soak: " + what);
    };
    need(stream_minutes > 0.0 && std::isfinite(stream_minutes), "--minutes " + std::to_string(stream_minutes) + ", expected > 0");
    need(estimators >= 1 && estimators <= 64, "--estimators " + std::to_string(estimators) + ", expected 1..64");
    need(warmup_seconds >= 0.0 && warmup_seconds < stream_minutes * 60.0, "warm-up " + std::to_string(warmup_seconds) +
                                                                              " s, expected 0 <= warm-up < the stream (" +
                                                                              std::to_string(stream_minutes * 60.0) + " s)");
    need(clean_seconds_min > 0.0 && clean_seconds_max >= clean_seconds_min, "clean stretches of " + std::to_string(clean_seconds_min) +
                                                                                ".." + std::to_string(clean_seconds_max) +
                                                                                " s, expected 0 < min <= max");
    need(fault_seconds_min > 0.0 && fault_seconds_max >= fault_seconds_min,
         "faults of " + std::to_string(fault_seconds_min) + ".." + std::to_string(fault_seconds_max) + " s, expected 0 < min <= max");
    need(recovery_bound_cycles >= 1, "recovery bound " + std::to_string(recovery_bound_cycles) + " cycles, expected at least 1");
    need(rss_growth_tolerance_kib >= 0, "memory tolerance " + std::to_string(rss_growth_tolerance_kib) + " KiB, expected >= 0");
  }
};

/// @brief A simulated session with raw rows to loop: one subject, `minutes` of motion after a
/// `calibration_seconds` calibration sequence. Set-up code (CPU-heavy: about 1 s per 10 s of motion
/// on `threads` threads, 0: all).
inline io::Dataset simulate_soak_source(std::uint64_t seed, double minutes, double calibration_seconds = 3.0, int threads = 0) {
  CorpusConfig config;
  config.seed = seed;
  config.subjects = 1;
  config.sessions = 1;
  config.intra_sessions = 1;
  config.gloves = 1;
  config.minutes = minutes;
  config.calibration_seconds = calibration_seconds;
  config.threads = threads;
  config.recording.raw_rows = true;  // default noise: readout jitter, rare spikes and drops
  return to_dataset(simulate_corpus(config), config);
}

/// @brief Why a cycle ended without a new pose (SoakReport::no_pose_cycles).
enum class NoPoseReason : std::uint8_t {
  Uncalibrated,  ///< push_row returned Status::Uncalibrated (frames solved before the calibration finished).
  NotReady,      ///< push_row returned Status::NotReady (rows unseen since the start or a restart).
  Rejected,      ///< push_row rejected readings (out of order, NaN, ...) and too few were accepted to solve.
  NoReadings,    ///< No reading arrived at all (the glove was unplugged).
  Unexplained,   ///< None of these: a lost frame. The run fails.
};
/// @brief Number of NoPoseReason values.
inline constexpr int kNoPoseReasonCount = 5;
/// @brief Number of Status values (status.hpp numbers them 0 .. Uncalibrated).
inline constexpr int kStatusCount = static_cast<int>(Status::Uncalibrated) + 1;

/// @brief A short name of a NoPoseReason.
constexpr const char* to_string(NoPoseReason reason) noexcept {
  constexpr const char* names[] = {"uncalibrated", "not ready (restart)", "readings rejected", "no reading arrived (unplugged)",
                                   "UNEXPLAINED"};  // in the enum's order
  static_assert(sizeof names / sizeof names[0] == kNoPoseReasonCount, "one name per reason");
  return name_of(reason, names, "unknown");
}

/// @brief The figures of a soak run, summed over the estimators.
struct SoakReport {
  /// @brief Recoveries of one fault kind: histogram of cycles (the last bucket: beyond the bound).
  struct Recoveries {
    std::vector<std::uint64_t> histogram;  ///< histogram[c]: faults back to a trusted pose after c cycles.
    std::uint64_t count = 0;               ///< Faults whose recovery was measured.
    long max = 0;                          ///< Longest recovery, cycles (exact, also beyond the bound).
  };

  // What ran.
  int estimators = 0;
  std::uint64_t seed = 0;
  double stream_seconds = 0.0;       ///< Simulated stream per estimator after calibration.
  double source_seconds = 0.0;       ///< Simulated motion looped.
  double calibration_seconds = 0.0;  ///< Calibration sequence each estimator starts with.
  int recovery_bound_cycles = 0;
  long rss_growth_tolerance_kib = 0;
  double wall_seconds = 0.0;

  // Frames.
  std::uint64_t cycles = 0;                                        ///< Readout cycles (60 Hz frames) over all estimators.
  std::uint64_t readings = 0;                                      ///< Readings pushed (after the faults).
  std::uint64_t poses = 0;                                         ///< New poses.
  std::uint64_t trusted_poses = 0;                                 ///< Of which trusted (no fault flag).
  std::array<std::uint64_t, kPoseFlagCount> poses_by_flag{};       ///< Poses carrying each PoseFlag bit.
  std::uint64_t trusted_cycles = 0;                                ///< Cycles that ended in a new trusted pose.
  std::uint64_t flagged_cycles = 0;                                ///< Cycles that ended in a new flagged pose.
  std::array<std::uint64_t, kNoPoseReasonCount> no_pose_cycles{};  ///< Cycles without a new pose, by reason.
  std::array<std::uint64_t, kStatusCount> statuses{};              ///< push_row's answers, by status.

  // Faults.
  std::array<std::uint64_t, kFaultKindCount> faults{};            ///< Faults injected, by kind.
  std::array<std::uint64_t, kFaultKindCount> altered_readings{};  ///< Clean readings lost, repeated, delayed or changed, by kind.
  std::array<Recoveries, kFaultKindCount> recoveries{};           ///< By kind.

  // Failures of the per-pose checks.
  std::uint64_t non_finite_poses = 0;  ///< New poses with a non-finite angle.
  std::uint64_t sequence_errors = 0;   ///< New poses whose sequence was not the last one plus one (or moved without one).

  // Memory.
  long rss_after_warmup_kib = 0;  ///< Resident set when every estimator had warmed up (0: not measurable here).
  long rss_end_kib = 0;           ///< Resident set at the end.
  long peak_rss_kib = 0;          ///< Peak resident set of the process (getrusage).
  bool allocations_counted = false;
  std::size_t allocations = 0;  ///< Heap allocations between the warm-up and the end (when counted).

  std::vector<std::string> errors;  ///< Set-up errors raised on the estimators' threads.

  /// @brief Recovery, in cycles, that `share` (0..1) of all faults stayed within (from the histograms).
  long recovery_quantile(double share) const {
    std::vector<std::uint64_t> all(static_cast<std::size_t>(recovery_bound_cycles) + 2, 0);
    std::uint64_t total = 0;
    for (const Recoveries& r : recoveries) {
      for (std::size_t c = 0; c < r.histogram.size() && c < all.size(); ++c) all[c] += r.histogram[c];
      total += r.count;
    }
    if (total == 0) return 0;
    return static_cast<long>(core::bin_of_rank(all, core::nearest_rank(total, share)));
  }
  /// @brief Longest recovery over all kinds, cycles.
  long recovery_max() const {
    long worst = 0;
    for (const Recoveries& r : recoveries) worst = std::max(worst, r.max);
    return worst;
  }

  /// @brief What went wrong; empty when the run passed.
  std::vector<std::string> failures() const {
    std::vector<std::string> out = errors;
    const auto fail = [&](bool bad, const std::string& what) {
      if (bad) out.push_back(what);
    };
    const std::uint64_t unexplained = no_pose_cycles[static_cast<std::size_t>(NoPoseReason::Unexplained)];
    fail(unexplained > 0, std::to_string(unexplained) + " cycles ended without a new pose and without a status explaining it");
    fail(non_finite_poses > 0, std::to_string(non_finite_poses) + " poses with a non-finite angle");
    fail(sequence_errors > 0, std::to_string(sequence_errors) + " poses whose sequence did not follow the last one");
    fail(trusted_cycles + flagged_cycles + no_pose_total() != cycles,
         "cycles accounted " + std::to_string(trusted_cycles + flagged_cycles + no_pose_total()) + ", expected " + std::to_string(cycles));
    fail(recovery_max() > recovery_bound_cycles,
         "a recovery took " + std::to_string(recovery_max()) + " cycles, expected at most " + std::to_string(recovery_bound_cycles));
    fail(rss_after_warmup_kib > 0 && rss_end_kib - rss_after_warmup_kib > rss_growth_tolerance_kib,
         "resident memory grew by " + std::to_string(rss_end_kib - rss_after_warmup_kib) + " KiB after the warm-up, expected at most " +
             std::to_string(rss_growth_tolerance_kib));
    fail(allocations_counted && allocations > 0,
         std::to_string(allocations) + " heap allocations after the warm-up, expected none on the per-frame path");
    return out;
  }
  /// @brief Whether every check held.
  bool passed() const { return failures().empty(); }

  /// @brief Cycles without a new pose, all reasons.
  std::uint64_t no_pose_total() const {
    std::uint64_t n = 0;
    for (std::uint64_t c : no_pose_cycles) n += c;
    return n;
  }

  /// @brief The figures, as printed by `glovepose soak` and the test.
  void print(std::ostream& out) const {
    char line[256];
    const auto put = [&](const char* format, auto... values) {
      std::snprintf(line, sizeof line, format, values...);
      out << line;
    };
    const auto share = [](std::uint64_t part, std::uint64_t whole) {
      return whole ? 100.0 * static_cast<double>(part) / static_cast<double>(whole) : 0.0;
    };
    put("soak: %d estimators x %.1f min of 60 Hz stream (%.2f h in all), seed %llu, one shared model\n", estimators, stream_seconds / 60.0,
        estimators * stream_seconds / 3600.0, static_cast<unsigned long long>(seed));
    put("  source: %.0f s of simulated motion looped forward and backward, after a %.0f s calibration sequence\n", source_seconds,
        calibration_seconds);
    put("  wall time %.1f s\n", wall_seconds);
    put("frames: %llu cycles, %llu readings pushed, %llu poses (%.1f%% trusted)\n", static_cast<unsigned long long>(cycles),
        static_cast<unsigned long long>(readings), static_cast<unsigned long long>(poses), share(trusted_poses, poses));
    put("  cycles ending in a trusted pose  %12llu (%.2f%%)\n", static_cast<unsigned long long>(trusted_cycles),
        share(trusted_cycles, cycles));
    put("  cycles ending in a flagged pose  %12llu (%.2f%%)\n", static_cast<unsigned long long>(flagged_cycles),
        share(flagged_cycles, cycles));
    for (int r = 0; r < kNoPoseReasonCount; ++r)
      put("  no new pose: %-30s %8llu\n", to_string(static_cast<NoPoseReason>(r)),
          static_cast<unsigned long long>(no_pose_cycles[static_cast<std::size_t>(r)]));
    out << "  poses by flag:";
    for (int b = 0; b < kPoseFlagCount; ++b)
      if (poses_by_flag[static_cast<std::size_t>(b)])
        put(" %s %llu;", pose_flag_name(b), static_cast<unsigned long long>(poses_by_flag[static_cast<std::size_t>(b)]));
    out << "\n  push_row statuses:";
    for (int s = 0; s < kStatusCount; ++s)
      if (statuses[static_cast<std::size_t>(s)])
        put(" %s %llu;", glovepose::to_string(static_cast<Status>(s)),
            static_cast<unsigned long long>(statuses[static_cast<std::size_t>(s)]));
    out << "\nfaults (kind: injected, readings altered, recovery cycles p99 / max):\n";
    std::uint64_t fault_total = 0;
    for (int k = 0; k < kFaultKindCount; ++k) {
      const auto i = static_cast<std::size_t>(k);
      fault_total += faults[i];
      put("  %-20s %6llu %12llu   %3ld / %3ld\n", to_string(static_cast<FaultKind>(k)), static_cast<unsigned long long>(faults[i]),
          static_cast<unsigned long long>(altered_readings[i]), kind_quantile(i, 0.99), recoveries[i].max);
    }
    put("recoveries: %llu faults, p50 %ld, p99 %ld, max %ld cycles (bound %d)\n", static_cast<unsigned long long>(fault_total),
        recovery_quantile(0.5), recovery_quantile(0.99), recovery_max(), recovery_bound_cycles);
    put("memory: resident %ld KiB after warm-up, %ld KiB at the end (growth %ld KiB, tolerance %ld), peak %ld KiB\n", rss_after_warmup_kib,
        rss_end_kib, rss_end_kib - rss_after_warmup_kib, rss_growth_tolerance_kib, peak_rss_kib);
    if (allocations_counted)
      put("  heap allocations after the warm-up: %zu\n", allocations);
    else
      out << "  heap allocations: not counted (preload the counter: LD_PRELOAD=build/tools/libglovepose_alloc_counter.so)\n";
    const std::vector<std::string> failed = failures();
    for (const std::string& f : failed) out << "FAILED: " << f << "\n";
    out << (failed.empty() ? "soak: passed\n" : "soak: FAILED\n");
  }

 private:
  long kind_quantile(std::size_t kind, double q) const {
    const Recoveries& r = recoveries[kind];
    if (r.count == 0) return 0;
    return static_cast<long>(core::bin_of_rank(r.histogram, core::nearest_rank(r.count, q)));
  }
};

#ifdef _WIN32
/// @brief The process's working set now and at its peak, KiB (Windows' resident set).
inline long resident_kib() {
  PROCESS_MEMORY_COUNTERS counters{};
  return GetProcessMemoryInfo(GetCurrentProcess(), &counters, sizeof counters) ? static_cast<long>(counters.WorkingSetSize / 1024) : 0;
}
inline long peak_resident_kib() {
  PROCESS_MEMORY_COUNTERS counters{};
  return GetProcessMemoryInfo(GetCurrentProcess(), &counters, sizeof counters) ? static_cast<long>(counters.PeakWorkingSetSize / 1024) : 0;
}
#else
/// @brief The process's resident set now, KiB (Linux /proc/self/statm; 0 where unavailable).
inline long resident_kib() {
  std::FILE* f = std::fopen("/proc/self/statm", "r");
  if (!f) return 0;
  long pages_total = 0, pages_resident = 0;
  const int read = std::fscanf(f, "%ld %ld", &pages_total, &pages_resident);
  std::fclose(f);
  return read == 2 ? pages_resident * (sysconf(_SC_PAGESIZE) / 1024) : 0;
}

/// @brief The process's peak resident set so far, KiB.
inline long peak_resident_kib() {
  rusage usage{};
  return getrusage(RUSAGE_SELF, &usage) == 0 ? usage.ru_maxrss : 0;  // Linux reports KiB
}
#endif

namespace detail {

// Readout cycles per second of the source's session (its frames are the cycles' ends).
inline double cycle_rate(const io::Dataset& source) noexcept {
  const std::size_t first = source.first_session_frame(), last = source.frames() - 1;
  return static_cast<double>(last - first) / (source.timestamps[last] - source.timestamps[first]);
}

/// One estimator's stream, its faults and its tally. Everything is allocated at construction;
/// run_cycle() is the per-frame path and neither allocates nor throws.
class SoakStream {
 public:
  SoakStream(std::shared_ptr<const PoseModel> model, const io::Dataset& source, const SoakConfig& config, int index)
      : estimator_(std::move(model), config.estimator),
        source_(source),
        config_(config),
        layout_(estimator_.model().solver()->layout()),
        rng_(core::derive_seed(config.seed, {static_cast<std::uint64_t>(index)})) {
    rows_ = static_cast<int>(source.row_count);
    calibration_frames_ = source.first_session_frame();
    session_frames_ = source.frames() - calibration_frames_;
    cycles_per_second_ = cycle_rate(source);
    cycle_seconds_ = 1.0 / cycles_per_second_;
    row_clock_ = {source.row_count, cycles_per_second_};
    // Each estimator starts the loop at its own place, so they do not play the same motion.
    loop_offset_ = static_cast<std::size_t>(index) * session_frames_ / static_cast<std::size_t>(std::max(1, config.estimators));
    total_cycles_ = calibration_frames_ + seconds_to_cycles(config.stream_minutes * 60.0);
    warmup_end_ = calibration_frames_ + seconds_to_cycles(config.warmup_seconds);
    clean_left_ = draw_cycles(config.clean_seconds_min, config.clean_seconds_max);  // counted from the warm-up's end
    for (auto& r : report_.recoveries) r.histogram.assign(static_cast<std::size_t>(config.recovery_bound_cycles) + 2, 0);
    estimator_.start_calibration();
  }

  std::uint64_t warmup_end() const noexcept { return warmup_end_; }
  std::uint64_t total_cycles() const noexcept { return total_cycles_; }
  const SoakReport& report() const noexcept { return report_; }

  /// Plays cycle `cycle_` and accounts for it. Set-up code at the end of the calibration
  /// (finish_calibration may throw); the per-frame path otherwise.
  void run_cycle() {
    if (cycle_ == calibration_frames_) (void)estimator_.finish_calibration();
    step_schedule();
    const float* rows = frame_rows();
    const double cycle_end = static_cast<double>(cycle_ + 1) * cycle_seconds_;
    std::array<bool, kStatusCount> seen{};
    std::uint64_t pushed = 0;
    for (int r = 0; r < rows_; ++r) {
      const Reading clean{r, static_cast<double>(rows[r]), row_clock_.time(cycle_end, static_cast<std::size_t>(r))};
      InjectedReadings delivered;
      if (fault_)
        delivered = fault_->apply(clean);
      else
        delivered.push_back(clean);
      for (const Reading& x : delivered) {
        const Status status = estimator_.push_row(x.row, x.value, x.timestamp);
        ++pushed;
        seen[static_cast<std::size_t>(status)] = true;
        ++report_.statuses[static_cast<std::size_t>(status)];
        check_pose(status);
      }
    }
    report_.readings += pushed;
    account_cycle(seen, pushed);
    ++cycle_;
  }

  /// Ends the run: a fault still active or a recovery still pending counts as not recovered.
  void finish() noexcept {
    if (fault_) end_fault();
    if (recovering_) record_recovery(config_.recovery_bound_cycles + 1 + recovery_cycles_);
    report_.cycles = cycle_;
  }

 private:
  std::uint64_t seconds_to_cycles(double seconds) const noexcept {
    return static_cast<std::uint64_t>(std::llround(seconds * cycles_per_second_));
  }
  std::uint64_t draw_cycles(double lo, double hi) noexcept { return std::max<std::uint64_t>(1, seconds_to_cycles(rng_.uniform(lo, hi))); }

  // The clean rows of the current cycle: the calibration sequence once, then the session forward
  // and backward in turn.
  const float* frame_rows() const noexcept {
    std::size_t frame = cycle_;
    if (cycle_ >= calibration_frames_) {
      const std::size_t period = 2 * session_frames_;
      const std::size_t q = (cycle_ - calibration_frames_ + loop_offset_) % period;
      frame = calibration_frames_ + (q < session_frames_ ? q : period - 1 - q);
    }
    return source_.raw_rows.data() + frame * static_cast<std::size_t>(rows_);
  }

  // Starts and ends faults at cycle boundaries.
  void step_schedule() noexcept {
    if (fault_) {
      if (--fault_left_ > 0) return;
      end_fault();
      clean_left_ = draw_cycles(config_.clean_seconds_min, config_.clean_seconds_max);
      return;
    }
    if (cycle_ < warmup_end_ || --clean_left_ > 0) return;
    const std::uint64_t length = draw_cycles(config_.fault_seconds_min, config_.fault_seconds_max);
    // The run ends with a clean stretch long enough to see the last recovery.
    if (cycle_ + length + seconds_to_cycles(config_.clean_seconds_min) >= total_cycles_) {
      clean_left_ = total_cycles_;
      return;
    }
    if (recovering_) record_recovery(config_.recovery_bound_cycles + 1 + recovery_cycles_);  // cut short: counts as too long
    FaultSettings settings;
    settings.lost_bottom_trace = rng_.index(layout_.bottom_traces());
    settings.stuck_row = rng_.index(layout_.row_count());
    settings.disconnected_top_trace = rng_.index(layout_.top_traces());
    const FaultKind kind = next_kind();
    fault_.emplace(kind, layout_, rng_.next(), settings);  // validated settings: never throws
    fault_left_ = length;
    ++report_.faults[static_cast<std::size_t>(kind)];
  }

  // Kinds come in rounds of all kinds, shuffled: every kind equally often, in a varying order.
  FaultKind next_kind() noexcept {
    if (round_next_ == kFaultKindCount) {
      for (int k = 0; k < kFaultKindCount; ++k) round_[static_cast<std::size_t>(k)] = static_cast<FaultKind>(k);
      for (int k = kFaultKindCount - 1; k > 0; --k)
        std::swap(round_[static_cast<std::size_t>(k)], round_[static_cast<std::size_t>(rng_.index(k + 1))]);
      round_next_ = 0;
    }
    return round_[static_cast<std::size_t>(round_next_++)];
  }

  void end_fault() noexcept {
    const auto kind = static_cast<std::size_t>(fault_->kind());
    report_.altered_readings[kind] += fault_->altered_readings();
    recovering_kind_ = kind;
    recovering_ = true;
    recovery_cycles_ = 0;
    fault_.reset();
  }

  void record_recovery(long cycles) noexcept {
    SoakReport::Recoveries& r = report_.recoveries[recovering_kind_];
    const auto bucket = std::min<std::size_t>(static_cast<std::size_t>(cycles), r.histogram.size() - 1);
    ++r.histogram[bucket];
    ++r.count;
    r.max = std::max(r.max, cycles);
    recovering_ = false;
  }

  // Every push: a new pose exactly when push_row says Solved, one sequence step, finite angles.
  void check_pose(Status status) noexcept {
    const Pose& pose = estimator_.pose();
    const std::uint64_t expected = last_sequence_ + (status == Status::Solved ? 1 : 0);
    if (pose.sequence != expected) ++report_.sequence_errors;
    last_sequence_ = pose.sequence;
    if (status != Status::Solved) return;
    ++report_.poses;
    bool finite = true;
    for (std::size_t d = 0; d < hand::kDofCount; ++d) finite = finite && std::isfinite(pose.angles[d]) && std::isfinite(pose.raw_angles[d]);
    if (!finite) ++report_.non_finite_poses;
    if (pose.trusted()) ++report_.trusted_poses;
    for (int b = 0; b < kPoseFlagCount; ++b) report_.poses_by_flag[static_cast<std::size_t>(b)] += (pose.flags >> b) & 1u;
  }

  void account_cycle(const std::array<bool, kStatusCount>& seen, std::uint64_t pushed) noexcept {
    const bool fresh = estimator_.pose().sequence != cycle_start_sequence_;
    cycle_start_sequence_ = estimator_.pose().sequence;
    const bool trusted = fresh && estimator_.pose().trusted();
    if (fresh) {
      ++(trusted ? report_.trusted_cycles : report_.flagged_cycles);
    } else {
      const auto saw = [&](Status s) { return seen[static_cast<std::size_t>(s)]; };
      bool rejected = false;
      for (int s = 0; s < kStatusCount; ++s)
        rejected = rejected || (seen[static_cast<std::size_t>(s)] && !accepted(static_cast<Status>(s)) &&
                                static_cast<Status>(s) != Status::Uncalibrated);
      const NoPoseReason reason = saw(Status::Uncalibrated) ? NoPoseReason::Uncalibrated
                                  : saw(Status::NotReady)   ? NoPoseReason::NotReady
                                  : rejected                ? NoPoseReason::Rejected
                                  : pushed == 0             ? NoPoseReason::NoReadings
                                                            : NoPoseReason::Unexplained;
      ++report_.no_pose_cycles[static_cast<std::size_t>(reason)];
    }
    if (!recovering_ || fault_) return;
    if (trusted)
      record_recovery(recovery_cycles_);
    else
      ++recovery_cycles_;
  }

  GlovePoseEstimator estimator_;
  const io::Dataset& source_;
  const SoakConfig& config_;
  const sensor::TraceLayout& layout_;
  core::Rng rng_;
  int rows_ = 0;
  std::size_t calibration_frames_ = 0;
  std::size_t session_frames_ = 0;
  std::size_t loop_offset_ = 0;
  double cycle_seconds_ = 0.0;
  io::RowClock row_clock_;
  double cycles_per_second_ = 0.0;
  std::uint64_t total_cycles_ = 0;
  std::uint64_t warmup_end_ = 0;
  std::uint64_t cycle_ = 0;
  std::uint64_t clean_left_ = 0;
  std::uint64_t fault_left_ = 0;
  std::optional<FaultInjector> fault_;
  std::array<FaultKind, kFaultKindCount> round_{};
  int round_next_ = kFaultKindCount;
  bool recovering_ = false;
  std::size_t recovering_kind_ = 0;
  long recovery_cycles_ = 0;
  std::uint64_t last_sequence_ = 0;
  std::uint64_t cycle_start_sequence_ = 0;
  SoakReport report_;
};

}  // namespace detail

/// @brief Runs the soak (see the file comment): config.estimators threads, each with its own
/// estimator over `model`, streaming `source` (simulate_soak_source) with faults. Throws
/// glovepose::Error for bad settings or a source without raw rows, a calibration sequence and
/// a session; errors on the threads are reported in SoakReport::errors.
inline SoakReport run_soak(const std::shared_ptr<const PoseModel>& model, const io::Dataset& source, const SoakConfig& config) {
  config.validate();
  if (!model || !model->solver()) throw Error("soak: no model with a wiring given, expected a loaded PoseModel for the row stream");
  if (!source.has_raw_rows() || static_cast<int>(source.row_count) != model->solver()->layout().row_count())
    throw Error("soak: the source has " + std::to_string(source.row_count) + " raw rows per frame, expected " +
                std::to_string(model->solver()->layout().row_count()) + " (simulate it with raw rows)");
  const std::size_t calibration = source.first_session_frame();
  if (calibration < 20 || source.frames() - calibration < 60)
    throw Error("soak: the source has " + std::to_string(calibration) + " calibration frames and " +
                std::to_string(source.frames() - calibration) + " session frames, expected at least 20 and 60");

  const auto start = std::chrono::steady_clock::now();
  std::vector<std::unique_ptr<detail::SoakStream>> streams;
  for (int e = 0; e < config.estimators; ++e) streams.push_back(std::make_unique<detail::SoakStream>(model, source, config, e));
  std::vector<std::string> errors(static_cast<std::size_t>(config.estimators));
  std::atomic<int> warmed{0};
  std::atomic<bool> go{false};
  const auto wait_for = [](const auto& ready) {
    while (!ready()) std::this_thread::sleep_for(std::chrono::milliseconds(1));
  };
  std::vector<std::thread> threads;
  for (int e = 0; e < config.estimators; ++e)
    threads.emplace_back([&, e] {
      detail::SoakStream& stream = *streams[static_cast<std::size_t>(e)];
      bool counted_in = false;
      try {
        for (std::uint64_t c = 0; c < stream.total_cycles(); ++c) {
          if (c == stream.warmup_end()) {
            warmed.fetch_add(1);
            counted_in = true;
            wait_for([&] { return go.load(); });
          }
          stream.run_cycle();
        }
      } catch (const std::exception& error) {
        errors[static_cast<std::size_t>(e)] = "estimator " + std::to_string(e) + ": " + error.what();
      }
      if (!counted_in) warmed.fetch_add(1);  // never block the others
      stream.finish();
    });

  SoakReport report;
  wait_for([&] { return warmed.load() == config.estimators; });
  report.rss_after_warmup_kib = resident_kib();
  const std::size_t allocations_before = config.allocation_count ? config.allocation_count() : 0;
  go.store(true);
  for (std::thread& t : threads) t.join();
  if (config.allocation_count) {
    report.allocations_counted = true;
    report.allocations = config.allocation_count() - allocations_before;
  }
  report.rss_end_kib = resident_kib();
  report.peak_rss_kib = peak_resident_kib();
  report.wall_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();

  report.estimators = config.estimators;
  report.seed = config.seed;
  report.stream_seconds = config.stream_minutes * 60.0;
  report.source_seconds = static_cast<double>(source.frames() - calibration) / detail::cycle_rate(source);
  report.calibration_seconds = static_cast<double>(calibration) / detail::cycle_rate(source);
  report.recovery_bound_cycles = config.recovery_bound_cycles;
  report.rss_growth_tolerance_kib = config.rss_growth_tolerance_kib;
  for (const std::string& error : errors)
    if (!error.empty()) report.errors.push_back(error);
  for (const auto& stream : streams) {
    const SoakReport& s = stream->report();
    report.cycles += s.cycles;
    report.readings += s.readings;
    report.poses += s.poses;
    report.trusted_poses += s.trusted_poses;
    report.trusted_cycles += s.trusted_cycles;
    report.flagged_cycles += s.flagged_cycles;
    report.non_finite_poses += s.non_finite_poses;
    report.sequence_errors += s.sequence_errors;
    for (std::size_t i = 0; i < report.poses_by_flag.size(); ++i) report.poses_by_flag[i] += s.poses_by_flag[i];
    for (std::size_t i = 0; i < report.no_pose_cycles.size(); ++i) report.no_pose_cycles[i] += s.no_pose_cycles[i];
    for (std::size_t i = 0; i < report.statuses.size(); ++i) report.statuses[i] += s.statuses[i];
    for (std::size_t k = 0; k < report.faults.size(); ++k) {
      report.faults[k] += s.faults[k];
      report.altered_readings[k] += s.altered_readings[k];
      SoakReport::Recoveries& into = report.recoveries[k];
      const SoakReport::Recoveries& from = s.recoveries[k];
      into.histogram.resize(from.histogram.size(), 0);
      for (std::size_t c = 0; c < from.histogram.size(); ++c) into.histogram[c] += from.histogram[c];
      into.count += from.count;
      into.max = std::max(into.max, from.max);
    }
  }
  return report;
}

}  // namespace glovepose::sim
