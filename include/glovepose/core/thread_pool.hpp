/// @file thread_pool.hpp
/// @brief Set-up code's fork-join (training, batch evaluation, simulating a corpus): a Team whose
/// tasks may throw. Work split by fixed, contiguous shares is computed by the same member in the
/// same order for a given thread count (reproducible results).
#pragma once

#include <algorithm>
#include <chrono>
#include <exception>
#include <mutex>
#include <string>
#include <utility>

#include "../config.hpp"
#include "team.hpp"

namespace glovepose::core {

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

/// @brief Threads that run a task together; the calling thread is member 0. Unlike the per-frame
/// Team it runs on, a task may throw: run() rethrows the first exception once every member is done.
/// Its workers park as soon as a task ends (set-up tasks are long; nothing to gain from spinning).
class ThreadPool {
 public:
  /// @brief A team of `threads` members (threads - 1 workers are started). Throws for threads
  /// outside 1..1024.
  explicit ThreadPool(int threads) : team_(checked(threads), std::chrono::microseconds(0)) {}

  /// @brief Members of the team.
  int size() const noexcept { return team_.size(); }

  /// @brief Runs task(member) on every member and returns when all are done; rethrows the first
  /// exception a member threw.
  template <typename Task>
  void run(Task&& task) {
    std::exception_ptr failure;
    std::mutex failure_mutex;
    auto guarded = [&](int member) noexcept {
      try {
        task(member);
      } catch (...) {
        const std::lock_guard<std::mutex> lock(failure_mutex);
        if (!failure) failure = std::current_exception();
      }
    };
    team_.run(guarded);
    if (failure) std::rethrow_exception(failure);
  }

  /// @brief Runs body(range, member) over [0, n) split into one contiguous share per member.
  template <typename Body>
  void for_shares(long n, Body&& body) {
    run([&](int member) {
      const Range r = share(n, member, size());
      if (r.size() > 0) body(r, member);
    });
  }

 private:
  static int checked(int threads) {
    if (threads < 1 || threads > 1024) throw Error("ThreadPool: " + std::to_string(threads) + " threads, expected 1..1024");
    return threads;
  }

  Team team_;
};

}  // namespace glovepose::core
