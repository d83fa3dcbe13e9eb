// glovepose view: a live view of the hand in the browser. A local web server (loopback only) serves
//   a page (tools/cli/web: three.js, embedded at build time) that draws the hand model's own spheres
//   and capsules (the OpenXR joints with their radii, on the subject's hand), the truth overlaid when
//   the source is simulated, the two 5x5 stretch maps and the 5x5 pose map, angle traces, the pinch
//   state, the trust flags, the calibration step with its target pose, and the latency; the server
//   pushes the newest hand to every open page about 30 times a second (Server-Sent Events, GET /events).
//   The glove is a simulated new user streamed in real time (default), a recorded dataset with raw rows
//   replayed in real time (--replay), or a real glove on stdin (--stdin): any glove's frames, one
//   "timestamp,cell,...,cell" line each (the model's glove's cells in the order of its description),
//   or the built-in glove's raw rows, one "row,value,timestamp" line each; the first 30 s of stream
//   time, or --calibration-seconds, are the calibration, or --calibration FILE is a saved one
//   (tools/cli/glove_lines.hpp; docs/own_glove.md, "Live viewing").
#include <glovepose/calibration/pose_offset.hpp>
#include <glovepose/estimator.hpp>
#include <glovepose/grid/grid_map.hpp>
#include <glovepose/hand/xr_hand.hpp>
#include <glovepose/model/pose_network.hpp>
#include <glovepose/sim/subject.hpp>

#include <nlohmann/json.hpp>

#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <list>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>

#include "commands.hpp"
#include "glove_frames.hpp"
#include "loopback_socket.hpp"
#include "new_user.hpp"
#include "session_options.hpp"
#include "view_page.hpp"

namespace glovepose::cli {
namespace {

using Clock = std::chrono::steady_clock;
using nlohmann::json;

// The server's limits: a request head is at most 8 KB and must arrive within 2 s (else 431 or
// 408); a page that takes no data for 2 s is dropped; at most 32 connections at once (else 503).
// Events go out about 30 times a second, the rate the page draws at.
constexpr std::size_t kMaxRequestHead = 8192;
constexpr int kRequestTimeoutMs = 2000;
constexpr int kSendTimeoutMs = 2000;
// Connections served at once, one thread each (a stalled reader costs a thread until the send
// time-out drops it); beyond, a request is answered 503 at once.
constexpr std::size_t kMaxConnections = 256;
constexpr std::chrono::duration<double> kEventPeriod(1.0 / 30.0);

struct ViewOptions {
  int port = 8765;
  SessionOptions session;  // --model, --weights, --seed (of the simulated user)
  std::string glove;       // --glove: checked against the model's
  std::string replay;
  bool from_stdin = false;
  double calibration_seconds = kDefaultCalibrationSeconds;  // --stdin
  bool calibration_seconds_given = false;
  std::string calibration;                                  // --stdin: a saved calibration instead (empty: none)
  double seconds = 0.0;                                     // 0: until the glove's stream ends (or Ctrl-C)
};

// What the glove's thread hands to the server's threads after each input (through a Latest: copied
// as words, never torn): the hand, its pinch state, the maps the network read and wrote, the truth.
struct ViewFrame {
  HandState hand;
  hand::XrHandAim aim;
  std::array<float, grid::kStretchValues> stretch{};  // the calibrated cells on the two 5x5 stretch maps
  std::array<float, grid::kMapSlots> pose_map{};      // the pose's angles normalised by the joint limits, on the 5x5 pose map
  bool maps = false;                                  // stretch and pose_map hold the latest pose's
  hand::Angles truth{};                               // the simulated person's true angles at this frame
  bool has_truth = false;
  double stream_time = 0.0;  // the glove stream's clock at this frame (s)
};

// The glove's thread: streams rows into the estimator at the pace of their timestamps (stream time
// 0 is `start`), publishing a ViewFrame after each frame.
class GloveStream {
 public:
  GloveStream(GlovePoseEstimator& estimator, core::Latest<ViewFrame>& latest, std::atomic<bool>& stop)
      : estimator_(estimator), latest_(latest), stop_(stop) {}

  // `clock`: set to the stream's time at `served_from` (the recording's clock against the server's).
  void recorded(const NewUser& user, Clock::time_point served_from, std::atomic<double>& clock) {
    const Clock::time_point start = Clock::now();
    const double t0 = row_time(user, 0, 0);
    clock = t0 - std::chrono::duration<double>(start - served_from).count();
    const bool truth = user.data.has_true_angles();
    estimator_.start_calibration();
    for (std::size_t f = 0; f < user.data.frames() && !stop_; ++f) {
      if (f == user.first_session_frame) estimator_.finish_calibration();
      std::this_thread::sleep_until(
          start + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(user.data.timestamps[f] - t0)));
      for (std::size_t r = 0; r < user.data.row_count; ++r)
        (void)estimator_.push_row(static_cast<int>(r), user.data.raw_rows[f * user.data.row_count + r], row_time(user, f, r));
      frame_.has_truth = truth;
      if (truth)
        for (std::size_t d = 0; d < hand::kDofCount; ++d) frame_.truth[d] = user.data.true_angles[f * hand::kDofCount + d];
      publish(user.data.timestamps[f]);
    }
  }

  // Lines of `format` from stdin until it ends (or stop): read_glove_lines, publishing after each
  // input, with a summary on stdout.
  void from_stdin(const GloveLineFormat& format, std::optional<double> calibration_seconds, GloveLineCounts& counts) {
    binary_stdin();
    device::LinkCounts link;
    read_glove_stream(
        GloveLineSource{std::cin, "stdin", "glovepose view"}, format, estimator_, calibration_seconds, counts,
        [this](Status) { publish(estimator_.pose().timestamp); }, link, &stop_);
    if (stop_) return;
    const std::lock_guard<std::mutex> hold(counts.lock);
    if (link.bytes > 0)
      std::printf("stdin: %ld frames, %ld inputs, %ld skipped, %ld refused by the estimator; %ld poses\nstdin: link: %s\n", counts.lines,
                  counts.inputs, counts.skipped, counts.rejected, counts.poses, link_summary(link).c_str());
    else
      std::printf("stdin: %ld lines, %ld understood, %ld skipped, %ld refused by the estimator; %ld poses\n", counts.lines, counts.inputs,
                  counts.skipped, counts.rejected, counts.poses);
    std::fflush(stdout);
  }

 private:
  void publish(double stream_time) {
    frame_.hand = estimator_.state();
    frame_.aim = estimator_.aim();
    frame_.stream_time = stream_time;
    frame_.maps = frame_.hand.pose.valid &&
                  estimator_.model().glove().map().to_stretch_maps(estimator_.normalized_cells().data(), frame_.stretch) == Status::Ok;
    if (frame_.maps)
      estimator_.model().glove().map().to_pose_map(estimator_.model().joint_limits().normalize(frame_.hand.pose.angles), frame_.pose_map);
    latest_.publish(frame_);
  }

  GlovePoseEstimator& estimator_;
  core::Latest<ViewFrame>& latest_;
  std::atomic<bool>& stop_;
  ViewFrame frame_;
};

// What the server and the glove's thread share. The thread holds it too: detached while it waits
// for stdin, it outlives view().
struct ViewShared {
  ViewShared(std::shared_ptr<const PoseModel> model, bool shipped_model, const EstimatorConfig& config)
      : format(*model, shipped_model), estimator(std::move(model), config) {}
  GloveLineFormat format;  // refers to the glove of the estimator's model
  GlovePoseEstimator estimator;
  core::Latest<ViewFrame> latest;
  GloveLineCounts notes;
  std::string failure;  // why the glove's stream stopped; written before stream_done
  std::atomic<bool> stop{false}, stream_done{false};
  std::atomic<bool> preparing{false};            // the simulated user is being made
  Clock::time_point served_from = Clock::now();  // when the server started
  std::atomic<double> stream_clock{0.0};         // the glove stream's time at served_from (stdin: 0)
  // The newest frame's event, made once for every page that streams it (state_event()).
  mutable std::mutex event_lock;
  mutable std::uint64_t event_number = 0;
  mutable std::shared_ptr<const std::string> event_text;
};


json degrees(const hand::Angles& angles) {
  json out = json::array();
  for (double a : angles) out.push_back(std::round(a * core::kDegreesPerRadian * 100.0) / 100.0);
  return out;
}

// The OpenXR joints' positions (wrist frame, millimetres) of `angles` on the estimator's hand.
json joints_mm(const hand::XrHandLocator& locator, const hand::Angles& angles) {
  hand::XrHandJoints joints;
  locator.locate(angles, nullptr, 0, joints);
  json list = json::array();
  for (const auto& j : joints.locations)
    list.push_back({std::round(j.pose.position.x * 1e4) / 10.0, std::round(j.pose.position.y * 1e4) / 10.0,
                    std::round(j.pose.position.z * 1e4) / 10.0});
  return list;
}

// What does not change while the tool runs, sent once to each page: the hand's geometry (the joints'
// parents and radii), readable names, the maps' layouts, the calibration sequence.
json meta_json(const GlovePoseEstimator& estimator, bool has_truth, const std::string& source) {
  const PoseModel& model = estimator.model();
  hand::XrHandJoints rest;
  estimator.locator().locate(hand::Angles{}, nullptr, 0, rest);
  json radii = json::array(), parents = json::array(), joint_names = json::array();
  for (std::size_t j = 0; j < hand::kXrJointCount; ++j) {
    radii.push_back(std::round(rest.locations[j].radius * 1e4) / 10.0);
    parents.push_back(hand::kXrJointParent[j]);
    joint_names.push_back(hand::kXrJointNames[j]);
  }
  json dof_names = json::array(), dof_fingers = json::array();
  for (const hand::Dof& dof : hand::kDofs) {
    dof_names.push_back(dof.name);
    dof_fingers.push_back(static_cast<int>(dof.finger));
  }
  // Each map as 5 rows of 5 names (null: an empty slot).
  const auto grid = [] { return json(std::vector<std::vector<json>>(grid::kGridSize, std::vector<json>(grid::kGridSize, nullptr))); };
  json stretch = json::array({grid(), grid()}), pose = grid();
  const grid::GridMap& map = model.glove().map();
  for (std::size_t c = 0; c < map.cell_slots().size(); ++c) {
    const grid::Slot& s = map.cell_slots()[c];
    if (s.on_maps()) stretch[s.channel][s.row][s.col] = model.glove().cell_names()[c];
  }
  for (std::size_t d = 0; d < hand::kDofCount; ++d) pose[map.dof_slots()[d].row][map.dof_slots()[d].col] = hand::kDofs[d].name;
  json steps = json::array();
  if (model.pose_offset())
    for (const auto& step : model.pose_offset()->sequence().steps())
      steps.push_back({{"name", step.name}, {"instruction", step.instruction}, {"seconds", step.seconds}});
  json fault = json::array();
  for (int b = 0; b < kPoseFlagCount; ++b) fault.push_back((kPoseFaultFlags & (1u << b)) != 0);
  return {{"source", source},
          {"has_truth", has_truth},
          {"side", estimator.config().handedness == hand::Handedness::Left ? "left" : "right"},
          {"radii_mm", radii},
          {"parents", parents},
          {"joint_names", joint_names},
          {"dof_names", dof_names},
          {"dof_fingers", dof_fingers},
          {"stretch_names", stretch},
          {"pose_names", pose},
          {"glove", model.glove().id()},
          {"steps", steps},
          {"flag_is_fault", fault},
          {"pinch_threshold_mm", hand::kPinchThresholdMm},
          {"pinch_release_mm", hand::kPinchReleaseMm},
          {"event_hz", 1.0 / kEventPeriod.count()}};
}

// The newest frame as the page's JSON (angles in degrees, positions in millimetres in the wrist
// frame, maps in [-1, 1] as 5 x 5 rows).
json state_json(const ViewFrame& frame, std::uint64_t number, const ViewShared& shared) {
  const HandState& state = frame.hand;
  const GlovePoseEstimator& estimator = shared.estimator;
  json out = {{"active", state.pose.valid},
              {"calibrating", state.calibration.collecting},
              {"published", number},
              {"preparing", shared.preparing.load()}};
  {
    const std::lock_guard<std::mutex> hold(shared.notes.lock);
    out["lines"] = shared.notes.lines;
    out["skipped"] = shared.notes.skipped;
    out["first_skipped"] = shared.notes.first_skipped;
    out["zeroed"] = shared.notes.calibration;
  }
  const hand::XrHandLocator& locator = estimator.locator();
  out["t"] = frame.stream_time;
  out["step"] = state.calibration.step;
  out["calibration_frames"] = state.calibration.frames;
  out["sequence_seconds"] = state.calibration.sequence_seconds;
  out["target_joints"] = nullptr;
  if (state.calibration.collecting && state.calibration.step >= 0 && estimator.model().pose_offset()) {
    const auto& steps = estimator.model().pose_offset()->sequence().steps();
    const auto& step = steps[static_cast<std::size_t>(state.calibration.step)];
    out["step_name"] = step.name;
    out["instruction"] = step.instruction;
    out["target_joints"] = joints_mm(locator, step.pose);
  }
  out["truth_joints"] = frame.has_truth ? joints_mm(locator, frame.truth) : json(nullptr);
  out["truth_deg"] = frame.has_truth ? degrees(frame.truth) : json(nullptr);
  if (!state.pose.valid) return out;
  json flags = json::array();
  for (int b = 0; b < kPoseFlagCount; ++b)
    if (state.pose.flags & (1u << b)) flags.push_back(pose_flag_name(b));
  const double stream_now = shared.stream_clock + std::chrono::duration<double>(Clock::now() - shared.served_from).count();
  out["seq"] = state.pose.sequence;
  out["angles"] = state.pose.angles;  // radians, for tools reading GET /state
  out["angles_deg"] = degrees(state.pose.angles);
  out["trusted"] = state.pose.trusted();
  out["flags"] = state.pose.flags;
  out["flag_names"] = flags;
  out["joints"] = joints_mm(locator, state.pose.angles);
  out["compute_us"] = std::round(1e7 * state.pose.compute_seconds) / 10.0;
  out["oldest_age_ms"] = std::round(1e4 * state.pose.oldest_age) / 10.0;
  out["age_ms"] = std::round(1e4 * std::max(0.0, stream_now - state.pose.timestamp)) / 10.0;
  json pinch = json::array();
  for (std::size_t p = 0; p < hand::kPinchPairCount; ++p)
    pinch.push_back({{"strength", frame.aim.pinch_strength[p]},
                     {"distance_mm",
                      std::isfinite(frame.aim.distance_mm[p]) ? json(std::round(frame.aim.distance_mm[p] * 10.0) / 10.0) : json(nullptr)},
                     {"pinching", (frame.aim.status & (hand::kXrAimIndexPinching << p)) != 0}});
  out["pinch"] = pinch;
  out["aim_valid"] = (frame.aim.status & hand::kXrAimValid) != 0;
  if (frame.maps) {
    const auto rows = [](const float* values) {
      json map = json::array();
      for (int r = 0; r < grid::kGridSize; ++r)
        map.push_back(std::vector<float>(values + r * grid::kGridSize, values + (r + 1) * grid::kGridSize));
      return map;
    };
    out["stretch"] = json::array({rows(frame.stretch.data()), rows(frame.stretch.data() + grid::kMapSlots)});
    out["pose_map"] = rows(frame.pose_map.data());
  }
  return out;
}

// The event-stream message of the newest frame and its number (0: none yet), serialised by the first
// page's thread that asks for a frame and shared with the others: a hundred pages cost one
// serialisation per frame, not a hundred.
std::pair<std::shared_ptr<const std::string>, std::uint64_t> state_event(const ViewShared& shared) {
  const std::lock_guard<std::mutex> hold(shared.event_lock);
  if (shared.latest.published() != shared.event_number) {
    ViewFrame frame;
    shared.event_number = shared.latest.read(frame);
    shared.event_text = std::make_shared<const std::string>("data: " + state_json(frame, shared.event_number, shared).dump() + "\n\n");
  }
  return {shared.event_text, shared.event_number};
}

const ViewAsset* find_asset(const std::string& path) {
#if GLOVEPOSE_VIEW_PAGE
  for (const ViewAsset& asset : kViewAssets)
    if (path == asset.path || (path == "/index.html" && std::strcmp(asset.path, "/") == 0)) return &asset;
#else
  (void)path;
#endif
  return nullptr;
}

const char* content_type(const std::string& path) {
  const auto ends = [&](const char* tail) {
    const std::size_t n = std::strlen(tail);
    return path.size() >= n && path.compare(path.size() - n, n, tail) == 0;
  };
  if (ends(".js")) return "text/javascript; charset=utf-8";
  if (ends(".txt")) return "text/plain; charset=utf-8";
  return "text/html; charset=utf-8";
}

// One connection, on its own thread (so a slow or stalled client holds up only itself): its request
// head within the limits, then a file, the state, or the event stream until the tool stops or the
// page goes away.
void serve_connection(Socket client, const ViewShared& shared, const std::string& meta) {
  const std::atomic<bool>& stop = shared.stop;
  set_send_timeout(client, kSendTimeoutMs);
  const RequestHead head = read_request_head(client, kMaxRequestHead, kRequestTimeoutMs, stop);
  if (head.status == 0) return;  // the peer went away
  if (head.status != 200) {
    send_error(client, head.status);
    return;
  }
  const bool get = head.method == "GET";
  if (!get && head.method != "HEAD") {
    send_error(client, 405);
    return;
  }
  const std::string path = head.target.substr(0, head.target.find('?'));
  const auto answer = [&](const char* type, const std::string& body) {
    send_all(client, std::string("HTTP/1.1 200 OK\r\nContent-Type: ") + type + "\r\nContent-Length: " + std::to_string(body.size()) +
                         "\r\nCache-Control: no-store\r\nConnection: close\r\n\r\n" + (get ? body : std::string()));
  };
  if (path == "/state") {
    ViewFrame frame;
    const std::uint64_t number = shared.latest.read(frame);
    answer("application/json", state_json(frame, number, shared).dump());
    return;
  }
  if (path == "/meta") {
    answer("application/json", meta);
    return;
  }
  if (path == "/events") {
    const std::string head = "HTTP/1.1 200 OK\r\nContent-Type: text/event-stream\r\nCache-Control: no-store\r\nConnection: close\r\n\r\n";
    if (!get) {
      (void)send_all(client, head);
      return;
    }
    if (!send_all(client, head + "event: meta\ndata: " + meta + "\n\n")) return;
    // The newest frame at each tick, when there is a new one; a comment every second otherwise, so
    // that a page whose tool went quiet still finds out when it went away.
    std::uint64_t sent = 0;
    Clock::time_point tick = Clock::now(), quiet_since = tick;
    while (!stop) {
      const auto [event, number] = state_event(shared);
      if (number != sent) {
        if (!send_all(client, *event)) return;
        sent = number;
        quiet_since = tick;
      } else if (tick - quiet_since > std::chrono::seconds(1)) {
        if (!send_all(client, ": waiting for the glove\n\n")) return;
        quiet_since = tick;
      }
      tick += std::chrono::duration_cast<Clock::duration>(kEventPeriod);
      std::this_thread::sleep_until(tick);
    }
    return;
  }
  const ViewAsset* asset = find_asset(path);
  if (asset == nullptr) {
    send_error(client, 404);
    return;
  }
  std::string body;
  body.reserve(asset->size);
  for (const char* const* chunk = asset->chunks; *chunk != nullptr; ++chunk) body += *chunk;
  answer(content_type(path), body);
}

// The connections being served: one thread each; finished ones are joined as new ones come.
class Connections {
 public:
  ~Connections() { join_all(); }
  bool full() {
    reap();
    return running_.size() >= kMaxConnections;
  }
  template <typename Serve>
  void start(Socket client, Serve serve) {
    auto& c = running_.emplace_back();
    c.done = std::make_shared<std::atomic<bool>>(false);
    c.thread = std::thread([client, serve, done = c.done] {
      serve(client);
      close_socket(client);
      *done = true;
    });
  }
  void join_all() {
    for (auto& c : running_) c.thread.join();
    running_.clear();
  }

 private:
  struct Running {
    std::thread thread;
    std::shared_ptr<std::atomic<bool>> done;
  };
  void reap() {
    for (auto it = running_.begin(); it != running_.end();)
      if (*it->done) {
        it->thread.join();
        it = running_.erase(it);
      } else {
        ++it;
      }
  }
  std::list<Running> running_;
};

int view(const ViewOptions& o) {
#if !GLOVEPOSE_VIEW_PAGE
  throw Error("this glovepose was built without the view's page (CMake GLOVEPOSE_VIEW_PAGE=OFF, as tools/demo.sh builds a new tree): "
              "run tools/setup.sh --view, then cmake -S . -B build -DGLOVEPOSE_VIEW_PAGE=ON && cmake --build build --target glovepose_cli");
#endif
  const std::string model_path = o.session.model_path();
  const auto model = o.session.load_model();
  check_glove(o.glove, model->glove(), model_path);
  if (!model->solver() && !o.from_stdin)
    throw Error("the model's glove '" + model->glove().id() + "' has no wiring to simulate or replay raw rows of, expected --stdin (its " +
                std::to_string(model->cell_count()) + " cells, one frame per line) or a model of a glove with a trace layout");
  auto user = std::make_shared<NewUser>();
  if (!o.replay.empty()) {
    user->data = read_dataset(o.replay);
    if (!user->data.has_raw_rows())
      throw Error("'" + o.replay + "' has no raw rows, expected a dataset written by glovepose simulate --raw-rows");
    user->cycle_rate = user->data.frame_rate();
    user->first_session_frame = user->data.first_session_frame();
    if (user->first_session_frame == 0)
      throw Error("'" + o.replay + "' starts with no calibration frames (kind 1), expected a calibration sequence before the session");
  }
  const bool simulated = o.replay.empty() && !o.from_stdin;
  // The simulated person's own hand (subject 0 of the seed, as simulate_new_user draws it): the page
  // draws it at their size. A replay or a real glove: the reference hand.
  EstimatorConfig config;
  if (simulated) config.hand = std::make_shared<const hand::HandModel>(sim::make_subjects(1, o.session.seed, sim::default_world().people)[0].hand_model());
  const auto shared = std::make_shared<ViewShared>(model, o.session.model.empty(), config);
  shared->preparing = simulated;  // until the glove's thread has made the simulated user
  const SocketLibrary sockets;
  const auto [server, port] = listen_on_loopback(o.port);
  std::printf("glovepose view: http://127.0.0.1:%d/\n", port);  // at once: the simulated user is made on the glove's thread
  std::fflush(stdout);
  const bool has_truth = simulated || user->data.has_true_angles();
  const std::string meta =
      meta_json(shared->estimator, has_truth, o.from_stdin ? "stdin" : (simulated ? "simulated new user" : "replay of " + o.replay)).dump();
  const Clock::time_point start = shared->served_from;
  std::optional<double> calibration_seconds;
  if (o.from_stdin) {
    const GloveCalibrationChoice calibration =
        choose_glove_calibration(*model, o.calibration_seconds, o.calibration_seconds_given, o.calibration);
    if (!o.calibration.empty()) shared->estimator.load_calibration(o.calibration);
    calibration.apply(shared->estimator);
    calibration_seconds = calibration.on_the_fly;
    std::fprintf(stderr, "glovepose view: calibration: %s\n", calibration.text.c_str());
  }
  std::thread glove([shared, user, simulated, seed = o.session.seed, from_stdin = o.from_stdin, calibration_seconds] {
    try {
      GloveStream stream(shared->estimator, shared->latest, shared->stop);
      if (from_stdin) {
        stream.from_stdin(shared->format, calibration_seconds, shared->notes);
      } else {
        if (simulated) {
          *user = simulate_new_user(seed, 10.0, shared->estimator.model());
          shared->preparing = false;
        }
        stream.recorded(*user, shared->served_from, shared->stream_clock);
      }
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
  {
    Connections connections;
    while (!finished()) {
      if (!wait_readable(server, 100)) continue;
      const Socket client = ::accept(server, nullptr, nullptr);
      if (client == kNoSocket) continue;
      if (connections.full()) {  // refused at once rather than queued behind the open streams
        send_error(client, 503);
        close_socket(client);
        continue;
      }
      connections.start(client, [&shared = *shared, &meta](Socket c) { serve_connection(c, shared, meta); });
    }
    shared->stop = true;  // the event streams end at their next tick
  }
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
      "A live view of the hand in the browser: a local web server (loopback only) whose page draws the hand in 3D (the truth beside "
      "it when simulated), the glove's stretch maps and the pose map, angle traces, pinch state, the trust flags, the calibration "
      "step with its target pose, and the latency. The glove is a simulated new user streamed in real time (default), a recorded "
      "dataset replayed (--replay), or a real glove on stdin (--stdin).");
  add_number(*command, "--port", "P", o->port, "port on 127.0.0.1 (default 8765; 0: any free one); the address is printed")
      ->check(CLI::Range(0, 65535));
  o->session.add_to(*command, "simulation seed of the simulated user (default 2026)");
  add_glove_file(*command, o->glove, "the glove the readings come from; refused unless the model was trained for it (default: the model's)");
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
  add_glove_line_calibration(*command, o->calibration_seconds, o->calibration_seconds_given, o->calibration, from_stdin);
  add_number(*command, "--seconds", "N", o->seconds, "stop serving after N seconds (default: when the stream ends)")->check(at_least(0.0));
  return {command, [o] { return view(*o); }};
}

}  // namespace glovepose::cli
