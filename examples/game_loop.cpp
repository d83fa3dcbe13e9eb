// A game loop driven by the glove. A sensor thread owns the estimator and pushes the glove's rows as
// they arrive; the game runs a fixed 90 Hz step that takes the newest pose without ever waiting for
// the sensor thread (nor making it wait), turns the 21-joint list into the parent-relative bone
// transforms an engine animates a skeleton with, and "renders" a few frames as text, with the
// OpenXR hand joints predicted for the frame's display time (11 ms after it is drawn).
//
// Usage: game_loop MODEL.safetensors [SECONDS]   (SECONDS of play after a 2 s calibration; default 3)
//
// The glove is the simulator, streamed in real time; with a real glove, the sensor thread reads
// rows from the glove's port instead.
#include <glovepose/glovepose.hpp>
#include <glovepose/hand/xr_hand.hpp>        // OpenXR joints and aim
#include <glovepose/pose_prediction.hpp>     // predict, locate
#include <glovepose/sim/corpus_dataset.hpp>  // the simulated glove only

#include <Eigen/Geometry>

#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <thread>

using namespace glovepose;
using Clock = std::chrono::steady_clock;

namespace {

// The sensor thread: owns the estimator, calibrates it on the first 2 s, then streams.
// After each pose it publishes the estimator's state (pose, joints, calibration progress): a plain
// copy that the game reads whenever it likes, never waiting for this thread nor making it wait.
void stream_glove(GlovePoseEstimator& estimator, const io::Dataset& glove, Clock::time_point start, LatestHand& latest) {
  const std::size_t rows = glove.row_count;
  const io::RowClock clock = glove.row_clock();                   // when each raw row was read
  const std::size_t session_start = glove.first_session_frame();  // where the simulated calibration ends
  estimator.start_calibration();
  for (std::size_t frame = 0; frame < glove.frames(); ++frame) {
    if (frame == session_start) estimator.finish_calibration();  // set-up call: may throw (too few frames)
    for (std::size_t r = 0; r < rows; ++r) {
      const double t = clock.time(glove.timestamps[frame], r);
      std::this_thread::sleep_until(start + std::chrono::duration<double>(t));  // stands in for a blocking read from the glove
      const Status status = estimator.push_row(static_cast<int>(r), glove.raw_rows[frame * rows + r], t);
      if (status != Status::Solved && status != Status::Uncalibrated) continue;  // no frame solved by this row
      latest.publish(estimator.state());
    }
  }
}

// An engine's hand skeleton: one bone per joint of the list, each with its transform relative to its
// parent bone (hand::kJointParent), which is what engines animate.
struct Bone {
  Eigen::Vector3f position = Eigen::Vector3f::Zero();            // metres, in the parent bone's frame
  Eigen::Quaternionf rotation = Eigen::Quaternionf::Identity();  // relative to the parent bone
};
using HandRig = std::array<Bone, hand::kJointCount>;

// The joint list is global (all in the hand's root frame); a bone's local transform is its parent's
// inverse times its own: rotation parent^-1 * joint, position parent^-1 * (joint - parent).
void drive_rig(const hand::JointList& joints, HandRig& rig) {
  // JointTransform::rotation is (x, y, z, w): Eigen's storage order, so a Map reads it in place.
  const auto rotation = [&](int j) { return Eigen::Map<const Eigen::Quaternionf>(joints[j].rotation.data()); };
  const auto position = [&](int j) { return Eigen::Map<const Eigen::Vector3f>(joints[j].position.data()); };
  for (int j = 0; j < static_cast<int>(hand::kJointCount); ++j) {
    const int parent = hand::kJointParent[j];
    if (parent < 0) {
      rig[j] = {position(j), rotation(j)};
      continue;
    }
    const Eigen::Quaternionf to_parent = rotation(parent).conjugate();
    rig[j].rotation = (to_parent * rotation(j)).normalized();
    rig[j].position = to_parent * (position(j) - position(parent));
  }
}

// What a renderer does with the rig: composes the local transforms from the root down.
Bone global_transform(const HandRig& rig, int joint) {
  const int parent = hand::kJointParent[joint];
  if (parent < 0) return rig[joint];
  const Bone up = global_transform(rig, parent);
  return {up.position + up.rotation * rig[joint].position, up.rotation * rig[joint].rotation};
}

float bend_degrees(const Bone& bone) {
  return 2.0f * std::acos(std::min(1.0f, std::abs(bone.rotation.w()))) * static_cast<float>(core::kDegreesPerRadian);
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2 || argc > 3) {
    std::fprintf(stderr, "usage: %s MODEL.safetensors [SECONDS]\n", argv[0]);
    return 2;
  }
  try {
    const double play_seconds = argc == 3 ? std::atof(argv[2]) : 3.0;
    if (!(play_seconds > 0.0 && play_seconds <= 600.0))
      throw Error("SECONDS is '" + std::string(argv[2]) + "', expected 0 < SECONDS <= 600");

    // Smoothing on (1-euro: steady when the hand rests, little lag when it moves) and the joint list.
    EstimatorConfig config;
    config.smoothing = filter::OneEuroConfig{60.0, 1.0, 0.5, 1.0};
    config.joint_transforms = true;
    GlovePoseEstimator estimator(PoseModel::load(argv[1]), config);

    sim::CorpusConfig simulated = sim::CorpusConfig::one_session(1, play_seconds, 2.0);
    simulated.recording.raw_rows = true;
    const io::Dataset glove = sim::to_dataset(sim::simulate_corpus(simulated), simulated);

    // The estimator belongs to the sensor thread from here on; the game only sees `latest`, and the
    // locator (the estimator's hand model and side), which never changes and so serves any thread.
    const hand::XrHandLocator& locator = estimator.locator();
    LatestHand latest;
    std::atomic<bool> glove_done{false};
    std::exception_ptr sensor_failure;
    const Clock::time_point start = Clock::now();
    std::thread sensor([&] {
      try {
        stream_glove(estimator, glove, start, latest);
      } catch (...) {
        sensor_failure = std::current_exception();
      }
      glove_done = true;
    });

    // The game: a fixed 90 Hz step, rendering every step (a faster renderer would interpolate).
    constexpr auto kStep = std::chrono::duration<double>(1.0 / 90.0);
    HandRig rig;
    Clock::time_point next_step = start;
    for (long step = 0; !glove_done; ++step) {
      HandState hand;
      (void)latest.read(hand);  // never waits: the newest state (pose.valid false before the first pose)
      if (hand.pose.valid) drive_rig(hand.joints, rig);
      if (step % 45 == 0) {  // "render" twice a second
        const double now = std::chrono::duration<double>(Clock::now() - start).count();
        if (!hand.pose.valid && !hand.calibration.collecting) {
          std::printf("%5.2f s  waiting for the glove\n", now);
        } else if (!hand.pose.valid) {
          std::printf("%5.2f s  calibrating: %ld frames (%d needed)\n", now, hand.calibration.frames, hand.calibration.frames_needed);
        } else {
          // The middle and distal index bones turn against their parents by the finger's flexion.
          const Bone& middle = rig[static_cast<int>(hand::Joint::IndexIntermediate)];
          const Bone& distal = rig[static_cast<int>(hand::Joint::IndexDistal)];
          const Eigen::Vector3f tip = 1e3f * global_transform(rig, static_cast<int>(hand::Joint::IndexTip)).position;
          std::printf("%5.2f s  pose %6llu, %4.1f ms old  index bones bent %5.1f %5.1f deg  index tip at (%5.1f %5.1f %5.1f) mm\n", now,
                      static_cast<unsigned long long>(hand.pose.sequence), 1e3 * (now - hand.pose.timestamp), bend_degrees(middle),
                      bend_degrees(distal), tip.x(), tip.y(), tip.z());
          // OpenXR joints for the display time (the stream's clock here is seconds since start):
          // what an OpenXR layer copies into XrHandJointLocationEXT, wrist-relative.
          PredictedPose ahead;
          hand::XrHandJoints xr;
          if (predict(hand, locator, now + 0.011, config.max_prediction, ahead) == Status::Ok) {
            locate(ahead, locator, xr);
            const hand::XrJointLocation& index_tip = xr.locations[static_cast<int>(hand::XrJoint::IndexTip)];
            const hand::XrJointVelocity& speed = xr.velocities[static_cast<int>(hand::XrJoint::IndexTip)];
            std::printf(
                "          OpenXR, %4.1f ms ahead: index tip (%5.1f %5.1f %5.1f) mm from the wrist, moving %5.1f cm/s\n",
                1e3 * ahead.horizon, 1e3 * index_tip.pose.position.x, 1e3 * index_tip.pose.position.y, 1e3 * index_tip.pose.position.z,
                100.0 * std::sqrt(speed.linear_velocity.x * speed.linear_velocity.x + speed.linear_velocity.y * speed.linear_velocity.y +
                                  speed.linear_velocity.z * speed.linear_velocity.z));
          }
        }
      }
      next_step += std::chrono::duration_cast<Clock::duration>(kStep);
      std::this_thread::sleep_until(next_step);
    }
    sensor.join();
    if (sensor_failure) std::rethrow_exception(sensor_failure);
    HandState last;
    return latest.read(last) > 0 && last.pose.valid ? 0 : 1;
  } catch (const Error& e) {
    std::fprintf(stderr, "game_loop: %s\n", e.what());
    return 2;
  }
}
