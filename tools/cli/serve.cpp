// glovepose serve: a glove's link (device_link.hpp) read, reopened when it goes away, its readings
// turned into poses by an estimator, and each pose published at once to the engine stream (TCP on
// loopback, any number of clients), over OSC, as VRChat avatar parameters and as OpenGloves lines
// (docs/pose_stream.md). The calibration is the
// glove's and the user's: with --profiles it is loaded when that glove says its Hello, or made on
// the fly over the first seconds and then saved for the next time.
#include <glovepose/estimator.hpp>
#include <glovepose/pose_model.hpp>
#include <glovepose/pose_model_options.hpp>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <memory>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#ifdef _WIN32
#  include <windows.h>
#else
#  include <pthread.h>
#  include <sched.h>
#endif

#include "commands.hpp"
#include "glove_frames.hpp"
#include "glove_link.hpp"
#include "opengloves_output.hpp"
#include "pose_outputs.hpp"
#include "session_options.hpp"

namespace glovepose::cli {
namespace {

struct ServeOptions {
  std::string in, model, hand = "right", user, profiles, calibration, osc, vrchat, opengloves;
  unsigned opengloves_max = 4095;  // LucidVR's SteamVR driver's max_analog_value by default
  bool opengloves_joints = false;
  nn::WeightStorage storage = nn::WeightStorage::F32;
  double calibration_seconds = kDefaultCalibrationSeconds;
  int engine_port = -1;  // -1: no engine stream
  double seconds = 0.0;  // 0: until a signal (or the end of a file or stdin)
  bool stats = false;
  bool normal_scheduling = false;  // else a live link's thread asks for real-time scheduling
};

std::atomic<bool> serve_stop{false};
extern "C" void serve_on_signal(int) { serve_stop = true; }

// Latencies per pose, kept for the whole run (a vector reserved for an hour at 60 Hz; past that,
// every 2nd, 4th, ... is kept, the run's spread in the same memory).
class LatencyStats {
 public:
  LatencyStats() { samples_.reserve(kKept); }
  void add(double seconds) {
    if (++seen_ % stride_ != 0) return;
    if (samples_.size() == kKept) {  // keep every other one: the run's spread, in the same memory
      for (std::size_t i = 0; i < kKept / 2; ++i) samples_[i] = samples_[2 * i];
      samples_.resize(kKept / 2);
      stride_ *= 2;
    }
    samples_.push_back(seconds);
  }
  // The q-quantile in milliseconds (NaN before the first).
  double quantile_ms(double q) const {
    if (samples_.empty()) return std::nan("");
    std::vector<double> sorted = samples_;
    const auto at = sorted.begin() + static_cast<std::ptrdiff_t>(std::min(sorted.size() - 1, static_cast<std::size_t>(q * sorted.size())));
    std::nth_element(sorted.begin(), at, sorted.end());
    return *at * 1e3;
  }
  std::uint64_t count() const { return seen_; }

 private:
  static constexpr std::size_t kKept = 216000;
  std::vector<double> samples_;
  std::uint64_t seen_ = 0, stride_ = 1;
};

// A live glove's poses should not wait for other programs: the thread asks for a real-time
// scheduling class (Linux: SCHED_FIFO at a low priority, allowed to root, CAP_SYS_NICE or an
// RLIMIT_RTPRIO; Windows: a time-critical thread), so that other programs' work delays poses less
// (docs/pose_stream.md). Says what it got.
std::string ask_for_real_time() {
#ifdef _WIN32
  return SetThreadPriority(GetCurrentThread(), THREAD_PRIORITY_TIME_CRITICAL) ? "a time-critical thread" : "normal priority (refused)";
#else
  sched_param priority{};
  priority.sched_priority = 10;
  if (pthread_setschedparam(pthread_self(), SCHED_FIFO, &priority) == 0) return "real-time scheduling (SCHED_FIFO 10)";
  return "normal scheduling (real-time refused: needs root, CAP_SYS_NICE or an RLIMIT_RTPRIO)";
#endif
}

// The profile of a glove and a user: DIR/<glove id>-<serial>-<user>.calibration.
std::string profile_path(const ServeOptions& o, const GloveIdentity& glove) {
  return (std::filesystem::path(o.profiles) / (glove.glove_id + "-" + std::to_string(glove.serial) + "-" + o.user + ".calibration")).string();
}

int serve(const ServeOptions& o) {
  if (o.engine_port < 0 && o.osc.empty() && o.vrchat.empty() && o.opengloves.empty())
    throw Error("nothing to serve to: expected at least one of --engine PORT, --osc HOST:PORT, --vrchat HOST:PORT, --opengloves TARGET");
  if (!o.profiles.empty() && o.user.empty()) throw Error("--profiles needs --user NAME: a profile is a glove's and a user's");
  PoseModelOptions model_options;
  model_options.storage = o.storage;
  const std::shared_ptr<const PoseModel> model = PoseModel::load(o.model.empty() ? shipped_model_path(kShippedModel) : o.model, model_options);
  GlovePoseEstimator estimator(model);
  if (!o.calibration.empty()) estimator.load_calibration(o.calibration);
  std::unique_ptr<EngineServer> engine;
  if (o.engine_port >= 0) engine = std::make_unique<EngineServer>(static_cast<unsigned>(o.engine_port));
  std::unique_ptr<OscSender> osc;
  if (!o.osc.empty()) osc = std::make_unique<OscSender>(o.osc);
  std::unique_ptr<AvatarParameters> vrchat;
  if (!o.vrchat.empty()) vrchat = std::make_unique<AvatarParameters>(o.vrchat, o.hand);
  OpenGlovesLine opengloves_line(o.opengloves_max, o.opengloves_joints);
  std::unique_ptr<OpenGlovesPort> opengloves;
  if (!o.opengloves.empty()) opengloves = std::make_unique<OpenGlovesPort>(o.opengloves);
  GloveLink link(o.in);
  stop_on_signals(serve_on_signal);
  if (engine) std::fprintf(stderr, "glovepose serve: engine stream on 127.0.0.1:%u\n", engine->port());
  if (opengloves) std::fprintf(stderr, "glovepose serve: OpenGloves lines to '%s'\n", opengloves->device().c_str());
  if (link.address().reconnects() && !o.normal_scheduling) std::fprintf(stderr, "glovepose serve: %s\n", ask_for_real_time().c_str());

  const hand::Handedness hand = o.hand == "left" ? hand::Handedness::Left : hand::Handedness::Right;
  const std::string osc_angles = "/glovepose/" + o.hand + "/angles", osc_time = "/glovepose/" + o.hand + "/time";
  const std::string angle_types(hand::kDofCount, 'f');
  std::istringstream no_lines;
  const GloveLineSource source{no_lines, "link '" + o.in + "'", "glovepose serve"};
  const GloveLineFormat format(*model, false);
  GloveLineCounts counts;
  std::unique_ptr<GloveFeed> feed;
  std::unique_ptr<FrameFeed> frames;
  std::string save_profile;  // the profile to write once the calibration on the fly is done
  PoseMessage message;
  // Per pose: from its frame's last byte read to the pose sent (all of it: also the wait behind the
  // frames read with it, a backlog after a reconnection), and the service's own part: from the start
  // of its frame's handling to the pose sent, less the estimator's work.
  LatencyStats total, own;
  double arrived = 0.0, handling = 0.0, mapped = 0.0;
  std::uint64_t published = 0, restarts = 0;

  // Each pose, published at once to every output.
  const std::function<void(Status)> on_pose = [&](Status status) {
    if (status != Status::Solved) return;
    const Pose& pose = estimator.pose();
    const double now = host_seconds();
    message.encode(pose, hand, mapped, now);
    if (engine) engine->publish(message);
    if (osc) {
      osc->begin(osc_angles, angle_types);
      for (const double a : pose.angles) osc->f(static_cast<float>(a));
      osc->send();
      osc->begin(osc_time, "hd").h(static_cast<std::int64_t>(pose.sequence)).d(pose.timestamp).send();
    }
    if (vrchat || opengloves) {
      const hand::FingerCurls curls = hand::finger_curls(pose.angles, model->joint_limits());
      if (vrchat) vrchat->publish(curls, now);
      if (opengloves) {
        opengloves_line.encode(curls);
        opengloves->send(opengloves_line.data(), opengloves_line.size());
      }
    }
    ++published;
    const double sent = host_seconds();
    total.add(sent - arrived);
    own.add(sent - handling - pose.compute_seconds);
  };

  // The feed starts with the glove's first frame: its Hello names the profile to use.
  const auto start_feed = [&](const device::Frame& f) {
    std::optional<double> on_the_fly = on_the_fly_seconds(o.calibration_seconds, o.calibration);
    if (!o.profiles.empty() && f.header.kind == device::FrameKind::Hello && link.identity()) {
      const std::string path = profile_path(o, *link.identity());
      if (std::filesystem::exists(path)) {
        estimator.load_calibration(path);
        on_the_fly.reset();
        std::fprintf(stderr, "glovepose serve: %s: profile '%s' applied\n", link.identity()->describe().c_str(), path.c_str());
      } else {
        save_profile = path;
        std::fprintf(stderr, "glovepose serve: %s: no profile for user '%s' yet: calibrating over the first %g s, then saving '%s'\n",
                     link.identity()->describe().c_str(), o.user.c_str(), o.calibration_seconds, path.c_str());
      }
    }
    feed = std::make_unique<GloveFeed>(source, format, estimator, on_the_fly, counts, on_pose, "frame");
    frames = std::make_unique<FrameFeed>(*feed, estimator, source.name);
  };

  const auto on_frame = [&](const device::Frame& f, double mapped_time, double arrived_time) {
    handling = host_seconds();
    arrived = arrived_time;
    mapped = mapped_time;
    if (!frames) start_feed(f);
    if (link.counts().restarts != restarts) {  // the device began again: its clock too
      restarts = link.counts().restarts;
      estimator.reset();
    }
    frames->use(f);
    if (!save_profile.empty() && !estimator.calibration_progress().collecting && estimator.calibration()) {
      estimator.save_calibration(save_profile);
      std::fprintf(stderr, "glovepose serve: profile '%s' saved\n", save_profile.c_str());
      save_profile.clear();
    }
  };

  using Clock = std::chrono::steady_clock;
  const auto started = Clock::now();
  auto told = started;
  std::uint64_t told_published = 0;
  LinkEvents link_told = link.events();
  while (!serve_stop) {
    if (o.seconds > 0 && Clock::now() - started >= std::chrono::duration<double>(o.seconds)) break;
    if (engine) engine->accept();
    if (!link.poll(std::chrono::milliseconds(20), on_frame)) break;
    if (frames) frames->count_dropped(link.counts());
    const LinkEvents& now = link.events();
    if (now.losses != link_told.losses)
      std::fprintf(stderr, "glovepose serve: link '%s' lost (%s); reopening it\n", o.in.c_str(), now.last_problem.c_str());
    if (now.connections != link_told.connections) std::fprintf(stderr, "glovepose serve: link '%s' open again\n", o.in.c_str());
    link_told = now;
    if (o.stats && Clock::now() - told >= std::chrono::seconds(1)) {
      const double span = std::chrono::duration<double>(Clock::now() - told).count();
      std::fprintf(stderr, "glovepose serve: %.1f poses/s, %zu engine clients; latency p50 %.3f ms, p99 %.3f ms; the service's own p50 %.3f ms, p99 %.3f ms\n",
                   static_cast<double>(published - told_published) / span, engine ? engine->clients() : std::size_t{0},
                   total.quantile_ms(0.5), total.quantile_ms(0.99), own.quantile_ms(0.5), own.quantile_ms(0.99));
      told = Clock::now();
      told_published = published;
    }
  }
  std::fprintf(stderr, "glovepose serve: %llu poses published; link: %s; %s\n", static_cast<unsigned long long>(published),
               link_summary(link.counts()).c_str(), link_events_summary(link).c_str());
  if (engine) {
    const EngineCounts& e = engine->counts();
    std::fprintf(stderr, "glovepose serve: engine stream: %llu clients, %llu messages sent, %llu missed by clients that did not read, %llu gone\n",
                 static_cast<unsigned long long>(e.clients), static_cast<unsigned long long>(e.sent), static_cast<unsigned long long>(e.skipped),
                 static_cast<unsigned long long>(e.gone));
  }
  if (osc) std::fprintf(stderr, "glovepose serve: OSC: %llu messages, %llu not sent\n", static_cast<unsigned long long>(osc->sent()),
                        static_cast<unsigned long long>(osc->failed()));
  if (vrchat)
    std::fprintf(stderr, "glovepose serve: VRChat avatar parameters: %llu messages, %llu not sent\n",
                 static_cast<unsigned long long>(vrchat->osc().sent()), static_cast<unsigned long long>(vrchat->osc().failed()));
  if (opengloves)
    std::fprintf(stderr, "glovepose serve: OpenGloves: %llu lines sent, %llu skipped while the other end had not taken the one before\n",
                 static_cast<unsigned long long>(opengloves->counts().sent), static_cast<unsigned long long>(opengloves->counts().skipped));
  std::fprintf(stderr, "glovepose serve: latency (last byte read to pose sent) over %llu poses: p50 %.3f ms, p99 %.3f ms; the service's own "
               "(its frame's handling to the pose sent, less the estimator's work): p50 %.3f ms, p99 %.3f ms\n",
               static_cast<unsigned long long>(total.count()), total.quantile_ms(0.5), total.quantile_ms(0.99), own.quantile_ms(0.5),
               own.quantile_ms(0.99));
  if (published == 0) {
    if (feed) feed->end();  // says why no pose came
    throw Error("no pose published from link '" + o.in + "' (" + link_summary(link.counts()) + "), expected a glove's frames");
  }
  return 0;
}

}  // namespace

Command add_serve(CLI::App& tool) {
  auto o = std::make_shared<ServeOptions>();
  CLI::App* command = tool.add_subcommand(
      "serve",
      "Reads a glove's link (reopened when it goes away), turns its readings into poses and publishes each at once: the engine stream "
      "(TCP on 127.0.0.1, any number of clients), OSC over UDP, VRChat avatar parameters and OpenGloves lines (docs/pose_stream.md). With --profiles, a glove's and user's "
      "calibration is loaded when that glove says its Hello, or made on the fly and saved.");
  command->add_option("--in", o->in, kLinkHelp)->type_name("SOURCE")->required();  // no default: a service reads a glove
  add_model_file(*command, o->model, std::string("weights (default: models/") + kShippedModel + ", shipped with glovepose)");
  add_weight_storage(*command, o->storage, false);
  command->add_option("--hand", o->hand, "which hand the glove is on, as the outputs name it (default right)")
      ->check(CLI::IsMember({"left", "right"}));
  add_glove_line_calibration(*command, o->calibration_seconds, o->calibration, nullptr);
  CLI::Option* profiles =
      command->add_option("--profiles", o->profiles, "a directory of calibration profiles, one per glove (its id and serial) and user")
          ->type_name("DIR")
          ->check(CLI::ExistingDirectory.description(""));
  command->add_option("--user", o->user, "the user whose profile to apply or save")->type_name("NAME")->needs(profiles);
  add_number(*command, "--engine", "PORT", o->engine_port, "serve the engine stream on 127.0.0.1:PORT (0: a free port, printed)")
      ->check(CLI::Range(0, 65535));
  command->add_option("--osc", o->osc, "send OSC messages to HOST:PORT over UDP")->type_name("HOST:PORT");
  command->add_option("--vrchat", o->vrchat, "send the finger curls and splays as VRChat avatar parameters (OSC) to HOST:PORT, 20 times a second")
      ->type_name("HOST:PORT");
  CLI::Option* opengloves = command->add_option("--opengloves", o->opengloves,
                      "write OpenGloves lines (finger curls and splays) for SteamVR's or Monado's OpenGloves driver: pty:LINK (a new pty "
                      "named by the symlink LINK), a serial port (serial:PORT[@BAUD] or its path) or a file")
      ->type_name("TARGET");
  add_number(*command, "--opengloves-max", "N", o->opengloves_max,
             "the value of a full curl in OpenGloves lines: the driver's max_analog_value (default 4095, SteamVR's; Monado's is 1023)")
      ->check(CLI::Range(1, 9999))
      ->needs(opengloves);
  command->add_flag("--opengloves-joints", o->opengloves_joints,
                    "also each joint's curl in OpenGloves lines (SteamVR's driver only: the lines grow past Monado's 150 bytes)")
      ->needs(opengloves);
  add_number(*command, "--seconds", "S", o->seconds, "stop after S seconds (default: at SIGINT or SIGTERM, or when a file ends)")
      ->check(above(0.0));
  command->add_flag("--no-real-time", o->normal_scheduling, "keep normal scheduling (by default a live link's thread asks for real-time)");
  command->add_flag("--stats", o->stats, "print the rate, the clients and the latency the service adds every second");
  return {command, [o] { return serve(*o); }};
}

}  // namespace glovepose::cli
