// A simulated new user of the glove, in memory: the tools' stand-in for a person wearing it
// (glovepose demo, glovepose view).
#pragma once

#include <glovepose/calibration/pose_offset.hpp>  // PoseModel::pose_offset()'s type
#include <glovepose/estimator.hpp>
#include <glovepose/sim/corpus_dataset.hpp>

#include <cstdint>
#include <string>

namespace glovepose::cli {

/// The calibration sequence, then the session, with every raw reading.
struct NewUser {
  io::Dataset data;
  std::size_t first_session_frame = 0;
  double cycle_rate = 0.0;  ///< readout cycles per second
};

/// Subject 0 of simulation seed `seed` in the simulator's default world, with a session of
/// `minutes`. The user follows the model's guided calibration sequence when it carries one
/// (pose-guided calibration), else explores the extreme poses freely (min-max).
inline NewUser simulate_new_user(std::uint64_t seed, double minutes, const PoseModel& model) {
  sim::CorpusConfig config;
  config.world = sim::default_world();
  config.seed = seed;
  config.subjects = 1;
  config.sessions = 1;
  config.gloves = 1;
  config.minutes = minutes;
  config.recording.raw_rows = true;
  if (model.pose_offset()) {
    config.guided_calibration = model.pose_offset()->sequence();
    config.calibration_seconds = config.guided_calibration->total_seconds();
  }
  NewUser user;
  user.data = sim::to_dataset(sim::simulate_corpus(config), config);
  user.cycle_rate = config.recording.cycle_rate;
  user.first_session_frame = user.data.first_session_frame();
  if (user.first_session_frame == 0 || user.first_session_frame == user.data.frames())
    throw Error("the simulated user has " + std::to_string(user.first_session_frame) + " calibration frames of " +
                std::to_string(user.data.frames()) + ", expected a calibration sequence followed by a session");
  return user;
}

/// When row r of frame f was read (io::RowClock at the user's cycle rate).
inline double row_time(const NewUser& user, std::size_t f, std::size_t r) {
  return io::RowClock{user.data.row_count, user.cycle_rate}.time(user.data.timestamps[f], r);
}

}  // namespace glovepose::cli
