/// @file trainable_fcn.hpp
/// @brief The paper's fully connected baseline (appendix A: F44-F2048-F2048-F2048-F2048-F1024-F26,
/// after Glauser et al. 2019), with 25 outputs: inputs -> h -> h -> h -> h -> h/2 -> 25, ReLU between
/// layers, no activation on the output. Tensors fc1..fc6 as torch.nn.Linear names them
/// (tools/python/glovepose_ref/fcn.py). Work is split over a ThreadPool by fixed shares: forward
/// and input gradients by frames, weight gradients by output rows.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "../config.hpp"
#include "../nn/fcn_topology.hpp"
#include "../core/random.hpp"
#include "network.hpp"

namespace glovepose::train {

using nn::fcn_widths;
static_assert(nn::kFcnOutputs == kTargets, "the FCN predicts every DoF");

/// @brief The trainable FCN.
class TrainableFcn final : public TrainableNetwork {
 public:
  /// @brief An FCN for `inputs` cells with hidden width `hidden` (the paper: 2048), for batches of
  /// up to `max_batch` frames; tensors zero until initialize() or load().
  TrainableFcn(int inputs, int hidden, int max_batch) : hidden_(hidden), max_batch_(max_batch), widths_(fcn_widths(inputs, hidden)) {
    if (inputs < 1 || hidden < 2 || hidden > 65536 || max_batch < 1 || max_batch > (1 << 20))
      throw Error("TrainableFcn: inputs " + std::to_string(inputs) + ", hidden " + std::to_string(hidden) + ", max_batch " +
                  std::to_string(max_batch) + ", expected inputs >= 1, hidden 2..65536, max_batch 1..1048576");
    for (std::size_t l = 0; l + 1 < widths_.size(); ++l) {
      const std::string name = "fc" + std::to_string(l + 1);
      weights_.push_back(params_.add(name + ".weight", {widths_[l + 1], widths_[l]}));
      biases_.push_back(params_.add(name + ".bias", {widths_[l + 1]}));
    }
    for (int w : widths_) {
      values_.emplace_back(static_cast<std::size_t>(w) * static_cast<std::size_t>(max_batch), 0.0f);
      grads_.emplace_back(static_cast<std::size_t>(w) * static_cast<std::size_t>(max_batch), 0.0f);
    }
  }

  model::Architecture architecture() const override { return model::Architecture::Fcn; }
  int width() const override { return hidden_; }
  int inputs() const override { return widths_.front(); }
  int max_batch() const override { return max_batch_; }
  const float* output() const override { return values_.back().data(); }
  ParameterSet& parameters() override { return params_; }
  const ParameterSet& parameters() const override { return params_; }

  /// @brief Xavier-uniform weights, zero biases; the draw depends only on `seed`.
  void initialize(std::uint64_t seed) override {
    core::Rng rng(seed);
    for (std::size_t l = 0; l < weights_.size(); ++l) {
      Parameter& w = params_[weights_[l]];
      const double a = std::sqrt(6.0 / static_cast<double>(w.shape[0] + w.shape[1]));
      for (float& v : w.value) v = static_cast<float>(rng.uniform(-a, a));
      std::fill(params_[biases_[l]].value.begin(), params_[biases_[l]].value.end(), 0.0f);
    }
  }

  void forward(const float* cells, int frames, bool /*training: no batch norm*/, core::ThreadPool& pool) override {
    if (frames < 1 || frames > max_batch_)
      throw Error("TrainableFcn: " + std::to_string(frames) + " frames, expected 1.." + std::to_string(max_batch_));
    frames_ = frames;
    std::copy(cells, cells + static_cast<long>(frames) * widths_.front(), values_[0].begin());
    pool.for_shares(frames, [&](core::Range r, int) {
      for (std::size_t l = 0; l < weights_.size(); ++l) {
        const int in = widths_[l], out = widths_[l + 1];
        ConstMatrixMap x(values_[l].data() + r.begin * in, r.size(), in);
        MatrixMap y(values_[l + 1].data() + r.begin * out, r.size(), out);
        ConstMatrixMap w(params_[weights_[l]].value.data(), out, in);
        y.rowwise() = Eigen::Map<const Eigen::RowVectorXf>(params_[biases_[l]].value.data(), out);
        y.noalias() += x * w.transpose();
        if (l + 2 < widths_.size()) y = y.cwiseMax(0.0f);
      }
    });
  }

  void backward(const float* output_grad, core::ThreadPool& pool) override {
    const int frames = frames_, members = pool.size();
    std::copy(output_grad, output_grad + static_cast<long>(frames) * kTargets, grads_.back().begin());
    for (std::size_t l = weights_.size(); l-- > 0;) {
      const int in = widths_[l], out = widths_[l + 1];
      float* delta = grads_[l + 1].data();
      const float* y = values_[l + 1].data();
      const bool relu = l + 2 < widths_.size();
      pool.run([&](int member) {
        const core::Range r = core::share(frames, member, members);
        if (relu)
          for (long i = r.begin * out; i < r.end * out; ++i) delta[i] = y[i] > 0.0f ? delta[i] : 0.0f;
      });
      pool.run([&](int member) {
        // Input gradient (frames x in) for this member's frames; weight and bias rows for its share of outputs.
        const core::Range r = core::share(frames, member, members);
        ConstMatrixMap w(params_[weights_[l]].value.data(), out, in);
        if (l > 0 && r.size() > 0) {
          MatrixMap dx(grads_[l].data() + r.begin * in, r.size(), in);
          ConstMatrixMap d(delta + r.begin * out, r.size(), out);
          dx.noalias() = d * w;
        }
        const core::Range rows = core::share(out, member, members);
        if (rows.size() == 0) return;
        ConstMatrixMap d(delta, frames, out);
        ConstMatrixMap x(values_[l].data(), frames, in);
        MatrixMap dw(params_[weights_[l]].grad.data() + rows.begin * in, rows.size(), in);
        dw.noalias() = d.middleCols(rows.begin, rows.size()).transpose() * x;
        float* db = params_[biases_[l]].grad.data();
        for (long o = rows.begin; o < rows.end; ++o) {
          double s = 0.0;
          for (int f = 0; f < frames; ++f) s += delta[static_cast<long>(f) * out + o];
          db[o] = static_cast<float>(s);
        }
      });
    }
  }

 private:
  using RowMatrix = Eigen::Matrix<float, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
  using MatrixMap = Eigen::Map<RowMatrix>;
  using ConstMatrixMap = Eigen::Map<const RowMatrix>;

  int hidden_;
  int max_batch_;
  std::vector<int> widths_;
  ParameterSet params_;
  std::vector<std::size_t> weights_, biases_;
  std::vector<std::vector<float>> values_, grads_;  // per layer boundary, [frame][feature]
  int frames_ = 0;
};

}  // namespace glovepose::train
