// A made-up glove for the "Your own glove" walk-through: 20 resistive-like stretch sensors, read at
// 20 Hz, with reference angles for 21 of the 25 DoFs (no finger twists), written as a glove maker's
// files: a glove description, one calibration take and one recording take (CSV) per person, and the
// list of takes for `glovepose import --takes`.
//
// With --keypoints LAYOUT the takes carry no angles: each has a hand tracker's keypoint file beside
// it instead (MediaPipe's 21 landmarks or OpenXR's 26 joints, metres, 30 Hz, 5 mm 3D RMS noise, on
// the tracker's own clock: offset from the glove's by up to 2 s), listed in takes.csv's keypoints
// column. Each person's hand is the template scaled by 0.9-1.1; the hand turns in front of the
// camera (sim/keypoint_tracker.hpp). The keypoints show the true angles (the corpus's true_angles
// when it has them).
//
// The people are a simulated corpus (`glovepose simulate`): each sensor reads a strip over two cells
// of the built-in 44-cell glove, as ohms with a DC offset (offset + gain x (main cell + 0.3 x a
// neighbour) + noise), every third 60 Hz frame. Nothing is copied from anywhere; a fixed seed makes
// the files the same on every run.
//
// usage: example_glove CORPUS.safetensors OUTDIR [--keypoints mediapipe|openxr]
#include <glovepose/grid/glove_description.hpp>
#include <glovepose/hand/dofs.hpp>
#include <glovepose/hand/keypoints.hpp>
#include <glovepose/io/dataset.hpp>
#include <glovepose/sim/keypoint_tracker.hpp>

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <random>
#include <string>
#include <vector>

using namespace glovepose;

namespace {

struct Sensor {
  std::string name;
  int main_cell, neighbour;
  double offset, gain;
};

// 20 sensors at 20 distinct slots of the built-in glove: its first 15 cells along the fingers and
// its first 5 across, each named after where it sits.
std::vector<Sensor> make_sensors(const grid::GridMap& paper, std::mt19937& rng) {
  std::uniform_real_distribution<double> offset(80.0, 160.0), gain(1.5, 4.0);
  std::uniform_int_distribution<int> any_cell(0, paper.cell_count() - 1);
  std::vector<Sensor> sensors;
  for (int channel : {0, 1})
    for (int c = 0; c < paper.cell_count() && sensors.size() < (channel == 0 ? 15u : 20u); ++c) {
      const grid::Slot& s = paper.cell_slots()[static_cast<std::size_t>(c)];
      if (s.channel != channel) continue;
      int neighbour = any_cell(rng);
      while (neighbour == c) neighbour = any_cell(rng);
      sensors.push_back({std::string(channel == 0 ? "along" : "across") + "_r" + std::to_string(s.row) + "c" + std::to_string(s.col), c,
                         neighbour, offset(rng), gain(rng)});
    }
  return sensors;
}

}  // namespace

// The tracker's keypoint file of frames [begin, end) of the corpus: tracker time = glove time - offset.
void write_keypoints(const io::Dataset& corpus, std::size_t begin, std::size_t end, hand::KeypointLayout layout, double hand_scale,
                     double offset, std::uint64_t seed, const std::filesystem::path& path) {
  hand::HandModel model = hand::HandModel::reference();
  for (std::size_t p = 1; p < hand::kPhalanxCount; ++p) model.rest[p].translation() *= hand_scale;
  for (double& tip : model.tip_length) tip *= hand_scale;
  const std::vector<float>& truth = corpus.true_angles.empty() ? corpus.angles : corpus.true_angles;
  const double t0 = corpus.timestamps[begin];
  // The true pose between the corpus's frames, linearly.
  const auto pose_at = [&](double t) {
    std::size_t i = begin;
    while (i + 2 < end && corpus.timestamps[i + 1] - t0 < t) ++i;
    const double w = std::clamp((t - (corpus.timestamps[i] - t0)) / (corpus.timestamps[i + 1] - corpus.timestamps[i]), 0.0, 1.0);
    hand::Angles q{};
    for (std::size_t d = 0; d < hand::kDofCount; ++d)
      q[d] = (1.0 - w) * truth[i * hand::kDofCount + d] + w * truth[(i + 1) * hand::kDofCount + d];
    return q;
  };
  sim::KeypointTrackerConfig config;
  config.layout = layout;
  config.rate_hz = 30.0;
  config.noise_mm = 5.0;
  config.offset_seconds = offset;
  const train::KeypointTrack track =
      sim::track_keypoints(hand::Kinematics(model), pose_at, 0.0, corpus.timestamps[end - 1] - t0, config, seed);
  std::ofstream file(path);
  file << "timestamp";
  const std::size_t count = hand::keypoint_count(layout);
  for (std::size_t k = 0; k < count; ++k)
    for (const char* axis : {"_x", "_y", "_z"}) file << "," << hand::keypoint_name(layout, k) << axis;
  file << "\n";
  char number[32];
  for (std::size_t f = 0; f < track.times.size(); ++f) {
    std::snprintf(number, sizeof number, "%.4f", track.times[f]);
    file << number;
    for (std::size_t k = 0; k < count; ++k)
      for (int a = 0; a < 3; ++a) {
        std::snprintf(number, sizeof number, "%.5f", track.points[f * count + k][a] * 1e-3);  // metres
        file << "," << number;
      }
    file << "\n";
  }
}

int main(int argc, char** argv) {
  const bool keypoints = argc == 5 && std::string(argv[3]) == "--keypoints";
  if (argc != 3 && !(keypoints && (std::string(argv[4]) == "mediapipe" || std::string(argv[4]) == "openxr"))) {
    std::cerr << "usage: example_glove CORPUS.safetensors OUTDIR [--keypoints mediapipe|openxr]   (CORPUS: glovepose simulate --out CORPUS "
                 "...)\n";
    return 2;
  }
  const hand::KeypointLayout layout = keypoints && std::string(argv[4]) == "openxr" ? hand::KeypointLayout::OpenXr : hand::KeypointLayout::MediaPipe;
  try {
    const io::Dataset corpus = io::Dataset::read(argv[1]);
    if (!corpus.has_angles() || corpus.cell_count != 44) throw Error("the corpus needs angles and the 44 cells of the built-in glove");
    const std::filesystem::path out = argv[2];
    std::filesystem::create_directories(out);
    std::mt19937 rng(2026);
    const grid::GridMap paper = grid::GridMap::glauser2019();
    const std::vector<Sensor> sensors = make_sensors(paper, rng);

    std::vector<std::string> names;
    std::vector<grid::Slot> slots;
    for (const Sensor& s : sensors) {
      names.push_back(s.name);
      slots.push_back(paper.cell_slots()[static_cast<std::size_t>(s.main_cell)]);
    }
    // Read at 20 Hz; resistive sensors on a DC offset (80-160 ohm) stretch by a few percent of it, so
    // the description calls a sensor flat only below 0.1% (the default 1% suits capacitance).
    grid::GloveSettings settings;
    settings.rate_hz = 20.0;
    settings.calibration.flat_relative_range = 0.001;
    grid::GloveDescription("example-20", names, grid::GridMap(slots, paper.dof_slots()), settings)
        .write((out / "example-20.json").string());

    std::vector<std::size_t> labelled;  // no finger twists: the reference measures 21 DoFs
    for (std::size_t d = 0; d < hand::kDofCount; ++d)
      if (std::string(hand::kDofs[d].name).find("twist") == std::string::npos || d == hand::dof_from_name("thumb_base_twist"))
        labelled.push_back(d);

    std::normal_distribution<double> noise(0.0, 0.05);
    std::ofstream takes(out / "takes.csv");
    takes << (keypoints ? "file,subject,session,kind,keypoints\n" : "file,subject,session,kind\n");
    std::uniform_real_distribution<double> hand_scale(0.9, 1.1), offset(-2.0, 2.0);
    std::vector<double> scale_of;  // each person's hand size
    std::size_t written = 0;
    for (std::size_t begin = 0; begin < corpus.frames();) {
      std::size_t end = begin + 1;
      while (end < corpus.frames() && corpus.subject[end] == corpus.subject[begin] && corpus.session[end] == corpus.session[begin] &&
             corpus.glove[end] == corpus.glove[begin] && corpus.kind[end] == corpus.kind[begin])
        ++end;
      const bool calibration = corpus.kind[begin] == io::kKindCalibration;
      const std::string file = "person" + std::to_string(corpus.subject[begin]) + "_session" + std::to_string(corpus.session[begin]) +
                               (calibration ? "_calibration.csv" : "_recording.csv");
      takes << file << "," << corpus.subject[begin] << "," << corpus.session[begin] << "," << (calibration ? "calibration" : "recording");
      if (keypoints) {
        const auto subject = static_cast<std::size_t>(corpus.subject[begin]);
        while (scale_of.size() <= subject) scale_of.push_back(hand_scale(rng));
        const std::string keypoint_file = file.substr(0, file.size() - 4) + "_keypoints.csv";
        write_keypoints(corpus, begin, end, layout, scale_of[subject], offset(rng), rng(), out / keypoint_file);
        takes << "," << keypoint_file;
      }
      takes << "\n";
      std::ofstream take(out / file);
      take << "timestamp_ms";
      for (const Sensor& s : sensors) take << "," << s.name;
      if (!keypoints)
        for (std::size_t d : labelled) take << "," << hand::kDofs[d].name;
      take << "\n";
      char number[32];
      for (std::size_t i = begin; i < end; i += 3) {  // 60 Hz -> 20 Hz
        std::snprintf(number, sizeof number, "%.1f", 1000.0 * (corpus.timestamps[i] - corpus.timestamps[begin]));
        take << number;
        for (const Sensor& s : sensors) {
          const double stretch = corpus.cells[i * 44 + static_cast<std::size_t>(s.main_cell)] +
                                 0.3 * corpus.cells[i * 44 + static_cast<std::size_t>(s.neighbour)];
          std::snprintf(number, sizeof number, "%.3f", s.offset + s.gain * stretch + noise(rng));
          take << "," << number;
        }
        for (std::size_t d : labelled) {
          if (keypoints) break;
          std::snprintf(number, sizeof number, "%.6f", static_cast<double>(corpus.angles[i * hand::kDofCount + d]));
          take << "," << number;
        }
        take << "\n";
      }
      ++written;
      begin = end;
    }
    std::printf("wrote %s: glove example-20 (20 sensors), %zu takes of %zu frames at 60 Hz read at 20 Hz, %s, takes.csv\n",
                out.string().c_str(), written, corpus.frames(),
                keypoints ? (std::string(hand::to_string(layout)) + " keypoint files (30 Hz, the tracker's clock)").c_str() : "21 labelled DoFs");
    return 0;
  } catch (const Error& e) {
    std::cerr << "example_glove: " << e.what() << "\n";
    return 1;
  }
}
