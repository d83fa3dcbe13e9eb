// A made-up device that is not a glove, for docs/own_glove.md's walk-through "A device that is not
// a glove": examples/wearable_device.glove.json's 16 channels at 30 Hz, every one an extra input,
// whose readings drift (sim/wearable_device.hpp states how). It writes what such a device's maker
// has: one CSV take per session of one person with the reference angles beside the channels (all
// 25 DoFs, radians), the list of takes for `glovepose import --takes`, and the second session's
// readings alone, as the device streams them live (`glovepose predict --raw`, `view --stdin`).
// Nothing is copied from anywhere; a fixed seed makes the files the same on every run.
//
// usage: example_device OUTDIR [MINUTES]   (each session's length; default 2)
#include <glovepose/hand/dofs.hpp>
#include <glovepose/io/atomic_file.hpp>
#include <glovepose/sim/wearable_device.hpp>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <iostream>
#include <string>

using namespace glovepose;

namespace {

// Frames [begin, end) of `data`: time, the channels and, with `labels`, the 25 angles.
void write_take(const io::Dataset& data, std::size_t begin, std::size_t end, bool labels, const std::filesystem::path& path) {
  io::AtomicFile file(path.string(), "take");
  std::ostream& out = file.stream();
  out << "timestamp";
  char name[32];
  for (std::size_t c = 0; c < data.cell_count; ++c) {
    std::snprintf(name, sizeof name, "channel_%02zu", c);
    out << "," << name;
  }
  if (labels)
    for (const hand::Dof& dof : hand::kDofs) out << "," << dof.name;
  out << "\n";
  char number[32];
  for (std::size_t i = begin; i < end; ++i) {
    std::snprintf(number, sizeof number, "%.6f", data.timestamps[i] - data.timestamps[begin]);
    out << number;
    for (std::size_t c = 0; c < data.cell_count; ++c) {
      // %.9g: the float32 reading exactly, so import and a live stream read the same value.
      std::snprintf(number, sizeof number, "%.9g", static_cast<double>(data.cells[i * data.cell_count + c]));
      out << "," << number;
    }
    for (std::size_t d = 0; labels && d < hand::kDofCount; ++d) {
      std::snprintf(number, sizeof number, "%.7f", static_cast<double>(data.angles[i * hand::kDofCount + d]));
      out << "," << number;
    }
    out << "\n";
  }
  file.commit();
}

}  // namespace

int main(int argc, char** argv) {
  char* end = nullptr;
  const double minutes = argc == 3 ? std::strtod(argv[2], &end) : 2.0;
  if (argc < 2 || argc > 3 || (argc == 3 && (*end != '\0' || !(minutes >= 0.1 && minutes <= 60.0)))) {
    std::cerr << "usage: example_device OUTDIR [MINUTES]   (each of the two sessions' length, 0.1 to 60; default 2)\n";
    return 2;
  }
  try {
    const std::filesystem::path out = argv[1];
    std::filesystem::create_directories(out);
    // A drift of 0.05 channel units per square-root second: over a 2-minute session a channel wanders
    // by about half its motion's span.
    const io::Dataset data = sim::drifting_wearable_sessions(0.05, 2026, minutes);
    io::AtomicFile takes((out / "takes.csv").string(), "take list");
    takes.stream() << "file,subject,session,kind\n";
    for (std::size_t begin = 0; begin < data.frames();) {
      std::size_t end_frame = begin + 1;
      while (end_frame < data.frames() && data.session[end_frame] == data.session[begin]) ++end_frame;
      const std::string name = "session" + std::to_string(data.session[begin]);
      write_take(data, begin, end_frame, true, out / (name + ".csv"));
      takes.stream() << name << ".csv,0," << data.session[begin] << ",recording\n";
      if (end_frame == data.frames()) write_take(data, begin, end_frame, false, out / (name + "_live.csv"));
      begin = end_frame;
    }
    takes.commit();
    std::printf("wrote %s: device wearable-16 (16 drifting channels at 30 Hz), 2 sessions of %zu frames with all 25 DoFs, takes.csv, "
                "session1_live.csv (its readings alone)\n",
                out.string().c_str(), data.frames() / 2);
    return 0;
  } catch (const Error& e) {
    std::cerr << "example_device: " << e.what() << "\n";
    return 1;
  }
}
