// Driver of team_layers.sh: one thread, then a team of 2, on the same random U-Net (Fixed16 where
// the instruction set has it, as BM_UNetForward), batch 1; prints thousands of time-stamp-counter
// cycles per frame for each layer's parts and each member's share of the products, read through
// the runner's layer probe (nn/layer_probe.hpp).
#include <x86intrin.h>

#include <glovepose/nn/layer_probe.hpp>

// Cycles per layer: [0] compaction, [1] products without the compaction, [2] Fixed16 finish,
// [3] activation; per member of a team: [0] start after the hand-over began, [1] its share.
struct LayerProfile {
  unsigned long long part[32][4] = {};
  unsigned long long member[32][2][2] = {};
  int layer = 0;
};
inline LayerProfile g_profile;

struct TscProbe {
  static void mark(glovepose::nn::LayerEvent event, int member = 0) noexcept {
    using E = glovepose::nn::LayerEvent;
    // Each member writes only its own slots; the layer index is set before the hand-over.
    static unsigned long long layer_begin, compaction_begin, products_end, activation_begin, handed_over;
    static thread_local unsigned long long share_begin;
    const unsigned long long now = __rdtsc();
    auto& part = g_profile.part[(g_profile.layer - 1) & 31];
    switch (event) {
      case E::Forward: g_profile.layer = 0; break;
      case E::LayerBegin: ++g_profile.layer; layer_begin = now; handed_over = 0; break;
      case E::CompactionBegin: compaction_begin = now; break;
      case E::CompactionEnd: part[0] += now - compaction_begin; part[1] -= now - compaction_begin; break;  // counted once
      case E::HandOver: handed_over = now; break;
      case E::ShareBegin:
        share_begin = now;
        if (handed_over != 0) g_profile.member[(g_profile.layer - 1) & 31][member & 1][0] += now - handed_over;
        break;
      case E::ShareEnd: g_profile.member[(g_profile.layer - 1) & 31][member & 1][1] += now - share_begin; break;
      case E::ProductsEnd: part[1] += now - layer_begin; products_end = now; break;
      case E::FinishEnd: part[2] += now - products_end; break;
      case E::ActivationBegin: activation_begin = now; break;
      case E::ActivationEnd: part[3] += now - activation_begin; break;
    }
  }
};
#define GLOVEPOSE_LAYER_PROBE TscProbe

#include <glovepose/core/team.hpp>
#include <glovepose/nn/unet.hpp>

#include "../../bench/random_unet.hpp"

#include <cstdio>
#include <cstdlib>
#include <random>
#include <string>
#include <vector>

using namespace glovepose::nn;

namespace {
double thousands(unsigned long long cycles, int frames) { return static_cast<double>(cycles) / frames / 1000.0; }
}  // namespace

int main(int argc, char** argv) {
  const int width = argc > 1 ? std::atoi(argv[1]) : 64;
  const int frames = 20000;
  const auto net = UNet<>::from_tensors(random_unet_tensors(width), width, 1e-5, realtime_storage());
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  std::vector<float> in(kUNetInputs), out(kUNetOutputs);
  for (float& v : in) v = u(rng);
  std::printf("w = %d, %s, thousands of cycles per frame (%d frames after 2000)\n", width, storage_name(realtime_storage()), frames);
  for (int members : {1, 2}) {
    glovepose::core::Team team(members);
    auto ws = net.make_workspace(1, members);
    for (int i = 0; i < 2000; ++i) net.forward(in.data(), out.data(), 1, ws, team);
    g_profile = LayerProfile{};
    const auto start = __rdtsc();
    for (int i = 0; i < frames; ++i) net.forward(in.data(), out.data(), 1, ws, team);
    const auto total = __rdtsc() - start;
    std::printf("\n%s: %.1f per frame\n\n", members == 1 ? "one thread" : "team of 2", thousands(total, frames));
    std::printf("| layer | compaction | products | finish | activation | member 0 | member 1 |\n|---|---:|---:|---:|---:|---:|---:|\n");
    for (int l = 0; l < g_profile.layer && l < 32; ++l) {
      const auto& p = g_profile.part[l];
      const auto& m = g_profile.member[l];
      std::printf("| %d | %.1f | %.1f | %.1f | %.1f | %.1f | %.1f |\n", l, thousands(p[0], frames), thousands(p[1], frames),
                  thousands(p[2], frames), thousands(p[3], frames), thousands(m[0][1], frames), thousands(m[1][1], frames));
    }
  }
}
