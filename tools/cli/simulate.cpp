// glovepose simulate --seed S --subjects N --sessions K --minutes M [--gloves G] --out FILE
//                    [--raw-rows] [--mean-window N] [--calibration-seconds T | --calibration-sequence FILE] [--threads T] [--csv FILE]
// glovepose simulate --print-calibration-sequence
// glovepose simulate --report [--seed S] [--subjects N] [--sessions K] [--minutes M]
//   Simulates the paper's capture protocol (defaults: 10 subjects x 5 sessions x 5 minutes, the
//   glove kept on for 3, a 30 s calibration sequence before each session, 2 sessions with a second
//   glove) and writes one dataset file, or prints the realism report.
#include <glovepose/sim/corpus_dataset.hpp>
#include <glovepose/sim/report.hpp>

#include <charconv>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <iostream>
#include <string>

#include "commands.hpp"

namespace glovepose::cli {
namespace {

// `problem` empty: the usage was asked for (--help).
[[noreturn]] void usage(const std::string& problem) {
  exit_with_usage("simulate", problem,
                  "usage: glovepose simulate [--seed S] [--subjects N] [--sessions K] [--minutes M] [--gloves G]\n"
                  "                          [--calibration-seconds T | --calibration-sequence FILE] [--raw-rows] [--mean-window N] [--threads T]\n"
                  "                          --out FILE [--csv FILE]\n"
                  "       glovepose simulate --print-calibration-sequence   (the built-in guided sequence as JSON)\n"
                  "       glovepose simulate --report [--seed S] [--subjects N] [--sessions K] [--minutes M] [--threads T]\n");
}

template <typename T>
T number(const std::string& option, const std::string& text) {
  T v{};
  const auto r = std::from_chars(text.data(), text.data() + text.size(), v);
  if (text.empty() || r.ec != std::errc() || r.ptr != text.data() + text.size()) usage(option + " '" + text + "' is not a number");
  return v;
}

}  // namespace

int simulate(int argc, char** argv) {
  sim::CorpusConfig config;
  std::string out, csv;
  std::string sequence_file;
  bool report = false, print_sequence = false;
  for (int i = 2; i < argc; ++i) {
    const std::string a = argv[i];
    const auto value = [&]() -> std::string {
      if (i + 1 >= argc) usage(a + " needs a value");
      return argv[++i];
    };
    if (a == "--seed") config.seed = number<std::uint64_t>(a, value());
    else if (a == "--subjects") config.subjects = number<int>(a, value());
    else if (a == "--sessions") config.sessions = number<int>(a, value());
    else if (a == "--minutes") config.minutes = number<double>(a, value());
    else if (a == "--gloves") config.gloves = number<int>(a, value());
    else if (a == "--calibration-seconds") config.calibration_seconds = number<double>(a, value());
    else if (a == "--calibration-sequence") sequence_file = value();
    else if (a == "--print-calibration-sequence") print_sequence = true;
    else if (a == "--threads") config.threads = number<int>(a, value());
    else if (a == "--raw-rows") config.recording.raw_rows = true;
    else if (a == "--mean-window") config.recording.readout.mean_window = number<int>(a, value());
    else if (a == "--out") out = value();
    else if (a == "--csv") csv = value();
    else if (a == "--report") report = true;
    else if (asks_for_help(a)) usage("");
    else usage("unknown option " + a);
  }
  if (config.intra_sessions > config.sessions) config.intra_sessions = config.sessions;
  if (print_sequence) {
    std::cout << sim::guided_calibration_sequence(sim::pose_gallery()).to_json();
    return 0;
  }
  if (!report && out.empty()) usage("--out FILE is required (or --report)");
  try {
    if (!sequence_file.empty()) {
      config.guided_calibration = calibration::Sequence::read(sequence_file);
      config.calibration_seconds = config.guided_calibration->total_seconds();
    }
    const auto start = std::chrono::steady_clock::now();
    const auto seconds = [&] { return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count(); };
    if (report) {
      std::cout << sim::format_report(sim::make_report(config));
      std::printf("(%.1f s)\n", seconds());
      return 0;
    }
    const std::vector<sim::SessionRecording> corpus = sim::simulate_corpus(config);
    const double simulated = seconds();
    const train::Dataset data = sim::to_dataset(corpus, config);
    data.write(out);
    if (!csv.empty()) data.write_csv(csv);
    std::printf("wrote %s: %zu frames (%d subjects, %zu recordings, %s raw rows); simulated in %.1f s, %.1f s in all\n", out.c_str(),
                data.frames(), config.subjects, corpus.size(), config.recording.raw_rows ? "with" : "without", simulated, seconds());
    return 0;
  } catch (const Error& e) {
    std::cerr << "glovepose simulate: " << e.what() << "\n";
    return 2;
  }
}

}  // namespace glovepose::cli
