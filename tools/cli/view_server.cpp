// The viewer's web server (view_server.hpp): the page's JSON, its files, one thread per connection.
#include "view_server.hpp"

#include <glovepose/grid/grid_map.hpp>
#include <glovepose/hand/xr_hand.hpp>
#include <glovepose/model/pose_network.hpp>

#include <nlohmann/json.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <list>
#include <mutex>
#include <thread>

#include <glovepose/core/latest.hpp>

#include "loopback_socket.hpp"
#include "view_page.hpp"

namespace glovepose::cli {
namespace {

using Clock = std::chrono::steady_clock;
using nlohmann::json;

// The server's limits: a request head is at most 8 KB and must arrive within 2 s (else 431 or
// 408); a page that takes no data for 2 s is dropped. Events go out about 30 times a second, the
// rate the page draws at.
constexpr std::size_t kMaxRequestHead = 8192;
constexpr int kRequestTimeoutMs = 2000;
constexpr int kSendTimeoutMs = 2000;
// Connections served at once, one thread each (a stalled reader costs a thread until the send
// time-out drops it); beyond, a request is answered 503 at once.
constexpr std::size_t kMaxConnections = 256;
constexpr std::chrono::duration<double> kEventPeriod(1.0 / 30.0);

}  // namespace

// What the glove's thread hands to the server's threads after each input (through a Latest: copied
// as words, never torn): the hand, its pinch state, the maps the network read and wrote, the truth.
struct ViewFrame {
  HandState hand;
  hand::XrHandAim aim;
  std::array<float, grid::kStretchValues> stretch{};  // the calibrated cells on the two 5x5 stretch maps
  std::array<float, grid::kMapSlots> pose_map{};      // the pose's angles normalised by the joint limits, on the 5x5 pose map
  bool maps = false;                                  // stretch and pose_map hold the latest pose's
  hand::Angles truth{};                               // the true angles at this frame
  bool has_truth = false;
  double stream_time = 0.0;  // the glove stream's clock at this frame (s)
};

// What the server's threads share: set up once, then the newest frame and the event made of it.
struct ViewServer::State {
  State(const GlovePoseEstimator& e, const GloveLineCounts& n) : estimator(e), notes(n) {}
  const GlovePoseEstimator& estimator;
  const GloveLineCounts& notes;
  SocketLibrary sockets;
  Socket listening = kNoSocket;
  int port = 0;
  std::string meta;
  core::Latest<ViewFrame> latest;
  ViewFrame frame;  // the glove's thread's, filled by publish()
  std::atomic<bool> stop{false}, preparing{false};
  Clock::time_point served_from = Clock::now();
  std::atomic<double> stream_clock{0.0};
  std::thread thread;  // start()'s
  // The newest frame's event, made once for every page that streams it (state_event()).
  mutable std::mutex event_lock;
  mutable std::uint64_t event_number = 0;
  mutable std::shared_ptr<const std::string> event_text;
};

namespace {

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
json state_json(const ViewFrame& frame, std::uint64_t number, const ViewServer::State& shared) {
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
  out["confidence"] = state.pose.confidence;  // per DoF: the chance of being within 10 degrees
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
std::pair<std::shared_ptr<const std::string>, std::uint64_t> state_event(const ViewServer::State& shared) {
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
void serve_connection(Socket client, const ViewServer::State& shared) {
  const std::string& meta = shared.meta;
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

}  // namespace

ViewServer::ViewServer(const GlovePoseEstimator& estimator, int port, const ViewSource& source, const GloveLineCounts& notes)
    : state_(std::make_unique<State>(estimator, notes)) {
  const auto [listening, got] = listen_on_loopback(port);
  state_->listening = listening;
  state_->port = got;
  state_->meta = meta_json(estimator, source.has_truth, source.name).dump();
}

ViewServer::~ViewServer() { stop(); }

int ViewServer::port() const { return state_->port; }

void ViewServer::publish(const GlovePoseEstimator& estimator, double stream_time, const hand::Angles* truth) noexcept {
  ViewFrame& frame = state_->frame;
  frame.hand = estimator.state();
  frame.aim = estimator.aim();
  frame.stream_time = stream_time;
  frame.has_truth = truth != nullptr;
  if (truth) frame.truth = *truth;
  frame.maps = frame.hand.pose.valid &&
               estimator.model().glove().map().to_stretch_maps(estimator.normalized_cells().data(), frame.stretch) == Status::Ok;
  if (frame.maps)
    estimator.model().glove().map().to_pose_map(estimator.model().joint_limits().normalize(frame.hand.pose.angles), frame.pose_map);
  state_->latest.publish(frame);
}

void ViewServer::serve_until(const std::function<bool()>& finished) {
  State& s = *state_;
  {
    Connections connections;
    while (!s.stop && !finished()) {
      if (!wait_readable(s.listening, 100)) continue;
      const Socket client = ::accept(s.listening, nullptr, nullptr);
      if (client == kNoSocket) continue;
      if (connections.full()) {  // refused at once rather than queued behind the open streams
        send_error(client, 503);
        close_socket(client);
        continue;
      }
      connections.start(client, [&s](Socket c) { serve_connection(c, s); });
    }
    s.stop = true;  // the event streams end at their next tick
  }
}

void ViewServer::start() {
  state_->thread = std::thread([this] { serve_until([] { return false; }); });
}

void ViewServer::stop() {
  state_->stop = true;
  if (state_->thread.joinable()) state_->thread.join();
  if (state_->listening != kNoSocket) {
    close_socket(state_->listening);
    state_->listening = kNoSocket;
  }
}

void ViewServer::set_preparing(bool preparing) noexcept { state_->preparing = preparing; }
void ViewServer::set_stream_clock(double seconds_at_start) noexcept { state_->stream_clock = seconds_at_start; }
std::chrono::steady_clock::time_point ViewServer::served_from() const { return state_->served_from; }

}  // namespace glovepose::cli
