// glovepose serve: a glove's link (device_link.hpp), or a left and a right glove's, read and reopened
// when it goes away; the readings turned into poses by an estimator per glove, and each pose
// published at once to the engine stream (TCP on loopback, any number of clients), over OSC, as
// VRChat avatar parameters, as OpenGloves lines or pipe messages (docs/pose_stream.md), and to the
// viewer's page in the browser (view_server.hpp). The calibration is the glove's and the user's:
// with --profiles it is loaded when that glove says its Hello, or made on the fly over the first
// seconds and then saved for the next time.
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
#include "view_server.hpp"

namespace glovepose::cli {
namespace {

struct ServeOptions {
  std::string in, left, right, model, hand = "right", user, profiles, calibration, osc, vrchat, opengloves;
  unsigned opengloves_max = 4095;  // LucidVR's SteamVR driver's max_analog_value by default
  bool opengloves_joints = false;
  nn::WeightStorage storage = nn::WeightStorage::F32;
  double calibration_seconds = kDefaultCalibrationSeconds;
  bool calibration_seconds_given = false;
  int engine_port = -1;  // -1: no engine stream
  int view_port = -1;    // -1: no viewer
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

// Outputs every glove publishes to (the engine stream's messages carry the hand).
struct SharedOutputs {
  std::unique_ptr<EngineServer> engine;
};

// One glove: its link, estimator and calibration, its own outputs (OSC addresses, VRChat names and
// OpenGloves port are per hand), and its counts and latencies.
class ServedGlove {
 public:
  // `view_port`: the viewer's port for this glove (-1: none).
  ServedGlove(const ServeOptions& o, const std::string& source, const std::string& hand_name, bool several,
              const std::shared_ptr<const PoseModel>& model, SharedOutputs& shared, int view_port)
      : o_(o),
        told_(several ? "glovepose serve: " + hand_name + ": " : "glovepose serve: "),
        hand_(hand_name == "left" ? hand::Handedness::Left : hand::Handedness::Right),
        model_(model),
        estimator_(model),
        calibration_(choose_glove_calibration(*model, o.calibration_seconds, o.calibration_seconds_given, o.calibration)),
        shared_(shared),
        link_(source, {}, std::nullopt, GloveLink::OtherGlove::Refuse),  // a service goes on: another glove's frames are dropped
        source_{no_lines_, "link '" + source + "'", "glovepose serve"},
        format_(*model, false),
        opengloves_line_(o.opengloves_max, o.opengloves_joints),
        osc_angles_("/glovepose/" + hand_name + "/angles"),
        osc_time_("/glovepose/" + hand_name + "/time"),
        angle_types_(hand::kDofCount, 'f') {
    if (!o.calibration.empty()) estimator_.load_calibration(o.calibration);
    calibration_.apply(estimator_);
    std::fprintf(stderr, "%scalibration: %s%s\n", told_.c_str(), calibration_.text.c_str(),
                 o.profiles.empty() ? "" : ", unless the glove's and user's profile is found");
    if (!o.osc.empty()) osc_ = std::make_unique<OscSender>(o.osc);
    if (!o.vrchat.empty()) vrchat_ = std::make_unique<AvatarParameters>(o.vrchat, hand_name);
    if (!o.opengloves.empty()) {
      std::string target = o.opengloves == "pipe:" ? std::string("pipe:") + kDriverPipe : o.opengloves;
      const std::size_t at = target.find("{hand}");
      if (at != std::string::npos) target.replace(at, 6, hand_name);
      opengloves_ = std::make_unique<OpenGlovesPort>(target);
      std::fprintf(stderr, "%sOpenGloves %s to '%s'%s\n", told_.c_str(), opengloves_->takes_messages() ? "messages" : "lines",
                   opengloves_->device().c_str(), opengloves_->events().connections == 0 ? " (not served yet: tried again until it is)" : "");
      port_told_ = opengloves_->events();
    }
    link_told_ = link_.events();
    if (view_port >= 0) {
      view_ = std::make_unique<ViewServer>(estimator_, view_port, ViewSource{hand_name + " glove, link '" + source + "'", false}, counts_);
      view_started_ = host_seconds();
      view_->start();
      std::fprintf(stderr, "%sviewer on http://127.0.0.1:%d/\n", told_.c_str(), view_->port());
    }
  }

  bool live() const { return link_.address().reconnects(); }
  bool ended() const { return ended_; }

  // Reads the link for at most `wait`, publishing each pose; false once a file or stdin has ended.
  bool poll(std::chrono::milliseconds wait) {
    if (ended_) return false;
    if (!link_.poll(wait, [this](const device::Frame& f, double mapped, double arrived) { on_frame(f, mapped, arrived); })) {
      ended_ = true;
      return false;
    }
    if (frames_) frames_->count_dropped(link_.counts());
    const LinkEvents& now = link_.events();
    if (now.losses != link_told_.losses)
      std::fprintf(stderr, "%slink '%s' lost (%s); reopening it\n", told_.c_str(), link_.address().text.c_str(), now.last_problem.c_str());
    if (now.connections != link_told_.connections) std::fprintf(stderr, "%slink '%s' open again\n", told_.c_str(), link_.address().text.c_str());
    if (link_.refused() != refused_told_) {
      std::fprintf(stderr, "%s%s: its frames are dropped until the glove says its Hello again\n", told_.c_str(), link_.last_refused().c_str());
      refused_told_ = link_.refused();
    }
    link_told_ = now;
    if (opengloves_) {
      const LinkEvents& port = opengloves_->events();
      if (port.losses != port_told_.losses)
        std::fprintf(stderr, "%sOpenGloves port '%s' lost (%s); reopening it\n", told_.c_str(), opengloves_->device().c_str(), port.last_problem.c_str());
      if (port.connections != port_told_.connections)
        std::fprintf(stderr, "%sOpenGloves port '%s' open%s\n", told_.c_str(), opengloves_->device().c_str(), port.connections > 1 ? " again" : "");
      port_told_ = port;
    }
    return true;
  }

  std::uint64_t published() const { return published_; }

  void tell_stats(double span, std::size_t clients) {
    std::fprintf(stderr, "%s%.1f poses/s, %zu engine clients; latency p50 %.3f ms, p99 %.3f ms; the service's own p50 %.3f ms, p99 %.3f ms\n",
                 told_.c_str(), static_cast<double>(published_ - told_published_) / span, clients, total_.quantile_ms(0.5),
                 total_.quantile_ms(0.99), own_.quantile_ms(0.5), own_.quantile_ms(0.99));
    told_published_ = published_;
  }

  // The run's summary; throws Error when the glove gave no pose.
  void finish() {
    std::fprintf(stderr, "%s%llu poses published; link: %s; %s\n", told_.c_str(), static_cast<unsigned long long>(published_),
                 link_summary(link_.counts()).c_str(), link_events_summary(link_).c_str());
    if (osc_)
      std::fprintf(stderr, "%sOSC: %llu messages, %llu not sent\n", told_.c_str(), static_cast<unsigned long long>(osc_->sent()),
                   static_cast<unsigned long long>(osc_->failed()));
    if (vrchat_)
      std::fprintf(stderr, "%sVRChat avatar parameters: %llu messages, %llu not sent\n", told_.c_str(),
                   static_cast<unsigned long long>(vrchat_->osc().sent()), static_cast<unsigned long long>(vrchat_->osc().failed()));
    if (opengloves_) {
      opengloves_->finish();
      const OpenGlovesCounts& c = opengloves_->counts();
      const auto n = [](std::uint64_t v) { return static_cast<unsigned long long>(v); };
      const char* unit = opengloves_->takes_messages() ? "messages" : "lines";
      std::fprintf(stderr, "%sOpenGloves: %llu %s sent, %llu skipped while the other end had not taken the one before, %llu failed "
                   "(the port refused them or was lost), %llu of those sent discarded unread (no driver read them for %lld ms); "
                   "the port lost %llu times, reopened %llu times\n", told_.c_str(), n(c.sent), unit, n(c.skipped), n(c.failed), n(c.unread),
                   static_cast<long long>(OpenGlovesPort::kUnreadLimit.count()), n(opengloves_->events().losses),
                   n(std::max<std::uint64_t>(opengloves_->events().connections, 1) - 1));
    }
    std::fprintf(stderr, "%slatency (last byte read to pose sent) over %llu poses: p50 %.3f ms, p99 %.3f ms; the service's own "
                 "(its frame's handling to the pose sent, less the estimator's work): p50 %.3f ms, p99 %.3f ms\n",
                 told_.c_str(), static_cast<unsigned long long>(total_.count()), total_.quantile_ms(0.5), total_.quantile_ms(0.99),
                 own_.quantile_ms(0.5), own_.quantile_ms(0.99));
    if (published_ == 0) {
      if (feed_) feed_->end();  // says why no pose came
      throw Error("no pose published from link '" + link_.address().text + "' (" + link_summary(link_.counts()) + "), expected a glove's frames");
    }
  }

 private:
  // Each frame: shown by the viewer (while the calibration collects, with no pose yet, its step),
  // and its pose published at once to every output.
  void on_pose(Status status) {
    if (view_ && (status == Status::Solved || status == Status::Uncalibrated)) {
      // The page's latency: the device's clock when the viewer started, from this frame's mapping.
      view_->set_stream_clock(device_time_ - (mapped_ - view_started_));
      view_->publish(estimator_, device_time_);
    }
    if (status != Status::Solved) return;
    const Pose& pose = estimator_.pose();
    const double now = host_seconds();
    message_.encode(pose, hand_, mapped_, now);
    if (shared_.engine) shared_.engine->publish(message_);
    if (osc_) {
      osc_->begin(osc_angles_, angle_types_);
      for (const double a : pose.angles) osc_->f(static_cast<float>(a));
      osc_->send();
      osc_->begin(osc_time_, "hd").h(static_cast<std::int64_t>(pose.sequence)).d(pose.timestamp).send();
    }
    if (vrchat_ || opengloves_) {
      const hand::FingerCurls curls = hand::finger_curls(pose.angles, model_->joint_limits());
      if (vrchat_) vrchat_->publish(curls, now);
      if (opengloves_ && opengloves_->takes_messages()) {
        opengloves_message_.encode(curls);
        opengloves_->send(opengloves_message_.data(), opengloves_message_.size());
      } else if (opengloves_) {
        opengloves_line_.encode(curls);
        opengloves_->send(opengloves_line_.data(), opengloves_line_.size());
      }
    }
    ++published_;
    const double sent = host_seconds();
    total_.add(sent - arrived_);
    own_.add(sent - handling_ - pose.compute_seconds);
  }

  // The feed starts with the glove's first frame: its Hello names the profile to use.
  void start_feed(const device::Frame& f) {
    std::optional<double> on_the_fly = calibration_.on_the_fly;
    if (!o_.profiles.empty() && f.header.kind == device::FrameKind::Hello && link_.identity()) {
      const std::string path = profile_path(o_, *link_.identity());
      if (std::filesystem::exists(path)) {
        estimator_.load_calibration(path);
        on_the_fly.reset();
        std::fprintf(stderr, "%s%s: profile '%s' applied\n", told_.c_str(), link_.identity()->describe().c_str(), path.c_str());
      } else if (!on_the_fly) {
        std::fprintf(stderr, "%s%s: no profile for user '%s' yet, and none is made: the calibration is %s\n", told_.c_str(),
                     link_.identity()->describe().c_str(), o_.user.c_str(), calibration_.text.c_str());
      } else {
        save_profile_ = path;
        std::fprintf(stderr, "%s%s: no profile for user '%s' yet: calibrating over the first %g s, then saving '%s'\n", told_.c_str(),
                     link_.identity()->describe().c_str(), o_.user.c_str(), o_.calibration_seconds, path.c_str());
      }
    }
    feed_ = std::make_unique<GloveFeed>(source_, format_, estimator_, on_the_fly, counts_, on_pose_, "frame");
    frames_ = std::make_unique<FrameFeed>(*feed_, estimator_, source_.name);
  }

  void on_frame(const device::Frame& f, double mapped, double arrived) {
    handling_ = host_seconds();
    arrived_ = arrived;
    mapped_ = mapped;
    device_time_ = static_cast<double>(f.header.device_time_us) * 1e-6;
    if (!frames_) start_feed(f);
    if (link_.counts().restarts != restarts_) {  // the device began again: its clock too
      restarts_ = link_.counts().restarts;
      estimator_.reset();
    }
    frames_->use(f);
    if (!save_profile_.empty() && !estimator_.calibration_progress().collecting && estimator_.calibration()) {
      estimator_.save_calibration(save_profile_);
      std::fprintf(stderr, "%sprofile '%s' saved\n", told_.c_str(), save_profile_.c_str());
      save_profile_.clear();
    }
  }

  const ServeOptions& o_;
  std::string told_;
  hand::Handedness hand_;
  std::shared_ptr<const PoseModel> model_;
  GlovePoseEstimator estimator_;
  GloveCalibrationChoice calibration_;
  SharedOutputs& shared_;
  GloveLink link_;
  std::istringstream no_lines_;
  GloveLineSource source_;
  GloveLineFormat format_;
  GloveLineCounts counts_;
  std::function<void(Status)> on_pose_ = [this](Status status) { on_pose(status); };
  std::unique_ptr<GloveFeed> feed_;
  std::unique_ptr<FrameFeed> frames_;
  std::string save_profile_;  // the profile to write once the calibration on the fly is done
  std::unique_ptr<OscSender> osc_;
  std::unique_ptr<AvatarParameters> vrchat_;
  OpenGlovesLine opengloves_line_;
  OpenGlovesPipeMessage opengloves_message_;
  std::unique_ptr<OpenGlovesPort> opengloves_;
  std::string osc_angles_, osc_time_, angle_types_;
  PoseMessage message_;
  // Per pose: from its frame's last byte read to the pose sent (all of it: also the wait behind the
  // frames read with it, a backlog after a reconnection), and the service's own part: from the start
  // of its frame's handling to the pose sent, less the estimator's work.
  LatencyStats total_, own_;
  double arrived_ = 0.0, handling_ = 0.0, mapped_ = 0.0, device_time_ = 0.0;
  std::unique_ptr<ViewServer> view_;  // declared after the estimator and counts it reads: destroyed first
  double view_started_ = 0.0;         // host_seconds() when the viewer started
  std::uint64_t published_ = 0, told_published_ = 0, restarts_ = 0, refused_told_ = 0;
  LinkEvents link_told_, port_told_;
  bool ended_ = false;
};

int serve(const ServeOptions& o) {
  if (o.engine_port < 0 && o.osc.empty() && o.vrchat.empty() && o.opengloves.empty() && o.view_port < 0)
    throw Error("nothing to serve to: expected at least one of --engine PORT, --osc HOST:PORT, --vrchat HOST:PORT, --opengloves TARGET, --view PORT");
  if (!o.profiles.empty() && o.user.empty()) throw Error("--profiles needs --user NAME: a profile is a glove's and a user's");
  // The gloves: --in (on --hand), or --left and --right.
  std::vector<std::pair<std::string, std::string>> sources;  // hand, link
  if (!o.in.empty()) sources.emplace_back(o.hand, o.in);
  if (!o.left.empty()) sources.emplace_back("left", o.left);
  if (!o.right.empty()) sources.emplace_back("right", o.right);
  if (sources.empty()) throw Error("no glove: expected --in SOURCE (with --hand), or --left SOURCE, --right SOURCE or both");
  const bool several = sources.size() > 1;
  if (several && o.left == "-" && o.right == "-") throw Error("--left and --right both read stdin ('-'): expected a link of its own for each glove");
  if (several && !o.calibration.empty()) throw Error("--calibration is one glove's: with two gloves, use --profiles DIR --user NAME");
  if (several && !o.opengloves.empty() && o.opengloves != "pipe:" && o.opengloves.find("{hand}") == std::string::npos)
    throw Error("--opengloves '" + o.opengloves + "' with two gloves: expected '{hand}' in it, each glove's lines to its own target (pty:/tmp/glovepose-{hand})");
  PoseModelOptions model_options;
  model_options.storage = o.storage;
  const std::shared_ptr<const PoseModel> model = PoseModel::load(o.model.empty() ? shipped_model_path(kShippedModel) : o.model, model_options);
  SharedOutputs shared;
  if (o.engine_port >= 0) shared.engine = std::make_unique<EngineServer>(static_cast<unsigned>(o.engine_port));
  std::vector<std::unique_ptr<ServedGlove>> gloves;
  for (const auto& [hand_name, source] : sources) {
    // The viewer: a page per glove, the right's on --view PORT and the left's on PORT + 1 (0: free ones).
    const int view_port = o.view_port < 0 ? -1 : (o.view_port == 0 || !several || hand_name == "right" ? o.view_port : o.view_port + 1);
    gloves.push_back(std::make_unique<ServedGlove>(o, source, hand_name, several, model, shared, view_port));
  }
  stop_on_signals(serve_on_signal);
  if (shared.engine) std::fprintf(stderr, "glovepose serve: engine stream on 127.0.0.1:%u\n", shared.engine->port());
  const bool live = std::any_of(gloves.begin(), gloves.end(), [](const auto& g) { return g->live(); });
  if (live && !o.normal_scheduling) std::fprintf(stderr, "glovepose serve: %s\n", ask_for_real_time().c_str());

  // One thread reads every glove: with one, it waits up to 20 ms for its link; with two, 1 ms each
  // in turn, so a frame waits at most about 1 ms while the other glove's link is read.
  const std::chrono::milliseconds wait(several ? 1 : 20);
  using Clock = std::chrono::steady_clock;
  const auto started = Clock::now();
  auto told = started;
  while (!serve_stop) {
    if (o.seconds > 0 && Clock::now() - started >= std::chrono::duration<double>(o.seconds)) break;
    if (shared.engine) shared.engine->accept();
    bool reading = false;
    for (auto& glove : gloves) reading = glove->poll(wait) || reading;
    if (!reading) break;  // every file or stdin has ended
    if (o.stats && Clock::now() - told >= std::chrono::seconds(1)) {
      const double span = std::chrono::duration<double>(Clock::now() - told).count();
      for (auto& glove : gloves) glove->tell_stats(span, shared.engine ? shared.engine->clients() : std::size_t{0});
      told = Clock::now();
    }
  }
  if (shared.engine) {
    const EngineCounts& e = shared.engine->counts();
    std::fprintf(stderr, "glovepose serve: engine stream: %llu clients, %llu messages sent, %llu missed by clients that did not read, %llu gone\n",
                 static_cast<unsigned long long>(e.clients), static_cast<unsigned long long>(e.sent), static_cast<unsigned long long>(e.skipped),
                 static_cast<unsigned long long>(e.gone));
  }
  for (auto& glove : gloves) glove->finish();
  return 0;
}

}  // namespace

Command add_serve(CLI::App& tool) {
  auto o = std::make_shared<ServeOptions>();
  CLI::App* command = tool.add_subcommand(
      "serve",
      "Reads a glove's link, or a left and a right glove's (reopened when they go away), turns the readings into poses and publishes each "
      "at once: the engine stream "
      "(TCP on 127.0.0.1, any number of clients), OSC over UDP, VRChat avatar parameters, OpenGloves lines and the viewer's page "
      "(docs/pose_stream.md). With --profiles, a glove's and user's "
      "calibration is loaded when that glove says its Hello, or made on the fly and saved.");
  // No default link: a service reads a glove (serve() says so when none is given).
  CLI::Option* in = command->add_option("--in", o->in, kLinkHelp)->type_name("SOURCE");
  command->add_option("--left", o->left, "the left glove's link (as --in), with or without --right")->type_name("SOURCE")->excludes(in);
  command->add_option("--right", o->right, "the right glove's link (as --in), with or without --left")->type_name("SOURCE")->excludes(in);
  add_model_file(*command, o->model, std::string("weights (default: models/") + kShippedModel + ", shipped with glovepose)");
  add_weight_storage(*command, o->storage, false);
  command->add_option("--hand", o->hand, "which hand the --in glove is on, as the outputs name it (default right)")
      ->check(CLI::IsMember({"left", "right"}))
      ->needs(in);
  add_glove_line_calibration(*command, o->calibration_seconds, o->calibration_seconds_given, o->calibration, nullptr);
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
                      "named by the symlink LINK), a serial port (serial:PORT[@BAUD] or its path) or a file; or on Windows its messages "
                      "to the named pipe of SteamVR's driver (pipe: alone; pipe:NAME another); '{hand}' in it becomes left or right "
                      "(needed with two gloves)")
      ->type_name("TARGET");
  add_number(*command, "--opengloves-max", "N", o->opengloves_max,
             "the value of a full curl in OpenGloves lines: the driver's max_analog_value (default 4095, SteamVR's; Monado's is 1023)")
      ->check(CLI::Range(1, 9999))
      ->needs(opengloves);
  command->add_flag("--opengloves-joints", o->opengloves_joints,
                    "also each joint's curl in OpenGloves lines (SteamVR's driver only: the lines grow past Monado's 150 bytes)")
      ->needs(opengloves);
  add_number(*command, "--view", "PORT", o->view_port,
             "show the glove's hand in the browser, as glovepose view does, on 127.0.0.1:PORT (0: a free port, printed); with two gloves "
             "the left's page is on PORT + 1; during the calibration it shows each step's target pose")
      ->check(CLI::Range(0, 65534));
  add_number(*command, "--seconds", "S", o->seconds, "stop after S seconds (default: at SIGINT or SIGTERM, or when a file ends)")
      ->check(above(0.0));
  command->add_flag("--no-real-time", o->normal_scheduling, "keep normal scheduling (by default a live link's thread asks for real-time)");
  command->add_flag("--stats", o->stats, "print the rate, the clients and the latency the service adds every second");
  return {command, [o] { return serve(*o); }};
}

}  // namespace glovepose::cli
