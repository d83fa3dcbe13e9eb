// glovepose simulate: simulates the paper's capture protocol (defaults: 10 subjects x 5 sessions x
// 5 minutes, the glove kept on for 3, a 30 s calibration sequence before each session, 2 sessions
// with a second glove) and writes one dataset file, streams it as a device would (--stream), or
// prints the realism report.
#include <glovepose/grid/glove_description.hpp>
#include <glovepose/sim/corpus_dataset.hpp>
#include <glovepose/sim/report.hpp>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <iostream>
#include <memory>
#include <string>

#include "commands.hpp"
#include "device_stream.hpp"

namespace glovepose::cli {
namespace {

struct SimulateOptions {
  sim::CorpusConfig config;
  std::string out, csv, sequence_file, world = sim::default_world().name, stream, payload = "measurements";
  DeviceStreamSettings device;
  std::vector<std::string> without, settings;
  std::vector<double> tear;  // --tear: trace, cells kept, seconds
  double removal_seconds = -1.0;  // --removal-seconds: < 0 none
  bool report = false, print_sequence = false;
};

int simulate(SimulateOptions o) {
  sim::CorpusConfig& config = o.config;
  if (config.intra_sessions > config.sessions) config.intra_sessions = config.sessions;
  config.world = sim::world_named(o.world);
  for (const std::string& effect : o.without) config.world = sim::without(config.world, sim::effect_named(effect));
  for (const std::string& setting : o.settings) config.world = sim::with(config.world, setting);
  if (o.print_sequence) {
    std::cout << sim::guided_calibration_sequence(sim::pose_gallery()).to_json();
    return 0;
  }
  if (!o.report && o.out.empty() && o.stream.empty())
    throw CLI::RequiredError("--out FILE (or --stream TARGET, --report, or --print-calibration-sequence)");
  o.device.payload = o.payload == "rows" ? StreamPayload::Rows : o.payload == "cells" ? StreamPayload::Cells : StreamPayload::Measurements;
  if (!o.stream.empty() && o.device.payload != StreamPayload::Cells) config.recording.raw_rows = true;
  if (!o.tear.empty()) {
    const auto whole = [](double v) { return std::isfinite(v) && v >= 0.0 && v == std::floor(v); };
    if (o.tear.size() != 3 || !whole(o.tear[0]) || !whole(o.tear[1]) || !(o.tear[2] >= 0.0 && std::isfinite(o.tear[2])))
      throw Error("--tear: expected TRACE KEPT SECONDS (a trace 0-26: bottom 0-14, top 15-26; the cells it keeps from the wrist; "
                  "seconds into each session), three numbers");
    const sim::TraceTear tear{static_cast<int>(o.tear[0]), static_cast<int>(o.tear[1]), o.tear[2]};
    config.recording.tears = {tear};
    const sensor::TraceLayout layout = sensor::TraceLayout::glauser2019();
    const std::vector<int> floating = sim::cells_beyond_tear(layout, sim::glauser2019_sites(), tear);
    std::string cells;
    for (int c : floating) cells += (cells.empty() ? "" : ", ") + std::to_string(c);
    const int trace = tear.trace;
    std::fprintf(stderr, "--tear: %s trace %d torn %g s into each session, %d cell(s) kept (%zu float: cells %s)\n",
                 trace < layout.bottom_traces() ? "bottom" : "top", trace < layout.bottom_traces() ? trace : trace - layout.bottom_traces(),
                 o.tear[2], tear.cells_kept, floating.size(), cells.empty() ? "none" : cells.c_str());
  }
  if (o.removal_seconds >= 0.0) {
    config.removal.emplace();
    config.removal->off_seconds = o.removal_seconds;
  }
  if (!o.sequence_file.empty()) {
    config.guided_calibration = calibration::Sequence::read(o.sequence_file);
    config.calibration_seconds = config.guided_calibration->total_seconds();
  }
  const auto start = std::chrono::steady_clock::now();
  const auto seconds = [&] { return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count(); };
  if (o.report) {
    std::cout << sim::format_report(sim::make_report(config));
    std::printf("(%.1f s)\n", seconds());
    return 0;
  }
  const std::vector<sim::SessionRecording> corpus = sim::simulate_corpus(config);
  const double simulated = seconds();
  const io::Dataset data = sim::to_dataset(corpus, config);
  if (!o.stream.empty()) {
    const grid::GloveDescription glove = grid::GloveDescription::glauser2019();
    o.device.glove_id = glove.id();
    o.device.cells = glove.cell_count();
    FrameSink sink(o.stream);
    std::fprintf(stderr, "glovepose simulate: %zu frames (%.1f s of readings) simulated in %.1f s; streaming to %s\n", data.frames(),
                 static_cast<double>(data.frames()) / config.recording.cycle_rate, simulated, o.stream.c_str());
    const DeviceStreamCounts sent = stream_dataset(data, o.device, sink);
    std::fprintf(stderr, "glovepose simulate: streamed %llu frames, %llu bytes, in %.1f s\n", static_cast<unsigned long long>(sent.frames),
                 static_cast<unsigned long long>(sent.bytes), seconds() - simulated);
    if (o.out.empty()) return 0;
  }
  data.write(o.out);
  if (!o.csv.empty()) data.write_csv(o.csv);
  std::printf("wrote %s: %zu frames (%d subjects, %zu recordings, %s raw rows); simulated in %.1f s, %.1f s in all\n", o.out.c_str(),
              data.frames(), config.subjects, corpus.size(), config.recording.raw_rows ? "with" : "without", simulated, seconds());
  return 0;
}

}  // namespace

Command add_simulate(CLI::App& tool) {
  auto o = std::make_shared<SimulateOptions>();
  sim::CorpusConfig& config = o->config;
  CLI::App* command = tool.add_subcommand(
      "simulate",
      "Simulates the paper's capture protocol and writes one dataset file (--out), or prints the realism report (--report) "
      "or the built-in guided calibration sequence as JSON (--print-calibration-sequence).");
  add_number(*command, "--seed", "S", config.seed, "everything simulated derives from it (default 1)");
  add_number(*command, "--subjects", "N", config.subjects, "people (default 10)")->check(at_least(1));
  add_number(*command, "--sessions", "K", config.sessions,
             "sessions per person with the first glove, the first 3 without taking it off (default 5)")
      ->check(at_least(1));
  add_number(*command, "--minutes", "M", config.minutes, "per session (default 5)")->check(above(0.0, 600.0));
  add_number(*command, "--gloves", "G", config.gloves, "gloves; each further one records 2 sessions per person (default 2)")
      ->check(CLI::Range(1, 16));
  CLI::Option* seconds = add_number(*command, "--calibration-seconds", "T", config.calibration_seconds,
                                    "calibration sequence before every session, visiting the extreme poses (default 30; 0: none)")
                             ->check(at_least(0.0));
  command->add_option("--calibration-sequence", o->sequence_file, "a guided calibration sequence (JSON) every calibration follows instead")
      ->check(existing_file())
      ->type_name("FILE")
      ->excludes(seconds);
  command->add_flag("--raw-rows", config.recording.raw_rows,
                    "also write every raw row reading (for replaying rows: eval --replay-rows, view --replay)");
  add_number(*command, "--mean-window", "N", config.recording.readout.mean_window, "readings per row averaged before solving (default 5)")
      ->check(at_least(1));
  add_number(*command, "--threads", "T", config.threads, "threads (default 0: all cores)");
  command->add_option("--tear", o->tear,
                      "a trace that tears in every session: TRACE KEPT SECONDS (trace 0-26: the bottom traces 0-14, then the top 15-26; "
                      "the cells it keeps connected, nearest the wrist first; seconds into the session): the cells beyond the break "
                      "float (docs/simulator.md, \"Readout\")")
      ->expected(3)
      ->type_name("TRACE KEPT SECONDS");
  add_number(*command, "--removal-seconds", "S", o->removal_seconds,
             "record the glove taken off and put on again before each later donning, off the hand for S seconds (kind 2 frames "
             "without a pose; docs/simulator.md, \"Taking the glove off\"; default: not recorded)")
      ->check(bounded(0.0, false, 3600.0));
  std::string worlds;
  for (const sim::World& w : sim::worlds()) worlds += std::string(worlds.empty() ? "" : "; ") + w.name + ": " + w.summary;
  std::vector<std::string> names;
  for (const sim::World& w : sim::worlds()) names.emplace_back(w.name);
  command->add_option("--world", o->world, "the simulated world (default " + o->world + "; " + worlds + ")")
      ->check(CLI::IsMember(names))
      ->type_name("NAME");
  std::string effects;
  for (const char* e : sim::kEffectNames) effects += std::string(effects.empty() ? "" : ", ") + e;
  command->add_option("--without", o->without, "switch these effects of the world back to the clean world's, for ablations (" + effects + ")")
      ->check(CLI::IsMember(std::vector<std::string>(sim::kEffectNames.begin(), sim::kEffectNames.end())))
      ->delimiter(',')
      ->type_name("EFFECT[,EFFECT...]");
  std::string parameters;
  for (const sim::WorldParameter& p : sim::world_parameters()) parameters += std::string(parameters.empty() ? "" : ", ") + p.name;
  command->add_option("--set", o->settings, "set parameters of the world's effects, after --without, for fitting a world (" + parameters + ")")
      ->delimiter(',')
      ->type_name("NAME=VALUE[,NAME=VALUE...]");
  CLI::Option* out = command->add_option("--out", o->out, "the dataset file written")->type_name("FILE");
  command->add_option("--csv", o->csv, "also write the frames as CSV text")->type_name("FILE")->needs(out);
  CLI::Option* stream =
      command
          ->add_option("--stream", o->stream,
                       "stream the readings as a glove would, in the wire protocol (docs/wire_protocol.md), to TARGET: '-' for stdout, a "
                       "file, a named pipe, a pty or a serial port, or udp:HOST:PORT (a frame per datagram, a Hello every second)")
          ->type_name("TARGET");
  command
      ->add_option("--stream-payload", o->payload,
                   "--stream: what each frame holds: 'measurements' (a cycle's rows, default), 'rows' (the same rows, each with its own "
                   "time) or 'cells' (the solved cells)")
      ->check(CLI::IsMember({"measurements", "rows", "cells"}).description(""))
      ->type_name("KIND")
      ->needs(stream);
  add_number(*command, "--speed", "X", o->device.speed, "--stream: multiples of real time (default 1; 0: as fast as the target reads)")
      ->check(CLI::Range(0.0, 1000.0))
      ->needs(stream);
  add_number(*command, "--serial", "N", o->device.serial, "--stream: the device's serial number in its Hello (default 1)")->needs(stream);
  CLI::Option* report =
      command->add_flag("--report", o->report, "print the realism report of the simulated people instead")->excludes(out)->excludes(stream);
  command->add_flag("--print-calibration-sequence", o->print_sequence, "print the built-in guided calibration sequence as JSON and stop")
      ->excludes(out)
      ->excludes(report);
  return {command, [o] { return simulate(*o); }};
}

}  // namespace glovepose::cli
