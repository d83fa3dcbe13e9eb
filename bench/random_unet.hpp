// The benchmarks' U-Net: random weights in [-0.05, 0.05] and BN variances near 1 (seed 1), the same
// for every benchmark and for tools/experiments/team_layers.cpp.
#pragma once

#include <glovepose/nn/unet.hpp>

#include <random>
#include <string>
#include <utility>

inline glovepose::nn::TensorMap random_unet_tensors(int width) {
  std::mt19937 rng(1);
  std::uniform_real_distribution<float> u(-0.05f, 0.05f);
  glovepose::nn::TensorMap out;
  for (const auto& [name, shape] : glovepose::nn::UNet<>::expected_tensors(width)) {
    glovepose::nn::Tensor t{shape, {}};
    t.values.resize(static_cast<std::size_t>(t.element_count()));
    const bool variance = name.find("running_var") != std::string::npos;
    for (float& v : t.values) v = variance ? 1.0f + u(rng) : u(rng);
    out[name] = std::move(t);
  }
  return out;
}
