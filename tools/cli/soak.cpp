// glovepose soak [--minutes M] [--estimators N] [--seed S] [--source-minutes X] [--model FILE]
//   The soak run (tools/soak/soak.hpp): N estimators on threads sharing one loaded
//   model, each calibrating on the fly (30 s sequence) and then streaming M minutes of simulated
//   60 Hz rows (X minutes of simulated motion, looped forward and backward with a clock that keeps
//   running) with random faults of every kind
//   (sim/faults.hpp). Prints frames, faults by kind, recoveries, memory and allocations; exits 0
//   when every check held, 1 when one failed, 2 on bad options.

#include <dlfcn.h>

#include <cstdio>
#include <cstdlib>
#include <iostream>
#include <string>

// The test suite's allocation counter (global operator new), linked into this tool so the soak
// can prove the per-frame path allocates nothing here too.
#include "../soak/soak.hpp"
#include "commands.hpp"

namespace glovepose::cli {
namespace {

// The calibration sequence each estimator starts with: the simulator's default length (the demo's).
constexpr double kCalibrationSeconds = 30.0;

struct SoakOptions {
  sim::SoakConfig soak;
  double source_minutes = 3.0;
  std::string model;  // empty: the shipped FCN
};

// `problem` empty: the usage was asked for (--help).
[[noreturn]] void soak_usage(const std::string& problem) {
  exit_with_usage("soak", problem,
                  "usage: glovepose soak [--minutes M] [--estimators N] [--seed S] [--source-minutes X] [--model FILE]\n"
                  "  --minutes M         stream per estimator, minutes of 60 Hz rows (default 30)\n"
                  "  --estimators N      estimators on threads sharing the model (default 3)\n"
                  "  --seed S            seed of the faults (default 1)\n"
                  "  --source-minutes X  simulated motion looped, minutes (default 3; ~6 s of CPU per minute)\n"
                  "  --model FILE        weights (default: the shipped glovepose_fcn512.safetensors)\n");
}

SoakOptions parse_soak_options(int argc, char** argv) {
  SoakOptions o;
  o.soak.stream_minutes = 30.0;
  for (int i = 2; i < argc; ++i) {
    const std::string a = argv[i];
    const auto value = [&]() -> std::string {
      if (i + 1 >= argc) soak_usage(a + " needs a value");
      return argv[++i];
    };
    if (a == "--minutes") o.soak.stream_minutes = parse_number<double>(a, value());
    else if (a == "--estimators") o.soak.estimators = parse_number<int>(a, value());
    else if (a == "--seed") o.soak.seed = parse_number<std::uint64_t>(a, value());
    else if (a == "--source-minutes") o.source_minutes = parse_number<double>(a, value());
    else if (a == "--model") o.model = value();
    else if (asks_for_help(a)) soak_usage("");
    else soak_usage("unknown option " + a);
  }
  o.soak.validate();
  if (!(o.source_minutes >= 0.1 && o.source_minutes <= 600.0))
    throw Error("--source-minutes " + std::to_string(o.source_minutes) + ", expected 0.1 .. 600 minutes of simulated motion");
  return o;
}

}  // namespace

int soak(int argc, char** argv) {
  try {
    SoakOptions o = parse_soak_options(argc, argv);
    // The installed tool does not replace operator new; the allocation counter of the test suite
    // can be preloaded (LD_PRELOAD=.../libglovepose_alloc_counter.so), and is then used.
    if (void* counter = dlsym(RTLD_DEFAULT, "glovepose_allocation_count"))
      o.soak.allocation_count = reinterpret_cast<std::size_t (*)()>(counter);
    const auto model = PoseModel::load(o.model.empty() ? shipped_model_path("glovepose_fcn512.safetensors") : o.model);
    std::cout << "simulating " << o.source_minutes << " min of motion to loop ..." << std::endl;
    // The simulated user is the fault seed's, so one seed reproduces the whole run.
    const train::Dataset source = sim::simulate_soak_source(o.soak.seed, o.source_minutes, kCalibrationSeconds);
    std::cout << "streaming " << o.soak.estimators << " x " << o.soak.stream_minutes << " min ..." << std::endl;
    const sim::SoakReport report = sim::run_soak(model, source, o.soak);
    std::cout << "command: glovepose soak --minutes " << o.soak.stream_minutes << " --estimators " << o.soak.estimators << " --seed "
              << o.soak.seed << " --source-minutes " << o.source_minutes << "\n";
    report.print(std::cout);
    return report.passed() ? 0 : 1;
  } catch (const Error& e) {
    std::cerr << "glovepose soak: " << e.what() << "\n";
    return 2;
  }
}

}  // namespace glovepose::cli
