// The smallest complete program: load a model, create an estimator, calibrate on the fly, push the
// glove's rows, read poses.
//
// Usage: minimal MODEL.safetensors   (the shipped model: models/glovepose_fcn512.safetensors)
//
// The glove here is the simulator: one person moving through extreme poses for 3 s (the on-the-fly
// calibration), then moving naturally for 5 s, read out row by row (180 rows per 60 Hz cycle) as a
// real glove's firmware delivers them. With a real glove, replace the loop's source of rows.
#include <glovepose/glovepose.hpp>
#include <glovepose/sensor/calibration.hpp>  // CalibrationRange::flat_sensors
#include <glovepose/sim/corpus_dataset.hpp>  // the simulated glove only

#include <cstdio>

using namespace glovepose;

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: %s MODEL.safetensors\n", argv[0]);
    return 2;
  }
  try {
    // Set-up, which may allocate and throws glovepose::Error. One model can serve many estimators
    // (one per glove) on any threads; the estimator holds one glove's stream.
    const std::shared_ptr<const PoseModel> model = PoseModel::load(argv[1]);
    GlovePoseEstimator estimator(model);

    sim::CorpusConfig glove = sim::CorpusConfig::one_session(1, 5.0, 3.0);  // seed 1: 5 s after 3 s of calibration
    glove.recording.raw_rows = true;
    const io::Dataset recording = sim::to_dataset(sim::simulate_corpus(glove), glove);
    const std::size_t rows = recording.row_count;
    const io::RowClock clock = recording.row_clock();                   // when each raw row was read
    const std::size_t session_start = recording.first_session_frame();  // where the simulated calibration ends

    // The user first moves through extreme poses while the estimator collects each cell's range.
    estimator.start_calibration();
    for (std::size_t frame = 0; frame < recording.frames(); ++frame) {
      if (frame == session_start) {
        const long frames = estimator.calibration_progress().frames;
        const sensor::CalibrationRange& range = estimator.finish_calibration();
        std::printf("calibrated on %ld frames, %zu flat sensors\n", frames, range.flat_sensors().size());
      }
      // The per-frame path: no allocation, no exceptions, a Status per call; each row at the time
      // it was read.
      for (std::size_t r = 0; r < rows; ++r) {
        const double timestamp = clock.time(recording.timestamps[frame], r);
        const Status status = estimator.push_row(static_cast<int>(r), recording.raw_rows[frame * rows + r], timestamp);
        if (status != Status::Solved) continue;  // no new pose yet (or uncalibrated, or a rejected reading)
        const Pose& pose = estimator.pose();     // a new pose every 16 rows: 675 per second
        if (pose.sequence % 675 == 1) {
          const auto degrees = [&](hand::Finger finger, hand::Motion motion) {
            return pose.angles[hand::dof_of(finger, motion)] * core::kDegreesPerRadian;
          };
          std::printf(
              "t = %5.2f s  index flexion %5.1f %5.1f %5.1f deg  thumb abduction %5.1f deg  "
              "(oldest reading %4.1f ms, computed in %3.0f us)\n",
              pose.timestamp, degrees(hand::Finger::Index, hand::Motion::BaseFlexion),
              degrees(hand::Finger::Index, hand::Motion::MiddleFlexion), degrees(hand::Finger::Index, hand::Motion::TipFlexion),
              degrees(hand::Finger::Thumb, hand::Motion::Abduction), 1e3 * pose.oldest_age, 1e6 * pose.compute_seconds);
        }
      }
    }
    return estimator.pose().valid ? 0 : 1;
  } catch (const Error& e) {
    std::fprintf(stderr, "minimal: %s\n", e.what());
    return 2;
  }
}
