/// @file lag.hpp
/// @brief Motion-to-pose lag: how far the predicted angles trail the true ones in time.
///
/// Method (docs/results.md, "How lag is measured"): within every run, take the frame-to-frame
/// changes of the predicted and of the true angles (only between frames that are neighbours in the
/// recording); for every shift s of -max..+max frames, sum over runs, DoFs and frames the product
/// of the predicted change at frame t + s and the true change at frame t. The shift with the
/// largest sum is how many frames the prediction trails (positive: behind the hand); a parabola
/// through the peak and its two neighbours refines it to a fraction of a frame. Working on changes
/// rather than angles removes constant offsets and the slow drift of errors; it measures how late
/// motion appears, which is what a user sees as lag.
///
/// Set-up code: allocates, throws glovepose::Error for bad input.
#pragma once

#include <algorithm>
#include <cstdint>
#include <vector>

#include "../config.hpp"
#include "../hand/dofs.hpp"

namespace glovepose::train {

/// @brief The lag in recording frames (fraction included) of `predicted` behind `truth` (frames x
/// 25 each, radians; NaN truth for a DoF not labelled, which is left out). `source[f]` is frame f's
/// index in its recording and `run[f]` its run; the frames are every `step`-th of the recording (a
/// stride): two frames are neighbours when they share a run and their sources differ by `step`, and
/// the shifts go in whole steps over at least -max_shift..+max_shift recording frames. Throws
/// glovepose::Error for mismatched sizes or when no shift has any pair of neighbouring changes.
inline double lag_frames(const std::vector<float>& predicted, const std::vector<float>& truth, const std::vector<std::int64_t>& source,
                         const std::vector<std::int64_t>& run, int step = 1, int max_shift = 20) {
  const std::size_t n = source.size();
  const std::size_t dofs = hand::kDofCount;
  if (predicted.size() != n * dofs || truth.size() != n * dofs || run.size() != n || step < 1 || max_shift < 1)
    throw Error("lag_frames: " + std::to_string(predicted.size()) + " predicted and " + std::to_string(truth.size()) + " true angles for " +
                std::to_string(n) + " frames, a step of " + std::to_string(step) +
                ", expected 25 per frame each, a step of at least 1 and a maximum shift of at least 1");
  const int steps = (max_shift + step - 1) / step;  // the shifts, in steps
  // Position in `predicted` of recording frame (run, source), for the frames present.
  std::vector<std::size_t> order(n);
  for (std::size_t i = 0; i < n; ++i) order[i] = i;
  std::sort(order.begin(), order.end(),
            [&](std::size_t a, std::size_t b) { return run[a] != run[b] ? run[a] < run[b] : source[a] < source[b]; });
  const auto present = [&](std::int64_t r, std::int64_t s) -> long {
    const auto it = std::lower_bound(order.begin(), order.end(), std::make_pair(r, s),
                                     [&](std::size_t i, const std::pair<std::int64_t, std::int64_t>& key) {
                                       return run[i] != key.first ? run[i] < key.first : source[i] < key.second;
                                     });
    return it != order.end() && run[*it] == r && source[*it] == s ? static_cast<long>(*it) : -1;
  };
  std::vector<double> score(static_cast<std::size_t>(2 * steps + 1), 0.0);
  std::vector<long> pairs(score.size(), 0);
  for (std::size_t i = 0; i < n; ++i) {
    const long next = present(run[i], source[i] + step);
    if (next < 0) continue;
    for (int s = -steps; s <= steps; ++s) {
      const long a = present(run[i], source[i] + s * step), b = present(run[i], source[i] + (s + 1) * step);
      if (a < 0 || b < 0) continue;
      double sum = 0.0;
      for (std::size_t d = 0; d < dofs; ++d) {
        const double true_change = truth[static_cast<std::size_t>(next) * dofs + d] - truth[i * dofs + d];
        if (std::isnan(true_change)) continue;  // a DoF without reference angles (not labelled)
        const double predicted_change =
            predicted[static_cast<std::size_t>(b) * dofs + d] - predicted[static_cast<std::size_t>(a) * dofs + d];
        sum += true_change * predicted_change;
      }
      score[static_cast<std::size_t>(s + steps)] += sum;
      ++pairs[static_cast<std::size_t>(s + steps)];
    }
  }
  for (std::size_t k = 0; k < score.size(); ++k) {
    if (pairs[k] == 0)
      throw Error("lag_frames: no neighbouring frames (sources " + std::to_string(step) + " apart) at a shift of " +
                  std::to_string((static_cast<int>(k) - steps) * step) + " frames, expected runs long enough for every shift");
    score[k] /= static_cast<double>(pairs[k]);
  }
  const std::size_t best = static_cast<std::size_t>(std::max_element(score.begin(), score.end()) - score.begin());
  double fraction = 0.0;
  if (best > 0 && best + 1 < score.size()) {
    const double a = score[best - 1], b = score[best], c = score[best + 1];
    const double curvature = a - 2.0 * b + c;
    if (curvature < 0.0) fraction = 0.5 * (a - c) / curvature;
  }
  return (static_cast<double>(best) - steps + fraction) * step;
}

}  // namespace glovepose::train
