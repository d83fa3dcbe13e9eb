// What taking the glove off and putting it on again costs, and how well the estimator notices it
// (docs/results.md, "Taking the glove off"). Data: `glovepose simulate --removal-seconds S` with
// guided calibration sequences (--calibration-sequence): the glove is taken off and put on before
// each later donning. Per person, one estimator streams every session and removal in order on one
// clock (the calibration sequences left out: the wearer just puts the glove on and moves); scored
// over the first SECONDS (default 60) of each session after a removal, against the true angles:
//   detected     the default: continuous calibration, the removal noticed, restarted from the profile
//   prior        the same, but restarted from the model's prior range at the detected donning
//   unnoticed    continuous calibration, donnings not watched (EstimatorConfig::donning off)
//   oracle       the same, restarted from the prior at the session's first frame (the donning's time known)
//   guided       that session's own guided calibration (a fresh calibration after putting it on)
//   kept         session 0's guided calibration kept through every donning, donnings not watched
//   guided+      session 0's guided calibration, the removal noticed, then continuous from it as a profile
// Printed too: each removal's detection times (glove off: from the start of the off period;
// donning: from the end of the removal, when the glove is on), the detections in worn frames, and
// the floor of any detector that looks at the cells' level: each frame's RMS relative distance of
// the cells from the glove's own off-the-hand pattern (the median of the first removal's frames
// 2-9 s into its off period), for the glove off the hand and for each person's closest worn frame.
//
//   g++ -std=c++17 -O2 -march=native -Iinclude -isystem /usr/include/eigen3 tools/experiments/redonning.cpp -o redonning -lpthread
//   ./redonning models/glovepose_fcn512.safetensors redon6065.safetensors
#include <glovepose/core/units.hpp>
#include <glovepose/estimator.hpp>
#include <glovepose/io/dataset.hpp>
#include <glovepose/pose_model.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <map>
#include <string>
#include <vector>

using namespace glovepose;

namespace {

struct Mean {
  double sum = 0.0;
  long n = 0;
  void add(double e) { sum += e, ++n; }
  double mean() const { return n ? sum / static_cast<double>(n) : NAN; }
};

double pose_error(const io::Dataset& data, std::size_t i, const Pose& pose) {
  double sum = 0.0;
  for (std::size_t d = 0; d < hand::kDofCount; ++d)
    sum += std::abs(pose.angles[d] - data.true_angles[i * hand::kDofCount + d]) * core::kDegreesPerRadian;
  return sum / hand::kDofCount;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 3) {
    std::fprintf(stderr, "usage: redonning MODEL DATA [SECONDS]\n");
    return 2;
  }
  const auto model = PoseModel::load(argv[1]);
  const io::Dataset data = io::Dataset::read(argv[2]);
  const double window = argc > 3 ? std::atof(argv[3]) : 60.0;
  const double doff = 2.0;  // sim::RemovalConfig::doff_seconds
  const std::size_t C = data.cell_count;
  std::vector<double> row(C);
  std::map<std::string, Mean> pooled;
  std::vector<double> off_delay, on_delay;
  long removals = 0, missed = 0, worn_offs = 0, worn_donnings = 0, late_frames = 0, kept_offs = 0;
  double worn_seconds = 0.0;
  const int subjects = 1 + *std::max_element(data.subject.begin(), data.subject.end());
  for (int s = 0; s < subjects; ++s) {
    std::map<std::pair<int, int>, std::vector<std::size_t>> parts;  // (session, kind) -> frames
    int sessions = 0;
    for (std::size_t i = 0; i < data.frames(); ++i)
      if (data.subject[i] == s && data.glove[i] == 0) parts[{data.session[i], data.kind[i]}].push_back(i), sessions = std::max(sessions, data.session[i] + 1);
    const auto push = [&](GlovePoseEstimator& e, std::size_t i, double t) {
      for (std::size_t c = 0; c < C; ++c) row[c] = data.cells[i * C + c];
      return e.push_cells(row.data(), static_cast<int>(C), t) == Status::Solved;
    };
    const bool guided_sequences = !parts[{0, io::kKindCalibration}].empty();
    const auto calibrated = [&](int session) {
      GlovePoseEstimator e(model);
      e.start_calibration();
      for (std::size_t i : parts[{session, io::kKindCalibration}]) push(e, i, data.timestamps[i]);
      (void)e.finish_calibration();
      return e;
    };
    const auto scored = [&](int session, std::size_t i) {
      return !parts[{session, io::kKindRemoval}].empty() && data.kind[i] == io::kKindRecording &&
             data.timestamps[i] - data.timestamps[parts[{session, io::kKindRecording}].front()] < window;
    };
    // The fresh guided calibration of each session after a removal.
    for (int k = 1; k < sessions; ++k) {
      if (parts[{k, io::kKindRemoval}].empty()) continue;
      GlovePoseEstimator e = calibrated(k);
      for (std::size_t i : parts[{k, io::kKindRecording}])
        if (scored(k, i) && push(e, i, data.timestamps[i]) && e.pose().trusted()) pooled["guided"].add(pose_error(data, i, e.pose()));
    }
    // One estimator through everything, per condition.
    for (const std::string condition : {"detected", "prior", "unnoticed", "oracle", "kept", "guided+"}) {
      EstimatorConfig config;
      if (condition == "unnoticed" || condition == "oracle" || condition == "kept") config.donning.reset();
      if (config.donning) {  // exploration: REDON_SET="off_level on_level off_seconds on_seconds min_motion_frames"
        if (const char* set = std::getenv("REDON_SET"))
          std::sscanf(set, "%lf %lf %lf %lf %lf", &config.donning->off_level, &config.donning->on_level, &config.donning->off_seconds,
                      &config.donning->on_seconds, &config.donning->min_motion_frames);
      }
      GlovePoseEstimator e(model, config);
      const bool from_guided = condition == "kept" || condition == "guided+";
      if (from_guided && !guided_sequences) continue;
      if (from_guided) {
        e.start_calibration();
        for (std::size_t i : parts[{0, io::kKindCalibration}]) push(e, i, data.timestamps[i]);
        (void)e.finish_calibration();
      }
      double offset = 0.0, last = 0.0;
      bool pending_on = false, was_off = false;
      for (int k = 0; k < sessions; ++k)
        for (const int kind : {static_cast<int>(io::kKindRemoval), static_cast<int>(io::kKindRecording)}) {
          const std::vector<std::size_t>& frames = parts[{k, kind}];
          if (frames.empty()) continue;
          offset = last + 1.0 / 60.0 - data.timestamps[frames.front()];
          const bool removal = kind == io::kKindRemoval;
          if (condition == "oracle" && !removal && !parts[{k, io::kKindRemoval}].empty()) e.use_continuous_calibration();
          const double end = data.timestamps[frames.back()];
          bool seen_off = false, seen_on = false;
          const bool seen_off_before = !removal && pending_on;  // a removal whose donning is not noticed yet
          for (std::size_t i : frames) {
            last = data.timestamps[i] + offset;
            const long donnings = e.calibration_progress().donnings;
            const bool solved = push(e, i, last);
            const bool donned = e.calibration_progress().donnings > donnings;
            if (condition == "prior" && donned) e.use_continuous_calibration();
            if (condition == "detected") {
              const bool off_now = e.glove_off();
              if (removal && off_now && !seen_off) seen_off = true, off_delay.push_back(data.timestamps[i] - doff);
              if (donned && (removal || (seen_off_before && !seen_on))) {  // the removal's donning, noticed in it or after
                seen_on = true;
                on_delay.push_back(removal ? data.timestamps[i] - end : data.timestamps[i] - data.timestamps[frames.front()]);
              } else if (donned) {
                ++worn_donnings;
                if (std::getenv("REDON_VERBOSE")) std::printf("  subject %d session %d t %.2f: a donning while worn\n", s, k, data.timestamps[i]);
              }
              if (!removal && off_now && !was_off) {
                ++worn_offs;
                if (std::getenv("REDON_VERBOSE")) std::printf("  subject %d session %d t %.2f: off while worn\n", s, k, data.timestamps[i]);
              }
              if (!removal && off_now) ++late_frames;
              was_off = off_now;
            }
            if (condition == "guided+" && !removal && e.glove_off() && !was_off) ++kept_offs;
            if (condition == "guided+") was_off = e.glove_off();
            if (solved && scored(k, i) && e.pose().trusted()) pooled[condition].add(pose_error(data, i, e.pose()));
          }
          if (condition == "detected") pending_on = removal && seen_off && !seen_on;
          if (condition == "detected" && !removal && seen_off_before && !seen_on) ++missed;
          if (condition == "detected" && removal) {
            ++removals;
            missed += seen_off ? 0 : 1;
            if (std::getenv("REDON_VERBOSE") && !(seen_off && seen_on))
              std::printf("  subject %d session %d: removal %s\n", s, k, seen_off ? "donning not noticed within it" : "not noticed off");
          }
          if (condition == "detected" && !removal) worn_seconds += end - data.timestamps[frames.front()];
        }
    }
  }
  std::sort(off_delay.begin(), off_delay.end());
  std::sort(on_delay.begin(), on_delay.end());
  long on_within = 0;
  for (double d : on_delay) on_within += d <= 2.0 ? 1 : 0;
  std::printf("%d people, %ld removals: %ld missed; glove off noticed %.2f-%.2f s (median %.2f) into the off period; donning noticed "
              "%.2f-%.2f s (median %.2f) after the glove is on, %ld within 2 s; in %.0f worn minutes: %ld removals and %ld donnings "
              "noticed that were none, %ld frames flagged off before a donning was noticed\n",
              subjects, removals, missed, off_delay.empty() ? NAN : off_delay.front(), off_delay.empty() ? NAN : off_delay.back(),
              off_delay.empty() ? NAN : off_delay[off_delay.size() / 2], on_delay.empty() ? NAN : on_delay.front(),
              on_delay.empty() ? NAN : on_delay.back(), on_delay.empty() ? NAN : on_delay[on_delay.size() / 2], on_within, worn_seconds / 60.0,
              worn_offs, worn_donnings, late_frames);
  std::printf("with session 0's guided calibration instead (guided+): %ld removals noticed in worn frames\n", kept_offs);
  // The floor: distance from the glove's off-the-hand pattern.
  std::vector<std::vector<double>> off_cells(C);
  for (std::size_t i = 0; i < data.frames(); ++i)
    if (data.kind[i] == io::kKindRemoval && data.subject[i] == data.subject[0] && data.session[i] == 3 &&
        data.timestamps[i] > doff + 2.0 && data.timestamps[i] < doff + 9.0)
      for (std::size_t c = 0; c < C; ++c) off_cells[c].push_back(data.cells[i * C + c]);
  if (!off_cells[0].empty()) {
    std::vector<double> pattern(C), off_distance;
    for (std::size_t c = 0; c < C; ++c) {
      std::nth_element(off_cells[c].begin(), off_cells[c].begin() + static_cast<std::ptrdiff_t>(off_cells[c].size() / 2), off_cells[c].end());
      pattern[c] = off_cells[c][off_cells[c].size() / 2];
    }
    std::map<int, double> closest;  // per person, the smallest distance of a worn frame
    for (std::size_t i = 0; i < data.frames(); ++i) {
      const bool off = data.kind[i] == io::kKindRemoval && data.timestamps[i] > doff + 2.0 && data.timestamps[i] < doff + 9.0;
      if (data.kind[i] == io::kKindRemoval && !off) continue;
      double sum = 0.0;
      for (std::size_t c = 0; c < C; ++c) sum += std::pow((data.cells[i * C + c] - pattern[c]) / pattern[c], 2);
      const double distance = std::sqrt(sum / static_cast<double>(C));
      if (off) off_distance.push_back(distance);
      if (data.kind[i] != io::kKindRecording) continue;
      auto it = closest.find(data.subject[i]);
      if (it == closest.end() || distance < it->second) closest[data.subject[i]] = distance;
    }
    std::sort(off_distance.begin(), off_distance.end());
    std::printf("distance from the glove's off pattern: off the hand median %.3f, 99th percentile %.3f; closest worn frame per person:",
                off_distance[off_distance.size() / 2], off_distance[off_distance.size() * 99 / 100]);
    for (const auto& [person, d] : closest) std::printf(" %d:%.3f", person, d);
    std::printf("\n");
  }
  std::printf("first %.0f s of each session after a removal, mean error (deg), ratio to its fresh guided calibration:\n", window);
  for (const auto& [name, m] : pooled) std::printf("  %-10s %.3f  %.3fx  (%ld poses)\n", name.c_str(), m.mean(), m.mean() / pooled["guided"].mean(), m.n);
  return 0;
}
