// What the contact stage (hand/contact.hpp) could do for the fingertips if its evidence were
// perfect: in every frame that pinches in truth, the stage closes the pair anyway (detection
// switched to "always on"), and the tips' errors are compared with the estimate's and with the part
// of the error no closing can remove, the error of the two tips' midpoint (thumb and finger off
// together: closing moves them toward each other, not toward the truth).
//
//   g++ -std=c++17 -O2 -Iinclude -isystem /usr/include/eigen3 tools/experiments/contact_oracle.cpp -o contact_oracle
//   glovepose eval ... --predictions P.csv     (simulated data: its true angles)
//   contact_oracle P.csv SEED SUBJECTS         (the corpus' seed and subject count: each person's own hand)
//
// Prints per pair and pooled, over the true pinching frames (hand/pinch.hpp's rule on the true
// pose, per recording): the mean tip error (thumb and finger pooled) of the estimate, after the
// always-on stage, and the mean midpoint error; and the thumb-to-finger distance error before and after.
#include <glovepose/hand/contact.hpp>
#include <glovepose/sim/subject.hpp>

#include <array>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

using namespace glovepose;

int main(int argc, char** argv) {
  if (argc != 4) {
    std::fprintf(stderr, "usage: contact_oracle PREDICTIONS.csv SEED SUBJECTS\n");
    return 2;
  }
  std::ifstream in(argv[1]);
  if (!in) {
    std::fprintf(stderr, "contact_oracle: cannot read %s\n", argv[1]);
    return 1;
  }
  const std::vector<sim::Subject> people = sim::make_subjects(std::atoi(argv[3]), std::strtoull(argv[2], nullptr, 10));
  std::string line;
  std::getline(in, line);
  std::vector<std::string> header;
  for (std::stringstream s(line); std::getline(s, line, ',');) header.push_back(line);
  std::size_t pred0 = 0, truth0 = 0;
  for (std::size_t i = 0; i < header.size(); ++i) {
    if (header[i] == std::string("pred_") + hand::kDofs[0].name) pred0 = i;
    if (header[i] == std::string("truth_") + hand::kDofs[0].name) truth0 = i;
  }
  if (pred0 == 0 || truth0 == 0) {
    std::fprintf(stderr, "contact_oracle: %s has no pred_ and truth_ columns (eval --predictions of simulated data)\n", argv[1]);
    return 1;
  }
  hand::ContactConfig always;
  always.detection.threshold_mm = always.detection.release_mm = 1e9;  // the evidence says "contact" everywhere
  always.detection.far_mm = 2e9;
  struct Sums {
    std::size_t frames = 0;
    double tip = 0, tip_oracle = 0, midpoint = 0, distance = 0, distance_oracle = 0;
  };
  std::array<Sums, hand::kPinchPairCount + 1> sums{};
  int last_subject = -1, last_session = -1;
  double last_time = 0;
  hand::PinchTracker truth_pinch;
  std::vector<double> row;
  while (std::getline(in, line)) {
    row.clear();
    for (std::stringstream s(line); std::getline(s, line, ',');) row.push_back(std::atof(line.c_str()));
    const int subject = static_cast<int>(row[2]), session = static_cast<int>(row[3]);
    const double time = row[1];
    if (subject != last_subject || session != last_session || !(time > last_time)) truth_pinch.reset();
    last_subject = subject, last_session = session, last_time = time;
    hand::Angles predicted{}, truth{};
    for (std::size_t d = 0; d < hand::kDofCount; ++d) predicted[d] = row[pred0 + d], truth[d] = row[truth0 + d];
    const hand::Kinematics fk(people.at(static_cast<std::size_t>(subject)).hand_model());
    const hand::PinchState state = truth_pinch.update(fk, truth);
    // The pair: the closest of those pinching in truth.
    const hand::PinchDistances true_d = hand::pinch_distances(fk, truth);
    int pair = -1;
    for (std::size_t k = 0; k < hand::kPinchPairCount; ++k)
      if (state.pinching[k] && (pair < 0 || true_d[k] < true_d[static_cast<std::size_t>(pair)])) pair = static_cast<int>(k);
    if (pair < 0) continue;
    const auto k = static_cast<std::size_t>(pair), f = k + 1;
    const auto true_tips = hand::fingertip_positions(fk, truth), pred_tips = hand::fingertip_positions(fk, predicted);
    // The oracle stage: told "contact", it closes the closest predicted pair; scored on the true pair.
    hand::ContactStage stage(fk, hand::JointLimits{}, always);
    hand::Angles adjusted = predicted;
    hand::Skeleton skeleton;
    fk.pose(adjusted, skeleton);
    (void)stage.apply(adjusted, skeleton);
    const auto oracle_tips = hand::fingertip_positions(fk, skeleton);
    for (Sums* s : {&sums[k], &sums[hand::kPinchPairCount]}) {
      ++s->frames;
      s->tip += 0.5 * ((pred_tips[0] - true_tips[0]).norm() + (pred_tips[f] - true_tips[f]).norm());
      s->tip_oracle += 0.5 * ((oracle_tips[0] - true_tips[0]).norm() + (oracle_tips[f] - true_tips[f]).norm());
      s->midpoint += (0.5 * (pred_tips[0] + pred_tips[f]) - 0.5 * (true_tips[0] + true_tips[f])).norm();
      s->distance += std::abs((pred_tips[0] - pred_tips[f]).norm() - true_d[k]);
      s->distance_oracle += std::abs((oracle_tips[0] - oracle_tips[f]).norm() - true_d[k]);
    }
  }
  std::printf("pair    frames  tip error: estimate / stage told contact / midpoint (mm)  distance error: estimate / stage (mm)\n");
  for (std::size_t k = 0; k <= hand::kPinchPairCount; ++k) {
    const Sums& s = sums[k];
    if (s.frames == 0) continue;
    const double n = static_cast<double>(s.frames);
    std::printf("%-7s %6zu  %6.2f / %6.2f / %6.2f                                 %6.2f / %6.2f\n",
                k < hand::kPinchPairCount ? hand::to_string(static_cast<hand::Finger>(k + 1)) : "all", s.frames, s.tip / n,
                s.tip_oracle / n, s.midpoint / n, s.distance / n, s.distance_oracle / n);
  }
  return 0;
}
