// Driver of team_layers.sh: one thread, then a team of 2, on the same random U-Net (Fixed16 where
// the instruction set has it, as BM_UNetForward), batch 1; prints thousands of time-stamp-counter
// cycles per frame for each layer's parts and each member's share of the products. Built against
// the instrumented copy of the headers that team_layers_instrument.py writes.
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
