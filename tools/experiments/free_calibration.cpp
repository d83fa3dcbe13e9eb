// How close a calibration without a step can come to the guided protocol (issue: put it on and
// go), measured before one is built. New people of the fitted world (one per seed, used by no
// model or choice) perform the guided calibration sequence, then a 2-minute session of free
// motion, streamed as the dataset's solved cells through the shipped model's estimator. Scored
// against the true angles over session seconds 60-120, each person calibrated:
//
//   guided       the sequence, the default method (pose-guided where the model carries it)
//   seq min-max  the sequence, min-max only
//   free Pp      no sequence: the p-th and (100-p)-th percentile of each cell over the first
//                C seconds of the session's free motion (p = 0: its min and max), then fixed
//   mapped       no sequence: each cell's sequence min and max predicted from its 5th, 50th and
//                95th percentiles over the first C seconds of free motion, by a least-squares
//                map per cell fitted on other people (TRAIN_SEED.., TRAIN_PEOPLE of them)
//
//   g++ -std=c++17 -O2 -Iinclude -isystem /usr/include/eigen3 tools/experiments/free_calibration.cpp -o free_calibration -lpthread
//   ./free_calibration models/glovepose_fcn512.safetensors 983 8 [TRAIN_SEED TRAIN_PEOPLE]
//
// Prints each person's figures and the means over the people, the free ones as ratios to guided.
#include <glovepose/estimator.hpp>
#include <glovepose/sim/corpus_dataset.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <vector>

using namespace glovepose;

namespace {

constexpr double kWindows[] = {10.0, 30.0, 60.0};  // seconds of free motion the free ranges see
constexpr double kPercentiles[] = {0.0, 1.0, 5.0};
constexpr double kScoredFrom = 60.0;  // session seconds

double cell(const io::Dataset& d, std::size_t frame, int c) { return d.cells[frame * 44 + static_cast<std::size_t>(c)]; }

io::Dataset simulate_person(std::uint64_t seed) {
  sim::CorpusConfig config = sim::CorpusConfig::one_session(seed, 120.0, 0.0);
  config.world = sim::default_world();
  config.guided_calibration = sim::guided_calibration_sequence(sim::pose_gallery());
  config.calibration_seconds = config.guided_calibration->total_seconds();
  return sim::to_dataset(sim::simulate_corpus(config), config);
}

// The first frame `seconds` into the session.
std::size_t session_frame_at(const io::Dataset& d, double seconds) {
  const std::size_t first = d.first_session_frame();
  std::size_t end = first;
  while (end < d.frames() && d.timestamps[end] - d.timestamps[first] < seconds) ++end;
  return end;
}

// Cell c's q-th percentile over session frames [first, end).
double percentile(const io::Dataset& d, std::size_t end, int c, double q) {
  std::vector<double> values;
  for (std::size_t f = d.first_session_frame(); f < end; ++f) values.push_back(cell(d, f, c));
  std::sort(values.begin(), values.end());
  return values[static_cast<std::size_t>(std::lround(q / 100.0 * static_cast<double>(values.size() - 1)))];
}

// The features of the map: 1 and the 5th, 50th and 95th percentiles of each cell over `seconds`.
Eigen::MatrixXd motion_features(const io::Dataset& d, double seconds) {
  const std::size_t end = session_frame_at(d, seconds);
  Eigen::MatrixXd x(44, 4);
  for (int c = 0; c < 44; ++c) x.row(c) << 1.0, percentile(d, end, c, 5.0), percentile(d, end, c, 50.0), percentile(d, end, c, 95.0);
  return x;
}

// The sequence's min-max range, as the estimator takes it.
sensor::CalibrationRange sequence_range(const std::shared_ptr<const PoseModel>& model, const io::Dataset& d) {
  EstimatorConfig ec;
  ec.calibration_method = CalibrationMethod::MinMax;
  GlovePoseEstimator e(model, ec);
  e.start_calibration();
  for (std::size_t f = 0; f < d.first_session_frame(); ++f) {
    double cells[44];
    for (int c = 0; c < 44; ++c) cells[c] = cell(d, f, c);
    (void)e.push_cells(cells, 44, d.timestamps[f]);
  }
  return e.finish_calibration();
}

// Per cell, least-squares maps from motion_features to the sequence's min and max, over people.
struct RangeMap {
  std::vector<Eigen::Vector4d> low, high;
  sensor::CalibrationRange apply(const Eigen::MatrixXd& x, const std::vector<std::string>& names) const {
    Eigen::VectorXd lo(44), hi(44);
    for (int c = 0; c < 44; ++c) {
      lo(c) = x.row(c).dot(low[static_cast<std::size_t>(c)]);
      hi(c) = std::max(lo(c), x.row(c).dot(high[static_cast<std::size_t>(c)]));  // crossed: a flat cell
    }
    return sensor::CalibrationRange(lo, hi, names);
  }
};

// One map per window of kWindows.
std::vector<RangeMap> fit_maps(const std::shared_ptr<const PoseModel>& model, std::uint64_t first_seed, int people) {
  std::vector<std::vector<Eigen::MatrixXd>> features(std::size(kWindows));
  std::vector<sensor::CalibrationRange> ranges;
  for (int p = 0; p < people; ++p) {
    const io::Dataset d = simulate_person(first_seed + static_cast<std::uint64_t>(p));
    for (std::size_t w = 0; w < std::size(kWindows); ++w) features[w].push_back(motion_features(d, kWindows[w]));
    ranges.push_back(sequence_range(model, d));
  }
  std::vector<RangeMap> maps(std::size(kWindows));
  for (std::size_t w = 0; w < std::size(kWindows); ++w)
    for (int c = 0; c < 44; ++c) {
      Eigen::MatrixXd x(people, 4);
      Eigen::VectorXd lo(people), hi(people);
      for (int p = 0; p < people; ++p) {
        x.row(p) = features[w][static_cast<std::size_t>(p)].row(c);
        lo(p) = ranges[static_cast<std::size_t>(p)].min()(c);
        hi(p) = ranges[static_cast<std::size_t>(p)].max()(c);
      }
      maps[w].low.push_back(x.colPivHouseholderQr().solve(lo));
      maps[w].high.push_back(x.colPivHouseholderQr().solve(hi));
    }
  return maps;
}

// The estimator's mean angle error (degrees, against the true angles) over the session frames from
// kScoredFrom on, the cells pushed from frame `from` on.
double score(GlovePoseEstimator& e, const io::Dataset& d, std::size_t from) {
  const std::size_t first = d.first_session_frame();
  double sum = 0.0;
  long n = 0;
  for (std::size_t f = from; f < d.frames(); ++f) {
    double cells[44];
    for (int c = 0; c < 44; ++c) cells[c] = cell(d, f, c);
    if (e.push_cells(cells, 44, d.timestamps[f]) != Status::Solved || d.timestamps[f] - d.timestamps[first] < kScoredFrom) continue;
    double error = 0.0;
    for (std::size_t k = 0; k < hand::kDofCount; ++k) error += std::abs(e.pose().angles[k] - d.true_angles[f * hand::kDofCount + k]);
    sum += error * core::kDegreesPerRadian / static_cast<double>(hand::kDofCount);
    ++n;
  }
  return sum / static_cast<double>(n);
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 4 && argc != 6) {
    std::fprintf(stderr, "usage: free_calibration MODEL FIRST_SEED PEOPLE [TRAIN_SEED TRAIN_PEOPLE]\n");
    return 2;
  }
  const auto model = PoseModel::load(argv[1]);
  const std::uint64_t first_seed = std::strtoull(argv[2], nullptr, 10);
  const int people = std::atoi(argv[3]);
  if (people < 1) {
    std::fprintf(stderr, "free_calibration: PEOPLE '%s', expected at least 1\n", argv[3]);
    return 2;
  }
  std::vector<RangeMap> maps;  // per window
  const int train_people = argc == 6 ? std::atoi(argv[5]) : 0;
  if (train_people > 0) maps = fit_maps(model, std::strtoull(argv[4], nullptr, 10), train_people);
  double guided_sum = 0.0, minmax_sum = 0.0;
  std::vector<double> free_sum(std::size(kWindows) * std::size(kPercentiles), 0.0), mapped_sum(std::size(kWindows), 0.0);
  for (int person = 0; person < people; ++person) {
    const std::uint64_t seed = first_seed + static_cast<std::uint64_t>(person);
    const io::Dataset d = simulate_person(seed);
    const std::size_t first = d.first_session_frame();

    double guided = 0.0, minmax = 0.0;
    std::vector<std::string> names;
    for (CalibrationMethod method : {CalibrationMethod::Auto, CalibrationMethod::MinMax}) {
      EstimatorConfig ec;
      ec.calibration_method = method;
      GlovePoseEstimator e(model, ec);
      e.start_calibration();
      for (std::size_t f = 0; f < first; ++f) {
        double cells[44];
        for (int c = 0; c < 44; ++c) cells[c] = cell(d, f, c);
        (void)e.push_cells(cells, 44, d.timestamps[f]);
      }
      names = e.finish_calibration().names();
      (method == CalibrationMethod::Auto ? guided : minmax) = score(e, d, first);
    }
    guided_sum += guided;
    minmax_sum += minmax;
    std::printf("seed %llu: guided %.2f, seq min-max %.2f |", static_cast<unsigned long long>(seed), guided, minmax);
    EstimatorConfig min_max;
    min_max.calibration_method = CalibrationMethod::MinMax;
    for (std::size_t w = 0; w < std::size(kWindows); ++w) {
      const std::size_t end = session_frame_at(d, kWindows[w]);
      Eigen::VectorXd low(44), high(44);
      for (std::size_t p = 0; p < std::size(kPercentiles); ++p) {
        for (int c = 0; c < 44; ++c) low(c) = percentile(d, end, c, kPercentiles[p]), high(c) = percentile(d, end, c, 100.0 - kPercentiles[p]);
        GlovePoseEstimator e(model, min_max);
        e.set_calibration(sensor::CalibrationRange(low, high, names));
        const double error = score(e, d, first);
        free_sum[w * std::size(kPercentiles) + p] += error;
        std::printf(" %gs P%g %.2f", kWindows[w], kPercentiles[p], error);
      }
      if (maps.empty()) continue;
      GlovePoseEstimator e(model, min_max);
      e.set_calibration(maps[w].apply(motion_features(d, kWindows[w]), names));
      const double error = score(e, d, first);
      mapped_sum[w] += error;
      std::printf(" %gs mapped %.2f", kWindows[w], error);
    }
    std::printf("\n");
  }
  std::printf("mean over %d people: guided %.3f deg, seq min-max %.3f (%.3fx); free motion:", people, guided_sum / people, minmax_sum / people,
              minmax_sum / guided_sum);
  for (std::size_t w = 0; w < std::size(kWindows); ++w)
    for (std::size_t p = 0; p < std::size(kPercentiles); ++p)
      std::printf(" %gs P%g %.3fx", kWindows[w], kPercentiles[p], free_sum[w * std::size(kPercentiles) + p] / guided_sum);
  if (!maps.empty()) {
    std::printf("; mapped from %d other people:", train_people);
    for (std::size_t w = 0; w < std::size(kWindows); ++w) std::printf(" %gs %.3fx", kWindows[w], mapped_sum[w] / guided_sum);
  }
  std::printf("\n");
  return 0;
}
