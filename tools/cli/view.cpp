// glovepose view: a live view of the hand in the browser (the page and its server: view_server.hpp).
//   The glove is a simulated new user streamed in real time (default), a recorded dataset with raw rows
//   replayed in real time (--replay), or a real glove on stdin (--stdin): any glove's frames, one
//   "timestamp,cell,...,cell" line each (the model's glove's cells in the order of its description),
//   or the built-in glove's raw rows, one "row,value,timestamp" line each; the first 30 s of stream
//   time, or --calibration-seconds, are the calibration, or --calibration FILE is a saved one
//   (tools/cli/glove_lines.hpp; docs/own_glove.md, "Live viewing"). glovepose serve --view shows a
//   served glove on the same page.
#include <glovepose/estimator.hpp>
#include <glovepose/sim/subject.hpp>

#include <atomic>
#include <chrono>
#include <cstdio>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>

#include "commands.hpp"
#include "glove_frames.hpp"
#include "new_user.hpp"
#include "session_options.hpp"
#include "view_server.hpp"

namespace glovepose::cli {
namespace {

using Clock = std::chrono::steady_clock;

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

// The glove's thread: streams rows into the estimator at the pace of their timestamps (stream time
// 0 is `start`), publishing the hand to the server after each frame.
class GloveStream {
 public:
  GloveStream(GlovePoseEstimator& estimator, ViewServer& server, std::atomic<bool>& stop) : estimator_(estimator), server_(server), stop_(stop) {}

  // The server's stream clock is set to the recording's time when it started.
  void recorded(const NewUser& user) {
    const Clock::time_point start = Clock::now();
    const double t0 = row_time(user, 0, 0);
    server_.set_stream_clock(t0 - std::chrono::duration<double>(start - server_.served_from()).count());
    const bool truth = user.data.has_true_angles();
    estimator_.start_calibration();
    for (std::size_t f = 0; f < user.data.frames() && !stop_; ++f) {
      if (f == user.first_session_frame) estimator_.finish_calibration();
      std::this_thread::sleep_until(
          start + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(user.data.timestamps[f] - t0)));
      for (std::size_t r = 0; r < user.data.row_count; ++r)
        (void)estimator_.push_row(static_cast<int>(r), user.data.raw_rows[f * user.data.row_count + r], row_time(user, f, r));
      if (truth)
        for (std::size_t d = 0; d < hand::kDofCount; ++d) truth_[d] = user.data.true_angles[f * hand::kDofCount + d];
      server_.publish(estimator_, user.data.timestamps[f], truth ? &truth_ : nullptr);
    }
  }

  // Lines of `format` from stdin until it ends (or stop): read_glove_lines, publishing after each
  // input, with a summary on stdout.
  void from_stdin(const GloveLineFormat& format, std::optional<double> calibration_seconds, GloveLineCounts& counts) {
    binary_stdin();
    device::LinkCounts link;
    read_glove_stream(
        GloveLineSource{std::cin, "stdin", "glovepose view"}, format, estimator_, calibration_seconds, counts,
        [this](Status) { server_.publish(estimator_, estimator_.pose().timestamp); }, link, &stop_);
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
  GlovePoseEstimator& estimator_;
  ViewServer& server_;
  std::atomic<bool>& stop_;
  hand::Angles truth_{};
};

// What the server and the glove's thread share. The thread holds it too: detached while it waits
// for stdin, it outlives view().
struct ViewShared {
  ViewShared(std::shared_ptr<const PoseModel> model, bool shipped_model, const EstimatorConfig& config)
      : format(*model, shipped_model), estimator(std::move(model), config) {}
  GloveLineFormat format;  // refers to the glove of the estimator's model
  GlovePoseEstimator estimator;
  GloveLineCounts notes;
  std::unique_ptr<ViewServer> server;  // made once the estimator is
  std::string failure;                 // why the glove's stream stopped; written before stream_done
  std::atomic<bool> stop{false}, stream_done{false};
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
  const ViewSource source{o.from_stdin ? "stdin" : (simulated ? "simulated new user" : "replay of " + o.replay),
                          simulated || user->data.has_true_angles()};
  shared->server = std::make_unique<ViewServer>(shared->estimator, o.port, source, shared->notes);
  ViewServer& server = *shared->server;
  server.set_preparing(simulated);  // until the glove's thread has made the simulated user
  std::printf("glovepose view: http://127.0.0.1:%d/\n", server.port());  // at once: the simulated user is made on the glove's thread
  std::fflush(stdout);
  const Clock::time_point start = server.served_from();
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
      GloveStream stream(shared->estimator, *shared->server, shared->stop);
      if (from_stdin) {
        stream.from_stdin(shared->format, calibration_seconds, shared->notes);
      } else {
        if (simulated) {
          *user = simulate_new_user(seed, 10.0, shared->estimator.model());
          shared->server->set_preparing(false);
        }
        stream.recorded(*user);
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
  server.serve_until(finished);
  server.stop();
  shared->stop = true;  // the glove's thread stops at its next frame
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
