/// @file batching.hpp
/// @brief What every network shares about batches: the largest batch, when products skip zero
/// inputs, and how a batch for evaluation is split over threads.
#pragma once

#include <algorithm>
#include <cmath>
#include <string>

#include "../config.hpp"
#include "../status.hpp"

#include "../core/thread_pool.hpp"

namespace glovepose::nn {

/// @brief Largest batch a workspace may hold.
inline constexpr int kMaxBatch = 1 << 16;

/// @brief Up to this many frames per forward (forward_batch()'s default chunk), products take their
/// inputs as nonzero entries (kernels/sparse_row.hpp) and skip the zeros that ReLU leaves (about
/// half), their multiply-adds and, where a weight row meets a single activation, its reading. With
/// several frames each weight block is read once from memory and then from the L1/L2 for the other
/// rows, so skipping wins for batches too: at w = 64 a batch of 1024 frames in chunks of 32 ran
/// 1.1-1.6 times as fast as with the dense, register-blocked products, for every weight storage
/// (docs/performance.md). Larger calls keep the dense products, whose time does not depend on the input.
inline constexpr int kSparseMaxFrames = 32;

/// @brief Set-up code for evaluating many frames: calls work(begin, end) on `threads` threads, one
/// contiguous share of [0, frames) each (the calling thread takes the first), and rethrows the first
/// exception a share threw once all have ended.
template <typename Work>
void run_frame_shares(long frames, int threads, Work&& work) {
  core::ThreadPool pool(static_cast<int>(std::max<long>(1, std::min<long>(threads, frames))));
  pool.for_shares(frames, [&](core::Range r, int) { work(r.begin, r.end); });
}

/// @brief The forward_batch of every network (`net` named `name` in errors): checks the inputs,
/// then runs `chunk`-frame forwards of `in` values to `out` values per frame on `threads` threads,
/// each with its own workspace. Set-up code: allocates; throws glovepose::Error naming the first
/// frame with a non-finite input or the chunk that overflowed.
template <typename Network>
void forward_batch_of(const Network& net, const char* name, long in, long out, const float* input, float* output, long frames,
                      int threads, int chunk) {
  if (frames <= 0) return;
  const std::string where = std::string(name) + "::forward_batch: ";
  if (threads < 1 || chunk < 1) throw Error(where + "threads and chunk must be >= 1");
  for (long i = 0; i < frames * in; ++i)
    if (!std::isfinite(input[i])) throw Error(where + "frame " + std::to_string(i / in) + " has a non-finite input");
  chunk = std::min(chunk, kMaxBatch);
  run_frame_shares(frames, threads, [&](long begin, long end) {
    typename Network::Workspace ws = net.make_workspace(chunk);
    for (long f = begin; f < end; f += chunk) {
      const int n = static_cast<int>(std::min<long>(chunk, end - f));
      if (net.forward(input + f * in, output + f * out, n, ws) != Status::Ok)
        throw Error(where + "frames " + std::to_string(f) + ".." + std::to_string(f + n - 1) +
                    " overflowed inside the network (non-finite result)");
    }
  });
}

}  // namespace glovepose::nn
