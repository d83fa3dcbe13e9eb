/// @file batching.hpp
/// @brief What every network shares about batches: the largest batch, when products skip zero
/// inputs, and how a batch for evaluation is split over threads.
#pragma once

#include <algorithm>

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

}  // namespace glovepose::nn
