// Counts global heap allocations, so tests can prove a per-frame call allocates nothing.
#pragma once

#include <cstddef>

namespace glovepose::test {

/// Number of calls to the global operator new (all forms) in this process so far.
std::size_t allocation_count() noexcept;

/// Allocations made while running `f`.
template <typename F>
std::size_t allocations_during(F&& f) {
  const std::size_t before = allocation_count();
  f();
  return allocation_count() - before;
}

}  // namespace glovepose::test
