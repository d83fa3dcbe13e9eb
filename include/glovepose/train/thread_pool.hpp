/// @file thread_pool.hpp
/// @brief A fixed team of threads that runs one task on every member and waits: the training
/// loop's fork-join. Work is split by fixed, contiguous shares, so for a given thread count every
/// number is computed by the same thread in the same order (reproducible results).
#pragma once

#include <algorithm>
#include <condition_variable>
#include <exception>
#include <functional>
#include <mutex>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include "../config.hpp"

namespace glovepose::train {

/// @brief Half-open range [begin, end).
struct Range {
  long begin;  ///< First index.
  long end;    ///< One past the last index.
  /// @brief Number of indices.
  long size() const noexcept { return end - begin; }
};

/// @brief Share `part` of `parts` of [0, n): contiguous, sizes differ by at most one.
inline Range share(long n, int part, int parts) noexcept {
  const long base = n / parts, extra = n % parts;
  const long begin = part * base + std::min<long>(part, extra);
  return {begin, begin + base + (part < extra ? 1 : 0)};
}

/// @brief Threads that run a task together. The calling thread is member 0.
class ThreadPool {
 public:
  /// @brief A team of `threads` members (threads - 1 workers are started). Throws for threads < 1.
  explicit ThreadPool(int threads) : size_(threads) {
    if (threads < 1 || threads > 1024) throw Error("ThreadPool: " + std::to_string(threads) + " threads, expected 1..1024");
    for (int t = 1; t < threads; ++t) workers_.emplace_back([this, t] { work(t); });
  }
  ThreadPool(const ThreadPool&) = delete;
  ThreadPool& operator=(const ThreadPool&) = delete;
  ~ThreadPool() {
    {
      const std::lock_guard<std::mutex> lock(mutex_);
      stop_ = true;
      ++generation_;
    }
    start_.notify_all();
    for (std::thread& w : workers_) w.join();
  }

  /// @brief Members of the team.
  int size() const noexcept { return size_; }

  /// @brief Runs task(member) on every member and returns when all are done; rethrows the first
  /// exception a member threw.
  void run(const std::function<void(int)>& task) {
    if (size_ == 1) {
      task(0);
      return;
    }
    {
      const std::lock_guard<std::mutex> lock(mutex_);
      task_ = &task;
      pending_ = size_ - 1;
      failure_ = nullptr;
      ++generation_;
    }
    start_.notify_all();
    std::exception_ptr mine;
    try {
      task(0);
    } catch (...) {
      mine = std::current_exception();
    }
    std::unique_lock<std::mutex> lock(mutex_);
    done_.wait(lock, [this] { return pending_ == 0; });
    task_ = nullptr;
    if (mine) std::rethrow_exception(mine);
    if (failure_) std::rethrow_exception(failure_);
  }

  /// @brief Runs body(range, member) over [0, n) split into one contiguous share per member.
  template <typename Body>
  void for_shares(long n, Body&& body) {
    run([&](int member) {
      const Range r = share(n, member, size_);
      if (r.size() > 0) body(r, member);
    });
  }

 private:
  void work(int member) {
    unsigned long seen = 0;
    while (true) {
      const std::function<void(int)>* task = nullptr;
      {
        std::unique_lock<std::mutex> lock(mutex_);
        start_.wait(lock, [&] { return generation_ != seen; });
        seen = generation_;
        if (stop_) return;
        task = task_;
      }
      std::exception_ptr failure;
      try {
        (*task)(member);
      } catch (...) {
        failure = std::current_exception();
      }
      {
        const std::lock_guard<std::mutex> lock(mutex_);
        if (failure && !failure_) failure_ = failure;
        if (--pending_ == 0) done_.notify_one();
      }
    }
  }

  int size_;
  std::vector<std::thread> workers_;
  std::mutex mutex_;
  std::condition_variable start_, done_;
  const std::function<void(int)>* task_ = nullptr;
  unsigned long generation_ = 0;
  int pending_ = 0;
  bool stop_ = false;
  std::exception_ptr failure_;
};

}  // namespace glovepose::train
