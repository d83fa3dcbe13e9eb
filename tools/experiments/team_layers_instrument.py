#!/usr/bin/env python3
"""Writes a copy of include/glovepose whose U-Net runner reads the time-stamp counter around each
layer's parts (compaction, products, Fixed16 finish, activation) and each team member's share of
the products, into ROOT/include. Used by team_layers.sh; the library itself has no such hooks
(they would sit on the per-frame path). Fails naming the piece of code it no longer finds."""
import shutil
import sys

source, root = sys.argv[1], sys.argv[2]
shutil.copytree(source + "/include", root + "/include")
run_path = root + "/include/glovepose/nn/unet_run.hpp"
unet_path = root + "/include/glovepose/nn/unet.hpp"


def patch(path, edits):
    text = open(path).read()
    for old, new in edits:
        if old not in text:
            sys.exit(f"team_layers_instrument.py: {path} no longer contains:\n{old}")
        text = text.replace(old, new, 1)
    open(path, "w").write(text)


patch(run_path, [
    ("namespace glovepose::nn {\n", """#include <x86intrin.h>
namespace glovepose::nn {
// Cycles per layer: [0] compaction, [1] products (with the hand-over), [2] Fixed16 finish,
// [3] activation; per member of a team: [0] start after the hand-over began, [1] its share.
struct LayerProfile {
  unsigned long long part[32][4] = {};
  unsigned long long member[32][2][2] = {};
  unsigned long long handed_over = 0;
  int layer = 0;
};
inline LayerProfile g_profile;
"""),
    ("""    if (layer.weights.fixed16()) {                 // Fixed16: products of levels first, then scale, offset and bias
      std::fill(out, out + static_cast<long>(rows) * out_spec.stride, 0.0f);
      run_taps(layer, layer.weights.wfx16.data(), frames, ws, team);
      finish_fixed16(layer, frames, ws);""", """    auto& part = g_profile.part[g_profile.layer++ & 31];
    const auto start = __rdtsc();
    if (layer.weights.fixed16()) {                 // Fixed16: products of levels first, then scale, offset and bias
      std::fill(out, out + static_cast<long>(rows) * out_spec.stride, 0.0f);
      run_taps(layer, layer.weights.wfx16.data(), frames, ws, team);
      const auto products_end = __rdtsc();
      finish_fixed16(layer, frames, ws);
      part[1] += products_end - start;
      part[2] += __rdtsc() - products_end;"""),
    ("""          run_products(layer, w, frames, ws, team);
      });""", """          run_products(layer, w, frames, ws, team);
      });
      part[1] += __rdtsc() - start;"""),
    ("""    if (layer.activation == Activation::Relu)
      Backend::relu""", """    const auto activation_start = __rdtsc();
    if (layer.activation == Activation::Relu)
      Backend::relu"""),
    ("""      for (int r = 0; r < rows; ++r) out[r] = std::tanh(out[r]);
  }""", """      for (int r = 0; r < rows; ++r) out[r] = std::tanh(out[r]);
    part[3] += __rdtsc() - activation_start;
  }"""),
    ("""    if (frames <= kSparseMaxFrames) compact_sources(layer, frames, ws, first_row);
    if (team == nullptr""", """    const auto compaction_start = __rdtsc();
    if (frames <= kSparseMaxFrames) compact_sources(layer, frames, ws, first_row);
    const auto compaction = __rdtsc() - compaction_start;
    g_profile.part[(g_profile.layer - 1) & 31][0] += compaction;
    g_profile.part[(g_profile.layer - 1) & 31][1] -= compaction;  // counted once, as compaction
    if (team == nullptr"""),
    ("""    auto share = [&](int member) noexcept { run_tap_share(layer, weights, frames, ws, first_row, Share{member, team->size()}); };
    team->run(share);""", """    const int profiled = (g_profile.layer - 1) & 31;
    auto share = [&](int member) noexcept {
      const auto begin = __rdtsc();
      run_tap_share(layer, weights, frames, ws, first_row, Share{member, team->size()});
      g_profile.member[profiled][member & 1][0] += begin - g_profile.handed_over;
      g_profile.member[profiled][member & 1][1] += __rdtsc() - begin;
    };
    g_profile.handed_over = __rdtsc();
    team->run(share);"""),
])
patch(unet_path, [
    ("for (const PackedLayer& layer : layers_) runner.run(layer, frames, ws, team);",
     "g_profile.layer = 0;\n    for (const PackedLayer& layer : layers_) runner.run(layer, frames, ws, team);"),
])
