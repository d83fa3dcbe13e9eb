// The continuous calibration streamed as the estimator runs it, before it was in the estimator
// (docs/results.md, "Without a calibration step": how the design was chosen). A RangeMap is fitted
// (train::fit_range_map) on PEOPLE people of corpus seed FIT_SEED, then 8 people of corpus seed
// TEST_SEED do the guided sequence and 2 min of free motion: each scored against the truth by
// window of session time (0-10, 10-30, 30-60, 60-120 s) with the range a ContinuousRange keeps,
// and with the map's prior range fixed, as ratios to the guided calibration's error over 60-120 s.
// The percentile sets compared (5/50/95; 2/10/50/90/98; the kept seven) were run by changing
// calibration::kMotionPercentiles in a copy of include/ (-I that copy).
//
//   g++ -std=c++17 -O2 -Iinclude -isystem /usr/include/eigen3 tools/experiments/continuous_calibration.cpp -o cont -lpthread
//   ./cont models/glovepose_fcn512.safetensors 901 120 983 [NOVELTY MEMORY]    # about 4 min
#include <glovepose/estimator.hpp>
#include <glovepose/sim/corpus_dataset.hpp>
#include <glovepose/calibration/free_motion.hpp>
#include <glovepose/train/range_map_fit.hpp>
#include <cstdio>
using namespace glovepose;
io::Dataset corpus(std::uint64_t seed, int people, double seconds) {
  sim::CorpusConfig config = sim::CorpusConfig::one_session(seed, seconds, 0.0);
  config.subjects = people; config.threads = 2;
  config.world = sim::default_world();
  config.guided_calibration = sim::guided_calibration_sequence(sim::pose_gallery());
  config.calibration_seconds = config.guided_calibration->total_seconds();
  return sim::to_dataset(sim::simulate_corpus(config), config);
}
int main(int argc, char** argv) {
  if (argc < 5) {
    std::fprintf(stderr, "usage: continuous_calibration MODEL FIT_SEED PEOPLE TEST_SEED [NOVELTY MEMORY]\n");
    return 2;
  }
  const auto model = PoseModel::load(argv[1]);
  calibration::MotionHistogramConfig hc;
  if (argc > 5) hc.novelty = atof(argv[5]);
  if (argc > 6) hc.memory = atof(argv[6]);
  const io::Dataset fitd = corpus(atoi(argv[2]), atoi(argv[3]), 120.0);
  auto fit = train::fit_range_map(fitd, train::FrameFilter{}, model->glove().calibration(), hc);
  for (auto& s : fit.stages) std::printf("stage %g: %ld runs, map %.4f prior %.4f\n", s.frames, s.runs, s.map_error, s.prior_error);
  const io::Dataset d = corpus(atoi(argv[4]), 8, 120.0);
  const double windows[] = {0, 10, 30, 60, 120.01};
  double gsum = 0, csum[4] = {0}, psum[4] = {0};
  for (int subject = 0; subject < 8; ++subject) {
    std::vector<std::size_t> seq, rec;
    for (std::size_t i = 0; i < d.frames(); ++i) if (d.subject[i] == subject) (d.kind[i] == io::kKindRecording ? rec : seq).push_back(i);
    auto cells = [&](std::size_t f) { Eigen::VectorXd v(44); for (int c = 0; c < 44; ++c) v(c) = d.cells[f*44+c]; return v; };
    auto err = [&](const GlovePoseEstimator& e, std::size_t f) { double s = 0; for (int k = 0; k < 25; ++k) s += std::abs(e.pose().angles[k] - d.true_angles[f*25+k]); return s * 57.29578 / 25; };
    const double t0 = d.timestamps[rec.front()];
    // guided
    double g = 0; long gn = 0;
    { GlovePoseEstimator e(model); e.start_calibration();
      for (auto f : seq) { auto v = cells(f); (void)e.push_cells(v.data(), 44, d.timestamps[f]); }
      e.finish_calibration();
      for (auto f : rec) { auto v = cells(f); if (e.push_cells(v.data(), 44, d.timestamps[f]) == Status::Solved && d.timestamps[f]-t0 >= 60) g += err(e, f), ++gn; } }
    g /= gn; gsum += g;
    EstimatorConfig mm; mm.calibration_method = CalibrationMethod::MinMax;
    std::vector<std::string> names = model->glove().cell_names();
    double cw[4] = {0}, pw[4] = {0}; long cn[4] = {0}, pn[4] = {0};
    { GlovePoseEstimator e(model, mm), p(model, mm);
      calibration::ContinuousRange cr(fit.map);
      e.set_calibration(sensor::CalibrationRange(cr.min(), cr.max(), names));
      p.set_calibration(sensor::CalibrationRange(cr.min(), cr.max(), names));
      for (auto f : rec) { auto v = cells(f);
        if (cr.add(v, d.timestamps[f])) e.set_calibration(sensor::CalibrationRange(cr.min(), cr.max(), names));
        const double t = d.timestamps[f]-t0; int w = 0; while (t >= windows[w+1]) ++w;
        if (e.push_cells(v.data(), 44, d.timestamps[f]) == Status::Solved) cw[w] += err(e, f), cn[w]++;
        if (p.push_cells(v.data(), 44, d.timestamps[f]) == Status::Solved) pw[w] += err(p, f), pn[w]++;
      }
      std::printf("subject %d: guided %.2f | taken %ld eff %.0f | cont", subject, g, cr.histogram().taken(), cr.histogram().effective_frames());
    }
    for (int w = 0; w < 4; ++w) { cw[w] /= cn[w]; pw[w] /= pn[w]; csum[w] += cw[w]; psum[w] += pw[w]; std::printf(" %.2f", cw[w]); }
    std::printf(" | prior"); for (int w = 0; w < 4; ++w) std::printf(" %.2f", pw[w]); std::printf("\n");
  }
  std::printf("MEAN guided(60-120) %.3f; windows 0-10,10-30,30-60,60-120: cont", gsum/8);
  for (int w = 0; w < 4; ++w) std::printf(" %.3fx", csum[w]/gsum);
  std::printf(" | prior"); for (int w = 0; w < 4; ++w) std::printf(" %.3fx", psum[w]/gsum); std::printf("\n");
}
