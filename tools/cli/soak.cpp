// glovepose soak: the soak run (tools/soak/soak.hpp): N estimators on threads sharing one loaded
//   model, each calibrating on the fly (30 s sequence) and then streaming M minutes of simulated
//   60 Hz rows (X minutes of simulated motion, looped forward and backward with a clock that keeps
//   running) with random faults of every kind
//   (sim/faults.hpp). Prints frames, faults by kind, recoveries, memory and allocations; exits 0
//   when every check held, 1 when one failed (or the run could not start), 2 on bad options.

#ifndef _WIN32
#  include <dlfcn.h>
#endif

#include <cstdio>
#include <iostream>
#include <memory>
#include <string>

// The test suite's allocation counter (global operator new), linked into this tool so the soak
// can prove the per-frame path allocates nothing here too.
#include "../soak/soak.hpp"
#include "commands.hpp"
#include "session_options.hpp"

namespace glovepose::cli {
namespace {

// The calibration sequence each estimator starts with: the simulator's default length (the demo's).
constexpr double kCalibrationSeconds = 30.0;

struct SoakOptions {
  sim::SoakConfig soak;
  double source_minutes = 3.0;
  std::string model;  // empty: the shipped FCN
};

int soak(SoakOptions o) {
  // The installed tool does not replace operator new; the allocation counter of the test suite
  // can be preloaded (LD_PRELOAD=.../libglovepose_alloc_counter.so), and is then used.
  // (Linux: Windows has no preloading; there the report says allocations were not counted.)
#ifndef _WIN32
  if (void* counter = dlsym(RTLD_DEFAULT, "glovepose_allocation_count"))
    o.soak.allocation_count = reinterpret_cast<std::size_t (*)()>(counter);
#endif
  const auto model = PoseModel::load(o.model.empty() ? shipped_model_path(kShippedModel) : o.model);
  std::cout << "simulating " << o.source_minutes << " min of motion to loop ..." << std::endl;
  // The simulated user is the fault seed's, so one seed reproduces the whole run.
  const io::Dataset source = sim::simulate_soak_source(o.soak.seed, o.source_minutes, kCalibrationSeconds);
  std::cout << "streaming " << o.soak.estimators << " x " << o.soak.stream_minutes << " min ..." << std::endl;
  const sim::SoakReport report = sim::run_soak(model, source, o.soak);
  std::cout << "command: glovepose soak --minutes " << o.soak.stream_minutes << " --estimators " << o.soak.estimators << " --seed "
            << o.soak.seed << " --source-minutes " << o.source_minutes << "\n";
  report.print(std::cout);
  return report.passed() ? 0 : 1;
}

}  // namespace

Command add_soak(CLI::App& tool) {
  auto o = std::make_shared<SoakOptions>();
  o->soak.stream_minutes = 30.0;
  CLI::App* command = tool.add_subcommand(
      "soak",
      "Estimators on threads sharing one model stream simulated 60 Hz rows with random faults of every kind, after calibrating on "
      "the fly; prints frames, faults by kind, recoveries, memory and allocations. Exits 0 when every check held, 1 when one failed.");
  add_number(*command, "--minutes", "M", o->soak.stream_minutes, "stream per estimator, minutes of 60 Hz rows (default 30)")
      ->check(above(0.0));
  add_number(*command, "--estimators", "N", o->soak.estimators, "estimators on threads sharing the model (default 3)")
      ->check(CLI::Range(1, 64));
  add_number(*command, "--seed", "S", o->soak.seed, "seed of the faults and the simulated user (default 1)");
  add_number(*command, "--source-minutes", "X", o->source_minutes, "simulated motion looped, minutes (default 3; ~6 s of CPU per minute)")
      ->check(CLI::Range(0.1, 600.0));
  add_model_file(*command, o->model, std::string("weights (default: the shipped ") + kShippedModel + ")");
  return {command, [o] { return soak(*o); }};
}

}  // namespace glovepose::cli
