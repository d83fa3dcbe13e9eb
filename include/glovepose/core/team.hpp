/// @file team.hpp
/// @brief A small team of persistent threads that work on one frame together: the caller and
/// size() - 1 workers each run their share of a job, and run() returns when every share is done.
///
/// Made for a batch-1 forward split layer by layer (nn/unet.hpp), where a job lasts a few
/// microseconds, so handing it over must cost far less: a worker that just finished a share spins
/// on the job counter for `spin` before it parks, so the layers of one frame (and frames arriving
/// back to back) find it awake; a worker idle for longer sleeps on a condition variable and costs
/// no CPU (an idle estimator), at the price of a wake-up (tens of microseconds) for the next frame.
#pragma once

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "../config.hpp"

#if defined(__x86_64__) || defined(__i386__)
#  include <immintrin.h>
#endif

namespace glovepose::core {

/// @brief The caller plus persistent worker threads; one job at a time, from one calling thread.
class Team {
 public:
  /// @brief A team of `size` members (the caller and size - 1 new threads) whose workers spin for
  /// `spin` after each share before parking. Set-up: throws glovepose::Error for a size below 1.
  explicit Team(int size, std::chrono::microseconds spin = std::chrono::microseconds(200)) : spin_(spin) {
    if (size < 1 || size > 1024) throw Error("Team: " + std::to_string(size) + " members, expected 1..1024");
    workers_.reserve(static_cast<std::size_t>(size - 1));
    for (int m = 1; m < size; ++m) workers_.emplace_back([this, m] { work(m); });
  }
  Team(const Team&) = delete;
  Team& operator=(const Team&) = delete;
  ~Team() {
    {
      const std::lock_guard<std::mutex> lock(mutex_);
      stop_.store(true, std::memory_order_seq_cst);
    }
    wake_.notify_all();
    for (std::thread& t : workers_) t.join();
  }

  /// @brief Members, the caller included.
  int size() const noexcept { return static_cast<int>(workers_.size()) + 1; }

  /// @brief Runs job(member) for every member 0..size()-1, member 0 on the calling thread, and
  /// returns when all are done. `job` must not throw. No allocation; locks a mutex only to wake
  /// parked workers.
  template <typename Job>
  GLOVEPOSE_REALTIME void run(Job& job) noexcept {
    if (workers_.empty()) {
      job(0);
      return;
    }
    call_ = [](void* context, int member) noexcept { (*static_cast<Job*>(context))(member); };
    context_ = &job;
    pending_.store(static_cast<int>(workers_.size()), std::memory_order_relaxed);
    generation_.fetch_add(1, std::memory_order_seq_cst);  // publishes call_, context_ and pending_
    if (parked_.load(std::memory_order_seq_cst) > 0) {
      const std::lock_guard<std::mutex> lock(mutex_);
      wake_.notify_all();
    }
    job(0);
    while (pending_.load(std::memory_order_acquire) != 0) pause();
  }

 private:
  static void pause() noexcept {
#if defined(__x86_64__) || defined(__i386__)
    _mm_pause();
#endif
  }

  void work(int member) {
    std::uint64_t seen = 0;
    for (;;) {
      // Spin a while for the next job, then park.
      const auto give_up = std::chrono::steady_clock::now() + spin_;
      for (int n = 0; generation_.load(std::memory_order_acquire) == seen && !stop_.load(std::memory_order_relaxed); ++n) {
        pause();
        if ((n & 255) == 255 && std::chrono::steady_clock::now() > give_up) {
          std::unique_lock<std::mutex> lock(mutex_);
          parked_.fetch_add(1, std::memory_order_seq_cst);
          wake_.wait(lock, [&] { return generation_.load(std::memory_order_seq_cst) != seen || stop_.load(std::memory_order_seq_cst); });
          parked_.fetch_sub(1, std::memory_order_seq_cst);
          break;
        }
      }
      if (stop_.load(std::memory_order_acquire)) return;
      seen = generation_.load(std::memory_order_acquire);
      call_(context_, member);
      pending_.fetch_sub(1, std::memory_order_acq_rel);
    }
  }

  std::chrono::microseconds spin_;
  std::vector<std::thread> workers_;
  void (*call_)(void*, int) noexcept = nullptr;
  void* context_ = nullptr;
  alignas(64) std::atomic<std::uint64_t> generation_{0};  // jobs posted
  alignas(64) std::atomic<int> pending_{0};               // workers still on the current job
  std::atomic<int> parked_{0};
  std::atomic<bool> stop_{false};
  std::mutex mutex_;
  std::condition_variable wake_;
};

}  // namespace glovepose::core
