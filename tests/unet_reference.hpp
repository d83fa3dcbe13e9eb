// An independent U-Net forward written straight from PyTorch's definitions (Conv2d, ConvTranspose2d,
// BatchNorm2d in eval mode, cat, ReLU, tanh) on NCHW tensors in double: no tap plans, no folding,
// no packing. The library's forward is checked against it and against PyTorch itself.
#pragma once

#include <glovepose/nn/tensor.hpp>

#include <cmath>
#include <random>
#include <string>
#include <vector>

namespace glovepose::test {

struct Grid {  // C x S x S, double
  int channels = 0, size = 0;
  std::vector<double> v;
  double& at(int c, int y, int x) { return v[static_cast<std::size_t>((c * size + y) * size + x)]; }
  double at(int c, int y, int x) const { return v[static_cast<std::size_t>((c * size + y) * size + x)]; }
};

inline Grid conv(const Grid& in, const nn::TensorMap& t, const std::string& name, int out_size, int k, int s, int p, bool transposed) {
  const auto& w = t.at(name + ".weight");
  const auto& b = t.at(name + ".bias").values;
  const int out_ch = static_cast<int>(transposed ? w.shape[1] : w.shape[0]);
  Grid out{out_ch, out_size, std::vector<double>(static_cast<std::size_t>(out_ch * out_size * out_size))};
  for (int o = 0; o < out_ch; ++o)
    for (int y = 0; y < out_size; ++y)
      for (int x = 0; x < out_size; ++x) out.at(o, y, x) = b[static_cast<std::size_t>(o)];
  for (int c = 0; c < in.channels; ++c)
    for (int o = 0; o < out_ch; ++o)
      for (int ky = 0; ky < k; ++ky)
        for (int kx = 0; kx < k; ++kx) {
          const double weight = transposed ? w.values[static_cast<std::size_t>(((c * out_ch + o) * k + ky) * k + kx)]
                                           : w.values[static_cast<std::size_t>(((o * in.channels + c) * k + ky) * k + kx)];
          if (!transposed) {
            for (int y = 0; y < out_size; ++y)
              for (int x = 0; x < out_size; ++x) {
                const int iy = y * s - p + ky, ix = x * s - p + kx;
                if (iy >= 0 && iy < in.size && ix >= 0 && ix < in.size) out.at(o, y, x) += weight * in.at(c, iy, ix);
              }
          } else {
            for (int iy = 0; iy < in.size; ++iy)
              for (int ix = 0; ix < in.size; ++ix) {
                const int y = iy * s - p + ky, x = ix * s - p + kx;
                if (y >= 0 && y < out_size && x >= 0 && x < out_size) out.at(o, y, x) += weight * in.at(c, iy, ix);
              }
          }
        }
  return out;
}

inline Grid batch_norm_relu(Grid g, const nn::TensorMap& t, const std::string& name, double eps = 1e-5) {
  for (int c = 0; c < g.channels; ++c) {
    const auto i = static_cast<std::size_t>(c);
    const double scale = t.at(name + ".weight").values[i] / std::sqrt(t.at(name + ".running_var").values[i] + eps);
    for (int y = 0; y < g.size; ++y)
      for (int x = 0; x < g.size; ++x) {
        double& v = g.at(c, y, x);
        v = (v - t.at(name + ".running_mean").values[i]) * scale + t.at(name + ".bias").values[i];
      }
  }
  return g;
}

inline Grid relu(Grid g) {
  for (double& v : g.v) v = v > 0.0 ? v : 0.0;
  return g;
}

inline Grid cat(const Grid& a, const Grid& b) {
  Grid out{a.channels + b.channels, a.size, a.v};
  out.v.insert(out.v.end(), b.v.begin(), b.v.end());
  return out;
}

// One frame: (2 + E) x 5 x 5 inputs (E extra input planes: enc1.weight's input channels less 2) -> the hidden activations e1..e4, d1..d3
// (after their ReLU) and the 25 outputs (1x5x5, last).
inline std::vector<Grid> unet_reference_activations(const nn::TensorMap& t, const float* input) {
  const int planes = static_cast<int>(t.at("enc1.weight").shape[1]);
  Grid x{planes, 5, std::vector<double>(input, input + planes * 25)};
  const Grid e1 = relu(conv(x, t, "enc1", 5, 5, 1, 2, false));
  const Grid e2 = relu(batch_norm_relu(conv(e1, t, "enc2", 3, 3, 2, 1, false), t, "bn2"));
  const Grid e3 = relu(batch_norm_relu(conv(e2, t, "enc3", 2, 3, 2, 1, false), t, "bn3"));
  const Grid e4 = relu(batch_norm_relu(conv(e3, t, "enc4", 1, 4, 2, 1, false), t, "bn4"));
  const Grid d1 = relu(batch_norm_relu(conv(e4, t, "dec1", 2, 4, 2, 1, true), t, "dbn1"));
  const Grid d2 = relu(batch_norm_relu(conv(cat(d1, e3), t, "dec2", 3, 3, 2, 1, true), t, "dbn2"));
  const Grid d3 = relu(batch_norm_relu(conv(cat(d2, e2), t, "dec3", 5, 3, 2, 1, true), t, "dbn3"));
  Grid y = conv(cat(d3, e1), t, "out", 5, 5, 1, 2, false);
  for (double& v : y.v) v = std::tanh(v);
  return {e1, e2, e3, e4, d1, d2, d3, y};
}

// One frame: (2 + E) x 5 x 5 inputs -> 25 outputs (1x5x5).
inline std::vector<double> unet_reference(const nn::TensorMap& t, const float* input) {
  return unet_reference_activations(t, input).back().v;
}

// Random tensors of the given shapes: weights ~ U(+-sqrt(6 / (fan_in + fan_out))) (Xavier),
// biases U(+-0.1), BN scale U(0.5, 1.5), shift U(+-0.2), mean U(+-0.2), variance U(0.5, 2).
inline nn::TensorMap random_tensors(const std::map<std::string, std::vector<std::int64_t>>& shapes, unsigned seed) {
  std::mt19937 rng(seed);
  nn::TensorMap out;
  for (const auto& [name, shape] : shapes) {
    nn::Tensor t{shape, {}};
    t.values.resize(static_cast<std::size_t>(t.element_count()));
    const auto uniform = [&](double lo, double hi) { return static_cast<float>(std::uniform_real_distribution<double>(lo, hi)(rng)); };
    const bool bn = name.find("bn") != std::string::npos;
    for (float& v : t.values) {
      if (bn && name.find(".running_var") != std::string::npos)
        v = uniform(0.5, 2.0);
      else if (bn && name.find(".running_mean") != std::string::npos)
        v = uniform(-0.2, 0.2);
      else if (bn && name.find(".weight") != std::string::npos)
        v = uniform(0.5, 1.5);
      else if (bn)
        v = uniform(-0.2, 0.2);
      else if (name.find(".bias") != std::string::npos)
        v = uniform(-0.1, 0.1);
      else {
        const double receptive = static_cast<double>(shape[2] * shape[3]);
        const double bound = std::sqrt(6.0 / (static_cast<double>(shape[0] + shape[1]) * receptive));
        v = uniform(-bound, bound);
      }
    }
    out[name] = std::move(t);
  }
  return out;
}

}  // namespace glovepose::test
