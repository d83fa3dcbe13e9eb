// The viewer's web server (loopback only), shared by glovepose view and glovepose serve --view: it
// serves a page (tools/cli/web: three.js, embedded at build time) that draws the hand model's own
// spheres and capsules (the OpenXR joints with their radii), the truth overlaid when there is one,
// the two 5x5 stretch maps and the 5x5 pose map, angle traces, the pinch state, the trust flags, the
// calibration step with its target pose, and the latency; it pushes the newest hand to every open
// page about 30 times a second (Server-Sent Events, GET /events), and answers GET /state and /meta.
// The glove's thread calls publish() after each input; the server's threads never touch the
// estimator's per-frame state, only what publish() handed over (core/latest.hpp).
#pragma once

#include <glovepose/estimator.hpp>

#include <atomic>
#include <chrono>
#include <functional>
#include <memory>
#include <string>

#include "glove_lines.hpp"

namespace glovepose::cli {

/// @brief What the page shows: the tool's glove and source.
struct ViewSource {
  std::string name;        ///< "stdin", "simulated new user", "replay of FILE", "link 'udp:9000'"
  bool has_truth = false;  ///< whether publish() gets the true angles
};

/// @brief The server: listening from construction, serving from serve_until() or start() until stop().
class ViewServer {
 public:
  /// Listens on 127.0.0.1:`port` (0: a free one). The page draws `estimator`'s hand and model; the
  /// server's threads read only its model, locator and configuration, which do not change while it
  /// runs. `notes`: the glove's line counts the page reports.
  ViewServer(const GlovePoseEstimator& estimator, int port, const ViewSource& source, const GloveLineCounts& notes);
  ViewServer(const ViewServer&) = delete;
  ViewServer& operator=(const ViewServer&) = delete;
  ~ViewServer();

  /// The port it listens on.
  int port() const;
  /// After each input: the estimator's newest hand, at `stream_time` (s), with the person's true
  /// angles when there are some. Allocation-free; the glove's thread only.
  void publish(const GlovePoseEstimator& estimator, double stream_time, const hand::Angles* truth = nullptr) noexcept;
  /// Serves on the calling thread until `finished()` (checked every 100 ms) or stop().
  void serve_until(const std::function<bool()>& finished);
  /// Serves on a thread of its own until stop().
  void start();
  /// Ends serving: no new connection; the event streams end at their next tick, their threads joined.
  void stop();

  /// The page says "preparing" while this is set (the simulated user being made).
  void set_preparing(bool preparing) noexcept;
  /// The glove stream's time when the server started: the page's latency is stream time now less
  /// the pose's timestamp (0 when the stream's clock is the host's).
  void set_stream_clock(double seconds_at_start) noexcept;
  std::chrono::steady_clock::time_point served_from() const;

  struct State;  // view_server.cpp's

 private:
  std::unique_ptr<State> state_;
};

}  // namespace glovepose::cli
