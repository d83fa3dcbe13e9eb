/// @file trainable_unet.hpp
/// @brief The U-Net (nn/unet_topology.hpp) with a training-mode forward pass (batch norm on batch
/// statistics, running statistics updated as PyTorch does) and its backward pass.
///
/// Activations are kept as [position][frame][channel], so on the fixed small grids every
/// (output position, useful tap, source) triple is one matrix product of a (frames x in) block with
/// the tap's (in x out) weight block, and the backward pass is the two transposed products: the
/// input gradient (frames x out)(out x in) and the weight gradient (in x frames)(frames x out).
/// Taps that only meet zero padding are never multiplied (their gradient is exactly zero, as in
/// PyTorch). The work is split over a ThreadPool by fixed shares: forward and input gradients by
/// frames, weight gradients by (tap, column block), batch-norm sums by frames and combined in member
/// order, so the result is reproducible for a given thread count.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "../config.hpp"
#include "../grid/grid_map.hpp"
#include "../nn/conv_plan.hpp"
#include "../status.hpp"
#include "../nn/unet_topology.hpp"
#include "../core/random.hpp"
#include "network.hpp"

namespace glovepose::train {

/// @brief Batch-norm settings (PyTorch's defaults).
struct BatchNormConfig {
  double epsilon = 1e-5;  ///< Added to the variance.
  double momentum = 0.1;  ///< Weight of the new batch in the running statistics.
};

/// @brief The trainable U-Net of base width w.
class TrainableUNet final : public TrainableNetwork {
 public:
  /// @brief A width-`width` network for batches of up to `max_batch` frames, its input and output
  /// placed by `map`; tensors zero until initialize() or load().
  TrainableUNet(int width, grid::GridMap map, int max_batch, BatchNormConfig bn = {})
      : width_(width), max_batch_(max_batch), map_(std::move(map)), bn_(bn) {
    if (width < 1 || width > 4096) throw Error("TrainableUNet: width " + std::to_string(width) + ", expected 1..4096");
    if (max_batch < 1 || max_batch > (1 << 20))
      throw Error("TrainableUNet: max_batch " + std::to_string(max_batch) + ", expected 1..1048576");
    if (!(bn.epsilon > 0.0) || !(bn.momentum >= 0.0 && bn.momentum <= 1.0))
      throw Error("TrainableUNet: expected batch-norm epsilon > 0 and momentum in [0, 1]");
    const int extra = map_.extra_input_count();
    for (int id = 0; id < nn::kUNetBufferCount; ++id) {
      const int size = nn::unet_buffer_size(id);
      buffers_.push_back({nn::unet_buffer_channels(id, width, extra), size * size});
    }
    std::size_t largest = 0;
    for (const nn::UNetLayer& spec : nn::unet_layers(width)) {
      spec.geometry.validate(spec.conv);
      Layer l;
      l.spec = spec;
      l.in = spec.in_channels(width, extra);
      l.weight = params_.add(spec.conv + ".weight",
                             spec.geometry.transposed
                                 ? std::vector<std::int64_t>{l.in, spec.out_channels, spec.geometry.kernel, spec.geometry.kernel}
                                 : std::vector<std::int64_t>{spec.out_channels, l.in, spec.geometry.kernel, spec.geometry.kernel},
                             spec.geometry.transposed ? Layout::TransposedTaps : Layout::ConvTaps);
      l.bias = params_.add(spec.conv + ".bias", {spec.out_channels});
      if (!spec.bn.empty()) {
        l.gamma = params_.add(spec.bn + ".weight", {spec.out_channels});
        l.beta = params_.add(spec.bn + ".bias", {spec.out_channels});
        l.running_mean = params_.add(spec.bn + ".running_mean", {spec.out_channels}, Layout::Plain, false);
        l.running_var = params_.add(spec.bn + ".running_var", {spec.out_channels}, Layout::Plain, false);
      }
      const int positions = buffers_[static_cast<std::size_t>(spec.out_buffer)].positions;
      l.pairs.resize(static_cast<std::size_t>(positions));
      for (const nn::TapPairs& t : nn::plan_taps(spec.geometry)) {
        l.useful_taps.push_back(t.tap);
        for (std::size_t j = 0; j < t.out_positions.size(); ++j)
          l.pairs[static_cast<std::size_t>(t.out_positions[j])].push_back({t.tap, t.in_positions[j]});
      }
      l.pre.resize(static_cast<std::size_t>(positions) * static_cast<std::size_t>(max_batch) * static_cast<std::size_t>(spec.out_channels));
      largest = std::max(largest, l.pre.size());
      layers_.push_back(std::move(l));
    }
    for (const BufferShape& b : buffers_) {
      const std::size_t n =
          static_cast<std::size_t>(b.positions) * static_cast<std::size_t>(max_batch) * static_cast<std::size_t>(b.channels);
      values_.emplace_back(n, 0.0f);
      grads_.emplace_back(n, 0.0f);
    }
    delta_.resize(largest);
    planes_.resize(static_cast<std::size_t>(max_batch) * static_cast<std::size_t>(map_.input_plane_count()) * nn::kUNetGridPositions);
    output_.resize(static_cast<std::size_t>(max_batch) * kTargets);
  }

  model::Architecture architecture() const override { return model::Architecture::UNet; }
  int width() const override { return width_; }
  int inputs() const override { return map_.cell_count(); }
  int max_batch() const override { return max_batch_; }
  const float* output() const override { return output_.data(); }
  ParameterSet& parameters() override { return params_; }
  const ParameterSet& parameters() const override { return params_; }
  /// @brief The map placing cells and DoFs.
  const grid::GridMap& grid_map() const noexcept { return map_; }

  /// @brief Xavier-uniform convolution weights (torch.nn.init.xavier_uniform_'s fans), zero biases,
  /// batch norm scale 1, shift 0, running mean 0 and variance 1; the draw depends only on `seed`.
  void initialize(std::uint64_t seed) override {
    core::Rng rng(seed);
    for (Parameter& p : params_.all()) {
      const bool conv_weight = p.layout != Layout::Plain;
      const bool bn_scale = !conv_weight && p.name.rfind(".weight") == p.name.size() - 7;
      if (conv_weight) {
        const double receptive = static_cast<double>(p.shape[2] * p.shape[3]);
        const double a = std::sqrt(6.0 / (static_cast<double>(p.shape[0] + p.shape[1]) * receptive));
        for (float& v : p.value) v = static_cast<float>(rng.uniform(-a, a));
      } else {
        const bool unit = bn_scale || p.name.find("running_var") != std::string::npos;
        std::fill(p.value.begin(), p.value.end(), unit ? 1.0f : 0.0f);
      }
    }
  }

  void forward(const float* cells, int frames, bool training, core::ThreadPool& pool) override {
    check_frames(frames);
    // Cells -> the network's input planes (the stretch maps, one constant plane per extra input),
    // as the estimator makes them (GridMap::to_input_planes), then into the activation layout.
    const int cells_per_frame = map_.cell_count();
    const long values = static_cast<long>(map_.input_plane_count()) * nn::kUNetGridPositions;
    for (int f = 0; f < frames; ++f)
      if (map_.to_input_planes(cells + static_cast<long>(f) * cells_per_frame, planes_.data() + f * values) != Status::Ok)
        throw Error("TrainableUNet: frame " + std::to_string(f) + " of the batch has a non-finite input");
    nn::to_position_major(planes_.data(), frames, map_.input_plane_count(), nn::kUNetGridPositions, values_[0].data());
    run_forward(frames, training, pool);
    const float* out = values_.back().data();
    for (int f = 0; f < frames; ++f)
      for (int d = 0; d < kTargets; ++d)
        output_[static_cast<std::size_t>(f * kTargets + d)] =
            out[static_cast<long>(map_.dof_slots()[static_cast<std::size_t>(d)].flat()) * frames + f];
  }

  void backward(const float* output_grad, core::ThreadPool& pool) override {
    float* g = grads_.back().data();
    for (int f = 0; f < frames_; ++f)
      for (int d = 0; d < kTargets; ++d)
        g[static_cast<long>(map_.dof_slots()[static_cast<std::size_t>(d)].flat()) * frames_ + f] = output_grad[f * kTargets + d];
    run_backward(pool);
  }

  /// @brief Forward pass on input planes (frames x (2 + extra inputs) x 5 x 5, PyTorch's NCHW
  /// order: the stretch maps, then the extra inputs' planes); `pose_maps` receives frames x 1 x 5 x 5.
  void forward_maps(const float* maps, int frames, bool training, core::ThreadPool& pool, float* pose_maps) {
    check_frames(frames);
    nn::to_position_major(maps, frames, map_.input_plane_count(), nn::kUNetGridPositions, values_[0].data());
    run_forward(frames, training, pool);
    nn::from_position_major(values_.back().data(), frames, nn::kUNetGridPositions, pose_maps);
  }

  /// @brief Backward pass given dLoss/dpose_map (frames x 1 x 5 x 5) of the last forward_maps().
  void backward_maps(const float* pose_map_grad, core::ThreadPool& pool) {
    nn::to_position_major(pose_map_grad, frames_, 1, nn::kUNetGridPositions, grads_.back().data());
    run_backward(pool);
  }

 private:
  using RowMatrix = Eigen::Matrix<float, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
  using MatrixMap = Eigen::Map<RowMatrix>;
  using ConstMatrixMap = Eigen::Map<const RowMatrix>;

  struct BufferShape {
    int channels;
    int positions;
  };
  struct Pair {
    int tap;
    int in_position;
  };
  struct Layer {
    nn::UNetLayer spec;
    int in = 0;
    std::size_t weight = 0, bias = 0, gamma = 0, beta = 0, running_mean = 0, running_var = 0;
    std::vector<std::vector<Pair>> pairs;  // [output position] -> the useful taps reaching it
    std::vector<int> useful_taps;
    std::vector<float> pre;             // conv output; with batch norm, overwritten by x-hat
    std::vector<double> mean, inv_std;  // batch norm: the statistics the forward used
    bool has_bn() const noexcept { return !spec.bn.empty(); }
  };

  void check_frames(int frames) {
    if (frames < 1 || frames > max_batch_)
      throw Error("TrainableUNet: " + std::to_string(frames) + " frames, expected 1.." + std::to_string(max_batch_));
    frames_ = frames;
  }

  // Per member, two sums per channel (double), zeroed; combined afterwards in member order.
  std::vector<double>& partials(int members, int channels) {
    partial_.assign(static_cast<std::size_t>(members) * 2 * static_cast<std::size_t>(channels), 0.0);
    return partial_;
  }

  void run_forward(int frames, bool training, core::ThreadPool& pool) {
    training_ = training;
    for (Layer& layer : layers_) forward_layer(layer, frames, training, pool);
  }

  void forward_layer(Layer& layer, int frames, bool training, core::ThreadPool& pool) {
    const int cout = layer.spec.out_channels;
    const int positions = buffers_[static_cast<std::size_t>(layer.spec.out_buffer)].positions;
    const float* w = params_[layer.weight].value.data();
    const float* bias = params_[layer.bias].value.data();
    float* pre = layer.pre.data();
    const int members = pool.size();
    std::vector<double>& sums = partials(members, cout);
    // Convolution (plus, for batch norm in training, the per-channel sums of this member's frames).
    pool.for_shares(frames, [&](core::Range r, int member) {
      const long n = r.size();
      for (int o = 0; o < positions; ++o) {
        MatrixMap z(pre + (static_cast<long>(o) * frames + r.begin) * cout, n, cout);
        z.rowwise() = Eigen::Map<const Eigen::RowVectorXf>(bias, cout);
        for (const Pair& pr : layer.pairs[static_cast<std::size_t>(o)]) {
          int base = 0;
          for (int source : layer.spec.sources) {
            const int cs = buffers_[static_cast<std::size_t>(source)].channels;
            ConstMatrixMap x(values_[static_cast<std::size_t>(source)].data() + (static_cast<long>(pr.in_position) * frames + r.begin) * cs,
                             n, cs);
            ConstMatrixMap wt(w + (static_cast<long>(pr.tap) * layer.in + base) * cout, cs, cout);
            z.noalias() += x * wt;
            base += cs;
          }
        }
      }
      if (layer.has_bn() && training) {
        double* s = sums.data() + static_cast<std::size_t>(member) * 2 * static_cast<std::size_t>(cout);
        for (int o = 0; o < positions; ++o)
          for (long f = r.begin; f < r.end; ++f) {
            const float* row = pre + (static_cast<long>(o) * frames + f) * cout;
            for (int c = 0; c < cout; ++c) s[c] += row[c];
          }
      }
    });
    if (layer.has_bn()) batch_norm_statistics(layer, frames, positions, training, pool);
    // Batch norm (x-hat kept in `pre` for the backward pass) and activation.
    const float* gamma = layer.has_bn() ? params_[layer.gamma].value.data() : nullptr;
    const float* beta = layer.has_bn() ? params_[layer.beta].value.data() : nullptr;
    float* out = values_[static_cast<std::size_t>(layer.spec.out_buffer)].data();
    const bool relu = layer.spec.activation == nn::Activation::Relu;
    pool.for_shares(frames, [&](core::Range r, int) {
      for (int o = 0; o < positions; ++o)
        for (long f = r.begin; f < r.end; ++f) {
          const long row = (static_cast<long>(o) * frames + f) * cout;
          for (int c = 0; c < cout; ++c) {
            float v = pre[row + c];
            if (gamma) {
              const float xhat =
                  static_cast<float>((v - layer.mean[static_cast<std::size_t>(c)]) * layer.inv_std[static_cast<std::size_t>(c)]);
              pre[row + c] = xhat;
              v = gamma[c] * xhat + beta[c];
            }
            out[row + c] = relu ? std::max(v, 0.0f) : std::tanh(v);
          }
        }
    });
  }

  // Mean and 1/std of each channel: from the batch in training (two passes, in double; the running
  // statistics updated with the unbiased variance as torch.nn.BatchNorm2d does), else the running ones.
  void batch_norm_statistics(Layer& layer, int frames, int positions, bool training, core::ThreadPool& pool) {
    const int cout = layer.spec.out_channels, members = pool.size();
    layer.mean.assign(static_cast<std::size_t>(cout), 0.0);
    layer.inv_std.assign(static_cast<std::size_t>(cout), 0.0);
    float* running_mean = params_[layer.running_mean].value.data();
    float* running_var = params_[layer.running_var].value.data();
    if (!training) {
      for (int c = 0; c < cout; ++c) {
        layer.mean[static_cast<std::size_t>(c)] = running_mean[c];
        layer.inv_std[static_cast<std::size_t>(c)] = 1.0 / std::sqrt(static_cast<double>(running_var[c]) + bn_.epsilon);
      }
      return;
    }
    const double count = static_cast<double>(frames) * positions;
    for (int m = 0; m < members; ++m)
      for (int c = 0; c < cout; ++c) layer.mean[static_cast<std::size_t>(c)] += partial_[static_cast<std::size_t>(m * 2 * cout + c)];
    for (double& m : layer.mean) m /= count;
    std::vector<double>& sums = partials(members, cout);
    const float* pre = layer.pre.data();
    pool.for_shares(frames, [&](core::Range r, int member) {
      double* s = sums.data() + static_cast<std::size_t>(member) * 2 * static_cast<std::size_t>(cout) + cout;
      for (int o = 0; o < positions; ++o)
        for (long f = r.begin; f < r.end; ++f) {
          const float* row = pre + (static_cast<long>(o) * frames + f) * cout;
          for (int c = 0; c < cout; ++c) {
            const double d = row[c] - layer.mean[static_cast<std::size_t>(c)];
            s[c] += d * d;
          }
        }
    });
    const double momentum = bn_.momentum;
    for (int c = 0; c < cout; ++c) {
      double squares = 0.0;
      for (int m = 0; m < members; ++m) squares += sums[static_cast<std::size_t>(m * 2 * cout + cout + c)];
      const double var = squares / count;
      layer.inv_std[static_cast<std::size_t>(c)] = 1.0 / std::sqrt(var + bn_.epsilon);
      const double unbiased = count > 1 ? squares / (count - 1) : var;
      running_mean[c] = static_cast<float>((1.0 - momentum) * running_mean[c] + momentum * layer.mean[static_cast<std::size_t>(c)]);
      running_var[c] = static_cast<float>((1.0 - momentum) * running_var[c] + momentum * unbiased);
    }
  }

  void run_backward(core::ThreadPool& pool) {
    if (!training_) throw Error("TrainableUNet::backward: the last forward was in evaluation mode, expected training mode");
    const int frames = frames_;
    // Gradients of every buffer but the output start at zero; each consumer adds its share.
    pool.run([&](int member) {
      for (std::size_t b = 0; b + 1 < grads_.size(); ++b) {
        const long n = static_cast<long>(buffers_[b].positions) * frames * buffers_[b].channels;
        const core::Range r = core::share(n, member, pool.size());
        std::fill(grads_[b].data() + r.begin, grads_[b].data() + r.end, 0.0f);
      }
    });
    for (auto layer = layers_.rbegin(); layer != layers_.rend(); ++layer) backward_layer(*layer, frames, pool);
  }

  void backward_layer(Layer& layer, int frames, core::ThreadPool& pool) {
    const int cout = layer.spec.out_channels, members = pool.size();
    const int positions = buffers_[static_cast<std::size_t>(layer.spec.out_buffer)].positions;
    const float* y = values_[static_cast<std::size_t>(layer.spec.out_buffer)].data();
    const float* dy = grads_[static_cast<std::size_t>(layer.spec.out_buffer)].data();
    const float* pre = layer.pre.data();
    float* delta = delta_.data();
    const bool relu = layer.spec.activation == nn::Activation::Relu;
    std::vector<double>& sums = partials(members, cout);
    // Through the activation (and, for batch norm, the sums of delta and delta * x-hat).
    pool.for_shares(frames, [&](core::Range r, int member) {
      double* s = sums.data() + static_cast<std::size_t>(member) * 2 * static_cast<std::size_t>(cout);
      for (int o = 0; o < positions; ++o)
        for (long f = r.begin; f < r.end; ++f) {
          const long row = (static_cast<long>(o) * frames + f) * cout;
          for (int c = 0; c < cout; ++c) {
            const float d = relu ? (y[row + c] > 0.0f ? dy[row + c] : 0.0f) : dy[row + c] * (1.0f - y[row + c] * y[row + c]);
            delta[row + c] = d;
            if (layer.has_bn()) {
              s[c] += d;
              s[cout + c] += static_cast<double>(d) * pre[row + c];
            }
          }
        }
    });
    if (layer.has_bn()) {
      // dbeta = sum(delta), dgamma = sum(delta * x-hat); dz = gamma / std (delta - mean(delta) - x-hat mean(delta * x-hat)).
      float* dgamma = params_[layer.gamma].grad.data();
      float* dbeta = params_[layer.beta].grad.data();
      const float* gamma = params_[layer.gamma].value.data();
      std::vector<float> scale(static_cast<std::size_t>(cout)), mean_delta(static_cast<std::size_t>(cout)),
          mean_product(static_cast<std::size_t>(cout));
      const double count = static_cast<double>(frames) * positions;
      for (int c = 0; c < cout; ++c) {
        double sd = 0.0, sp = 0.0;
        for (int m = 0; m < members; ++m) {
          sd += sums[static_cast<std::size_t>(m * 2 * cout + c)];
          sp += sums[static_cast<std::size_t>(m * 2 * cout + cout + c)];
        }
        dbeta[c] = static_cast<float>(sd);
        dgamma[c] = static_cast<float>(sp);
        scale[static_cast<std::size_t>(c)] = static_cast<float>(gamma[c] * layer.inv_std[static_cast<std::size_t>(c)]);
        mean_delta[static_cast<std::size_t>(c)] = static_cast<float>(sd / count);
        mean_product[static_cast<std::size_t>(c)] = static_cast<float>(sp / count);
      }
      pool.for_shares(frames, [&](core::Range r, int) {
        for (int o = 0; o < positions; ++o)
          for (long f = r.begin; f < r.end; ++f) {
            const long row = (static_cast<long>(o) * frames + f) * cout;
            for (int c = 0; c < cout; ++c) {
              const std::size_t k = static_cast<std::size_t>(c);
              delta[row + c] = scale[k] * (delta[row + c] - mean_delta[k] - pre[row + c] * mean_product[k]);
            }
          }
      });
    }
    // The products: input gradients by frames, weight gradients by (tap, column block), bias by columns.
    const float* w = params_[layer.weight].value.data();
    float* dw = params_[layer.weight].grad.data();
    float* dbias = params_[layer.bias].grad.data();
    std::fill(params_[layer.weight].grad.begin(), params_[layer.weight].grad.end(), 0.0f);
    const int blocks = cout >= 32 * members ? members : 1;
    const long units = static_cast<long>(layer.useful_taps.size()) * blocks;
    // Output positions and in-positions reached by each tap, for the weight gradient.
    pool.run([&](int member) {
      const core::Range rows = core::share(frames, member, members);
      const long n = rows.size();
      for (int o = 0; o < positions && n > 0; ++o) {
        ConstMatrixMap dz(delta + (static_cast<long>(o) * frames + rows.begin) * cout, n, cout);
        for (const Pair& pr : layer.pairs[static_cast<std::size_t>(o)]) {
          int base = 0;
          for (int source : layer.spec.sources) {
            const int cs = buffers_[static_cast<std::size_t>(source)].channels;
            if (source != 0) {  // the network input needs no gradient
              MatrixMap dx(grads_[static_cast<std::size_t>(source)].data() + (static_cast<long>(pr.in_position) * frames + rows.begin) * cs,
                           n, cs);
              ConstMatrixMap wt(w + (static_cast<long>(pr.tap) * layer.in + base) * cout, cs, cout);
              dx.noalias() += dz * wt.transpose();
            }
            base += cs;
          }
        }
      }
      const core::Range mine = core::share(units, member, members);
      for (long u = mine.begin; u < mine.end; ++u) {
        const int tap = layer.useful_taps[static_cast<std::size_t>(u / blocks)];
        const core::Range cols = core::share(cout, static_cast<int>(u % blocks), blocks);
        for (int o = 0; o < positions; ++o)
          for (const Pair& pr : layer.pairs[static_cast<std::size_t>(o)]) {
            if (pr.tap != tap) continue;
            ConstMatrixMap dz(delta + static_cast<long>(o) * frames * cout, frames, cout);
            int base = 0;
            for (int source : layer.spec.sources) {
              const int cs = buffers_[static_cast<std::size_t>(source)].channels;
              ConstMatrixMap x(values_[static_cast<std::size_t>(source)].data() + static_cast<long>(pr.in_position) * frames * cs, frames,
                               cs);
              MatrixMap g(dw + (static_cast<long>(tap) * layer.in + base) * cout, cs, cout);
              g.middleCols(cols.begin, cols.size()).noalias() += x.transpose() * dz.middleCols(cols.begin, cols.size());
              base += cs;
            }
          }
      }
      const core::Range bias_cols = core::share(cout, member, members);
      for (long c = bias_cols.begin; c < bias_cols.end; ++c) {
        double s = 0.0;
        for (long row = 0; row < static_cast<long>(positions) * frames; ++row) s += delta[row * cout + c];
        dbias[c] = static_cast<float>(s);
      }
    });
  }

  int width_;
  int max_batch_;
  grid::GridMap map_;
  std::vector<float> planes_;  // one batch's input planes, NCHW
  BatchNormConfig bn_;
  ParameterSet params_;
  std::vector<BufferShape> buffers_;
  std::vector<Layer> layers_;
  std::vector<std::vector<float>> values_, grads_;  // per buffer, [position][frame][channel]
  std::vector<float> delta_;                        // dLoss/d(conv output) of the layer being differentiated
  std::vector<double> partial_;
  std::vector<float> output_;
  int frames_ = 0;
  bool training_ = false;
};

}  // namespace glovepose::train
