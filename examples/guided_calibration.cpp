// Guided calibration, as an app shows it: the model's calibration sequence is data (steps, each a
// name, an instruction, a target pose and a duration); while the user follows it the estimator says
// which step is under way, so the app shows that step's instruction and its pose to copy, and how
// far into the step the user is. At the end the estimator tells which calibration it applied
// (pose-guided when the user followed the sequence, min-max otherwise).
//
// Usage: guided_calibration MODEL.safetensors   (the shipped models carry a sequence)
//
// The user here is the simulator following the sequence, read out row by row as a real glove's
// firmware delivers them; with a real glove, replace the source of rows.
#include <glovepose/calibration/pose_offset.hpp>  // the model's sequence
#include <glovepose/glovepose.hpp>
#include <glovepose/sim/corpus_dataset.hpp>  // the simulated user only

#include <cstdio>

using namespace glovepose;

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: %s MODEL.safetensors\n", argv[0]);
    return 2;
  }
  try {
    const std::shared_ptr<const PoseModel> model = PoseModel::load(argv[1]);
    if (!model->pose_offset()) {
      std::fprintf(stderr, "guided_calibration: this model carries no calibration sequence (glovepose fit-guided adds one)\n");
      return 1;
    }
    const calibration::Sequence& sequence = model->pose_offset()->sequence();
    std::printf("calibration sequence '%s': %zu steps, %.1f s\n", sequence.id().c_str(), sequence.steps().size(), sequence.total_seconds());
    GlovePoseEstimator estimator(model);

    // A simulated person who follows the sequence, then moves freely for 2 s.
    sim::CorpusConfig person = sim::CorpusConfig::one_session(31, 2.0, sequence.total_seconds());
    person.guided_calibration = sequence;
    person.recording.raw_rows = true;
    const io::Dataset glove = sim::to_dataset(sim::simulate_corpus(person), person);
    const std::size_t rows = glove.row_count;
    const io::RowClock clock = glove.row_clock();                   // when each raw row was read
    const std::size_t session_start = glove.first_session_frame();  // where the simulated person's calibration ends

    estimator.start_calibration();
    int shown = -1;
    for (std::size_t frame = 0; frame < glove.frames(); ++frame) {
      if (frame == session_start) {
        estimator.finish_calibration();  // set-up call: may throw (too few frames)
        std::printf("calibrated: %s\n", estimator.calibration_method() == CalibrationMethod::PoseGuided
                                            ? "pose-guided (range and this user's angle offsets)"
                                            : "min-max (the sequence was not followed)");
      }
      for (std::size_t r = 0; r < rows; ++r) {
        const double t = clock.time(glove.timestamps[frame], r);
        (void)estimator.push_row(static_cast<int>(r), glove.raw_rows[frame * rows + r], t);
      }
      // What the app shows: the step under way, its instruction and target pose, and the progress.
      const CalibrationProgress progress = estimator.calibration_progress();
      if (!progress.collecting || progress.step < 0) continue;
      const calibration::Step& step = sequence.steps()[static_cast<std::size_t>(progress.step)];
      const double into_step = progress.sequence_seconds - sequence.step_start(static_cast<std::size_t>(progress.step));
      if (progress.step != shown) {
        shown = progress.step;
        const auto degrees = [&](hand::Finger f, hand::Motion m) { return step.pose[hand::dof_of(f, m)] / core::kRadiansPerDegree; };
        std::printf("step %d/%zu %-18s %4.1f s  \"%s\"\n    target: index flexion %.0f %.0f %.0f deg, thumb abduction %.0f deg\n",
                    progress.step + 1, sequence.steps().size(), step.name.c_str(), step.seconds, step.instruction.c_str(),
                    degrees(hand::Finger::Index, hand::Motion::BaseFlexion), degrees(hand::Finger::Index, hand::Motion::MiddleFlexion),
                    degrees(hand::Finger::Index, hand::Motion::TipFlexion), degrees(hand::Finger::Thumb, hand::Motion::Abduction));
      } else if (frame % 60 == 0) {
        std::printf("    %3.0f%% of the step, %ld frames taken\n", 100.0 * into_step / step.seconds, progress.frames);
      }
    }
    return estimator.pose().valid && shown == static_cast<int>(sequence.steps().size()) - 1 ? 0 : 1;
  } catch (const Error& e) {
    std::fprintf(stderr, "guided_calibration: %s\n", e.what());
    return 2;
  }
}
