// glovepose view: a live view of the hand in the browser: a local web server (loopback only) whose page draws the
//   estimator's OpenXR joints in 3D with WebGL, the 25 angles, the trust flags, the calibration step
//   with its target pose, and the latency. The glove is a simulated new user streamed in real time
//   (default), a recorded dataset with raw rows replayed in real time (--replay), or a real glove on stdin
//   (--stdin): any glove's frames, one "timestamp,cell,...,cell" line each (the model's glove's cells in
//   the order of its description), or the built-in glove's raw rows, one "row,value,timestamp" line each;
//   the first 30 s of stream time, or --calibration-seconds, are the calibration, or --calibration FILE
//   is a saved one (tools/cli/glove_lines.hpp; docs/own_glove.md, "Live viewing"). The page asks for
//   the newest hand (GET /state) about 30 times a second.
#include <glovepose/estimator.hpp>

#include <nlohmann/json.hpp>


#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>

#include "commands.hpp"
#include "glove_lines.hpp"
#include "loopback_socket.hpp"
#include "new_user.hpp"
#include "view_page.hpp"

namespace glovepose::cli {
namespace {

using Clock = std::chrono::steady_clock;
using nlohmann::json;

struct ViewOptions {
  int port = 8765;
  std::string model;  // empty: the shipped one
  std::uint64_t seed = 2026;
  std::string replay;
  bool from_stdin = false;
  double calibration_seconds = kDefaultCalibrationSeconds;  // --stdin
  std::string calibration;                                  // --stdin: a saved calibration instead (empty: none)
  double seconds = 0.0;               // 0: until the glove's stream ends (or Ctrl-C)
};

// The glove's thread: streams rows into the estimator at the pace of their timestamps (stream time
// 0 is `start`), publishing the hand after each pose and the calibration's progress after each frame.
class GloveStream {
 public:
  GloveStream(GlovePoseEstimator& estimator, LatestHand& latest, std::atomic<bool>& stop)
      : estimator_(estimator), latest_(latest), stop_(stop) {}

  void recorded(const NewUser& user) {
    const Clock::time_point start = Clock::now();
    const double t0 = row_time(user, 0, 0);
    estimator_.start_calibration();
    for (std::size_t f = 0; f < user.data.frames() && !stop_; ++f) {
      if (f == user.first_session_frame) estimator_.finish_calibration();
      std::this_thread::sleep_until(
          start + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(user.data.timestamps[f] - t0)));
      for (std::size_t r = 0; r < user.data.row_count; ++r)
        (void)estimator_.push_row(static_cast<int>(r), user.data.raw_rows[f * user.data.row_count + r], row_time(user, f, r));
      latest_.publish(estimator_.state());
    }
  }

  // Lines of `format` from stdin until it ends (or stop): read_glove_lines, publishing the hand
  // after each input, with a summary on stdout.
  void from_stdin(const GloveLineFormat& format, std::optional<double> calibration_seconds, GloveLineCounts& counts) {
    read_glove_lines(
        GloveLineSource{std::cin, "stdin", "glovepose view"}, format, estimator_, calibration_seconds, counts,
        [this](Status) { latest_.publish(estimator_.state()); }, &stop_);
    if (stop_) return;
    const std::lock_guard<std::mutex> hold(counts.lock);
    std::printf("stdin: %ld lines, %ld understood, %ld skipped, %ld refused by the estimator; %ld poses\n", counts.lines, counts.inputs,
                counts.skipped, counts.rejected, counts.poses);
    std::fflush(stdout);
  }

 private:
  GlovePoseEstimator& estimator_;
  LatestHand& latest_;
  std::atomic<bool>& stop_;
};

// The newest hand as the page's JSON: pose, OpenXR joints (wrist frame, metres), the calibration
// step and its target pose's joints, latency.
json state_json(const LatestHand& latest, const GlovePoseEstimator& estimator, const GloveLineCounts& notes, Clock::time_point stream_start,
                double stream_t0) {
  HandState state;
  (void)latest.read(state);
  json out = {{"active", state.pose.valid}, {"calibrating", state.calibration.collecting}};
  {
    const std::lock_guard<std::mutex> hold(notes.lock);
    out["lines"] = notes.lines;
    out["skipped"] = notes.skipped;
    out["first_skipped"] = notes.first_skipped;
    out["zeroed"] = notes.calibration;
  }
  const XrHandLocator& locator = estimator.locator();
  const auto joints_of = [&](const hand::Angles& angles) {
    XrHandJoints joints;
    locator.locate(angles, nullptr, 0, joints);
    json list = json::array();
    for (const auto& j : joints.locations) list.push_back({j.pose.position.x, j.pose.position.y, j.pose.position.z});
    return list;
  };
  out["step"] = state.calibration.step;
  out["step_name"] = "";
  out["target_joints"] = nullptr;
  if (state.calibration.collecting && state.calibration.step >= 0 && estimator.model().pose_offset()) {
    const auto& steps = estimator.model().pose_offset()->sequence().steps();
    const auto& step = steps[static_cast<std::size_t>(state.calibration.step)];
    out["step_name"] = step.name;
    out["instruction"] = step.instruction;
    out["target_joints"] = joints_of(step.pose);
  }
  if (!state.pose.valid) return out;
  json names = json::array(), flags = json::array();
  for (const hand::Dof& dof : hand::kDofs) names.push_back(dof.name);
  for (int b = 0; b < kPoseFlagCount; ++b)
    if (state.pose.flags & (1u << b)) flags.push_back(pose_flag_name(b));
  const double stream_now = stream_t0 + std::chrono::duration<double>(Clock::now() - stream_start).count();
  out["seq"] = state.pose.sequence;
  out["angles"] = state.pose.angles;
  out["dof_names"] = names;
  out["trusted"] = state.pose.trusted();
  out["flag_names"] = flags;
  out["joints"] = joints_of(state.pose.angles);
  out["compute_us"] = 1e6 * state.pose.compute_seconds;
  out["oldest_age_ms"] = 1e3 * state.pose.oldest_age;
  out["age_ms"] = 1e3 * std::max(0.0, stream_now - state.pose.timestamp);
  return out;
}

void respond(Socket fd, const char* status, const char* type, const std::string& body) {
  send_all(fd, std::string("HTTP/1.1 ") + status + "\r\nContent-Type: " + type + "\r\nContent-Length: " + std::to_string(body.size()) +
                   "\r\nCache-Control: no-store\r\nConnection: close\r\n\r\n" + body);
}

// What the server and the glove's thread share. The thread holds it too: detached while it waits
// for stdin, it outlives view().
struct ViewShared {
  ViewShared(std::shared_ptr<const PoseModel> model, bool shipped_model)
      : format(*model, shipped_model), estimator(std::move(model), EstimatorConfig{}) {}
  GloveLineFormat format;  // refers to the glove of the estimator's model
  GlovePoseEstimator estimator;
  LatestHand latest;
  GloveLineCounts notes;
  std::string failure;  // why the glove's stream stopped; written before stream_done
  std::atomic<bool> stop{false}, stream_done{false};
};

int view(const ViewOptions& o) {
  const auto model = PoseModel::load(o.model.empty() ? shipped_model_path("glovepose_fcn512.safetensors") : o.model);
  if (!model->solver() && !o.from_stdin)
    throw Error("the model's glove '" + model->glove().id() + "' has no wiring to simulate or replay raw rows of, expected --stdin (its " +
                std::to_string(model->cell_count()) + " cells, one frame per line) or a model of a glove with a trace layout");
  auto user = std::make_shared<NewUser>();
  if (!o.replay.empty()) {
    user->data = read_dataset(o.replay);
    if (!user->data.has_raw_rows())
      throw Error("'" + o.replay + "' has no raw rows, expected a dataset written by glovepose simulate --raw-rows");
    user->cycle_rate = user->data.frame_rate();
    while (user->first_session_frame < user->data.frames() && user->data.kind[user->first_session_frame] == io::kKindCalibration)
      ++user->first_session_frame;
    if (user->first_session_frame == 0)
      throw Error("'" + o.replay + "' starts with no calibration frames (kind 1), expected a calibration sequence before the session");
  } else if (!o.from_stdin) {
    *user = simulate_new_user(o.seed, 10.0, *model);
  }
  const auto shared = std::make_shared<ViewShared>(model, o.model.empty());
  const SocketLibrary sockets;
  const auto [server, port] = listen_on_loopback(o.port);
  std::printf("glovepose view: http://127.0.0.1:%d/\n", port);
  std::fflush(stdout);
  const Clock::time_point start = Clock::now();
  const double stream_t0 = o.from_stdin ? 0.0 : row_time(*user, 0, 0);
  if (!o.calibration.empty()) shared->estimator.load_calibration(o.calibration);
  const std::optional<double> calibration_seconds = on_the_fly_seconds(o.calibration_seconds, o.calibration);
  std::thread glove([shared, user, from_stdin = o.from_stdin, calibration_seconds] {
    try {
      GloveStream stream(shared->estimator, shared->latest, shared->stop);
      if (from_stdin)
        stream.from_stdin(shared->format, calibration_seconds, shared->notes);
      else
        stream.recorded(*user);
    } catch (const Error& e) {
      shared->failure = e.what();
    }
    shared->stream_done = true;
  });
  // The stream failed: nothing more to show, the tool says why and exits.
  const auto failed = [&] { return shared->stream_done && !shared->failure.empty(); };
  const auto finished = [&] {
    return failed() ||
           (o.seconds > 0.0 ? std::chrono::duration<double>(Clock::now() - start).count() >= o.seconds : shared->stream_done.load());
  };
  while (!finished()) {
    if (!wait_readable(server, 100)) continue;
    const Socket client = ::accept(server, nullptr, nullptr);
    if (client == kNoSocket) continue;
    const std::string request = receive_some(client, 2047);
    const std::string line = request.substr(0, request.find('\r'));
    if (line.rfind("GET / ", 0) == 0 || line.rfind("GET /index.html ", 0) == 0)
      respond(client, "200 OK", "text/html; charset=utf-8", kViewPage);
    else if (line.rfind("GET /state", 0) == 0)
      respond(client, "200 OK", "application/json", state_json(shared->latest, shared->estimator, shared->notes, start, stream_t0).dump());
    else
      respond(client, "404 Not Found", "text/plain", "not found\n");
    close_socket(client);
  }
  shared->stop = true;
  close_socket(server);
  if (shared->stream_done || !o.from_stdin)
    glove.join();  // a recording stops at its next frame
  else
    glove.detach();  // blocked reading stdin; it holds what it uses
  if (failed()) throw Error(shared->failure);
  return 0;
}

}  // namespace

Command add_view(CLI::App& tool) {
  auto o = std::make_shared<ViewOptions>();
  CLI::App* command = tool.add_subcommand(
      "view",
      "A live view of the hand in the browser: a local web server (loopback only) whose page draws the estimator's joints in 3D, "
      "the 25 angles, the trust flags, the calibration step with its target pose, and the latency. The glove is a simulated new "
      "user streamed in real time (default), a recorded dataset replayed (--replay), or a real glove on stdin (--stdin).");
  add_number(*command, "--port", "P", o->port, "port on 127.0.0.1 (default 8765; 0: any free one); the address is printed")
      ->check(CLI::Range(0, 65535));
  add_model_file(*command, o->model, "weights (default: the shipped model)");
  add_number(*command, "--seed", "S", o->seed, "simulation seed of the simulated user (default 2026)");
  CLI::Option* replay =
      command->add_option("--replay", o->replay, "a dataset with raw rows (glovepose simulate --raw-rows), replayed in real time")
          ->check(existing_file())
          ->type_name("FILE");
  CLI::Option* from_stdin =
      command
          ->add_flag("--stdin", o->from_stdin,
                     "a real glove on stdin: one frame per line, 'timestamp,cell,...,cell' (the model's glove's cells "
                     "in the order of its description), or for the built-in glove one raw row per line, "
                     "'row,value,timestamp'; the first --calibration-seconds of stream time calibrate, or --calibration FILE")
          ->excludes(replay);
  add_glove_line_calibration(*command, o->calibration_seconds, o->calibration, from_stdin);
  add_number(*command, "--seconds", "N", o->seconds, "stop serving after N seconds (default: when the stream ends)")->check(at_least(0.0));
  return {command, [o] { return view(*o); }};
}

}  // namespace glovepose::cli
