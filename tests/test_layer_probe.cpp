// The U-Net runner's layer probe (nn/layer_probe.hpp), used as a timing experiment uses it
// (tools/experiments/team_layers.cpp): a probe changes the runner for the whole program, so this
// file is an executable of its own (tests/CMakeLists.txt). The events are checked against the
// network's layers as the reference forward (unet_reference.hpp) computes them.
#include <glovepose/nn/layer_probe.hpp>

#include <algorithm>
#include <mutex>
#include <vector>

namespace probe_test {
struct Mark {
  glovepose::nn::LayerEvent event;
  int member;
};
inline std::mutex mutex;
inline std::vector<Mark> marks;

struct RecordingProbe {
  static void mark(glovepose::nn::LayerEvent event, int member = 0) noexcept {
    const std::lock_guard<std::mutex> lock(mutex);  // team members mark from their own threads
    marks.push_back({event, member});               // reserved by the test: no allocation here
  }
};
}  // namespace probe_test

#define GLOVEPOSE_LAYER_PROBE ::probe_test::RecordingProbe
#include <glovepose/core/team.hpp>
#include <glovepose/nn/unet.hpp>

#include <doctest/doctest.h>

#include <cmath>
#include <random>

#include "unet_reference.hpp"

using namespace glovepose;
using namespace glovepose::nn;
using E = LayerEvent;

namespace {

constexpr int kWidth = 16;

struct Probed {
  std::vector<probe_test::Mark> marks;
  std::vector<float> out;
  std::vector<double> reference;
};

// One batch-1 forward of a random U-Net in `storage`, by a team of `members` (none when 1), with the
// events it marked and the reference forward of the same input.
Probed probed_forward(WeightStorage storage, int members) {
  const TensorMap tensors = test::random_tensors(UNet<>::expected_tensors(kWidth), 31);
  const auto net = UNet<>::from_tensors(tensors, kWidth, 1e-5, storage);
  std::mt19937 rng(3);
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  std::vector<float> in(kUNetInputs);
  for (float& v : in) v = u(rng);
  Probed p;
  p.out.resize(kUNetOutputs);
  p.reference = test::unet_reference(tensors, in.data());
  core::Team team(members);
  auto ws = net.make_workspace(1, members);
  probe_test::marks.clear();
  probe_test::marks.reserve(4096);
  const Status status = members > 1 ? net.forward(in.data(), p.out.data(), 1, ws, team) : net.forward(in.data(), p.out.data(), 1, ws);
  REQUIRE(status == Status::Ok);
  p.marks = probe_test::marks;
  return p;
}

std::vector<std::vector<probe_test::Mark>> by_layer(const std::vector<probe_test::Mark>& marks) {
  std::vector<std::vector<probe_test::Mark>> layers;
  for (const auto& m : marks)
    if (m.event == E::LayerBegin)
      layers.emplace_back(1, m);
    else if (!layers.empty())
      layers.back().push_back(m);
  return layers;
}

std::size_t layers_of_reference() {
  const TensorMap tensors = test::random_tensors(UNet<>::expected_tensors(kWidth), 31);
  const std::vector<float> in(kUNetInputs, 0.5f);
  return test::unet_reference_activations(tensors, in.data()).size();
}

std::vector<E> events_of(const std::vector<probe_test::Mark>& marks) {
  std::vector<E> out;
  for (const auto& m : marks) out.push_back(m.event);
  return out;
}

// The probed runner still computes the network: within `tolerance` of the reference forward.
void check_output(const Probed& p, double tolerance) {
  for (int i = 0; i < kUNetOutputs; ++i)
    CHECK(std::abs(p.out[static_cast<std::size_t>(i)] - p.reference[static_cast<std::size_t>(i)]) < tolerance);
}

}  // namespace

TEST_CASE("layer probe: one thread, Fixed16: per layer compaction, products, finish, activation, in order") {
  const Probed p = probed_forward(WeightStorage::Fixed16, 1);
  REQUIRE(!p.marks.empty());
  CHECK(p.marks.front().event == E::Forward);
  CHECK(std::count_if(p.marks.begin(), p.marks.end(), [](const auto& m) { return m.event == E::Forward; }) == 1);
  const auto layers = by_layer(p.marks);
  CHECK(layers.size() == layers_of_reference());
  // The first and last layers (few weights) stay F32 (unet_packing.hpp): their products in one piece.
  const std::vector<E> fixed16{E::LayerBegin,  E::CompactionBegin, E::CompactionEnd,   E::ShareBegin,   E::ShareEnd,
                               E::ProductsEnd, E::FinishEnd,       E::ActivationBegin, E::ActivationEnd};
  const std::vector<E> f32{E::LayerBegin, E::ProductsEnd, E::ActivationBegin, E::ActivationEnd};
  for (std::size_t l = 0; l < layers.size(); ++l) {
    INFO("layer " << l);
    CHECK(events_of(layers[l]) == (l == 0 || l + 1 == layers.size() ? f32 : fixed16));
  }
  check_output(p, 1e-2);  // Fixed16's rounding (test_unet.cpp)
}

TEST_CASE("layer probe: F32 layers have no Fixed16 finish and end with their activation") {
  const Probed p = probed_forward(WeightStorage::F32, 1);
  const auto layers = by_layer(p.marks);
  CHECK(layers.size() == layers_of_reference());
  for (std::size_t l = 0; l < layers.size(); ++l) {
    INFO("layer " << l);
    const std::vector<E> events = events_of(layers[l]);
    CHECK(std::count(events.begin(), events.end(), E::FinishEnd) == 0);
    REQUIRE(events.size() >= 4);
    CHECK(std::vector<E>(events.end() - 3, events.end()) == std::vector<E>{E::ProductsEnd, E::ActivationBegin, E::ActivationEnd});
  }
  check_output(p, 1e-5);
}

TEST_CASE("layer probe: a team of 2: each member's share once per layer, between the hand-over and the products' end") {
  const Probed p = probed_forward(WeightStorage::Fixed16, 2);
  const auto layers = by_layer(p.marks);
  CHECK(layers.size() == layers_of_reference());
  for (std::size_t l = 1; l + 1 < layers.size(); ++l) {  // the Fixed16 layers: products by taps
    INFO("layer " << l);
    const auto& marks = layers[l];
    const auto at = [&](E event) {
      return std::find_if(marks.begin(), marks.end(), [&](const auto& m) { return m.event == event; }) - marks.begin();
    };
    const auto hand_over = at(E::HandOver), products_end = at(E::ProductsEnd);
    REQUIRE(hand_over < products_end);
    for (int member : {0, 1}) {
      INFO("member " << member);
      std::vector<E> seen;
      for (auto i = hand_over + 1; i < products_end; ++i)
        if (marks[static_cast<std::size_t>(i)].member == member) seen.push_back(marks[static_cast<std::size_t>(i)].event);
      CHECK(seen == std::vector<E>{E::ShareBegin, E::ShareEnd});
    }
  }
  check_output(p, 1e-2);
}
