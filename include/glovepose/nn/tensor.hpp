/// @file tensor.hpp
/// @brief Aligned storage for weights and activations.
#pragma once

#include <cstddef>
#include <cstdlib>
#include <limits>
#include <new>
#include <vector>

namespace glovepose::nn {

/// @brief Alignment of every weight and activation buffer: one cache line, enough for AVX-512.
inline constexpr std::size_t kAlignment = 64;

/// @brief Minimal allocator returning kAlignment-aligned memory (set-up code only).
template <typename T>
struct AlignedAllocator {
  /// @brief Element type.
  using value_type = T;
  AlignedAllocator() noexcept = default;
  /// @brief Rebinding constructor.
  template <typename U>
  AlignedAllocator(const AlignedAllocator<U>&) noexcept {}
  /// @brief Allocates n elements aligned to kAlignment.
  T* allocate(std::size_t n) {
    if (n > std::numeric_limits<std::size_t>::max() / sizeof(T)) throw std::bad_alloc();
    return static_cast<T*>(::operator new (n * sizeof(T), std::align_val_t{kAlignment}));
  }
  /// @brief Frees memory from allocate().
  void deallocate(T* p, std::size_t) noexcept { ::operator delete (p, std::align_val_t{kAlignment}); }
  /// @brief All instances are interchangeable.
  template <typename U>
  bool operator==(const AlignedAllocator<U>&) const noexcept {
    return true;
  }
  /// @brief All instances are interchangeable.
  template <typename U>
  bool operator!=(const AlignedAllocator<U>&) const noexcept {
    return false;
  }
};

/// @brief A contiguous, kAlignment-aligned vector.
template <typename T>
using AlignedVector = std::vector<T, AlignedAllocator<T>>;

/// @brief Rounds n up to a multiple of m.
constexpr int round_up(int n, int m) noexcept { return (n + m - 1) / m * m; }

}  // namespace glovepose::nn

#include <cmath>
#include <cstdint>
#include <map>
#include <string>

#include "../config.hpp"
#include "../io/shape.hpp"

namespace glovepose::nn {

/// @brief A named tensor as read from or written to a weight file: shape and values, row-major,
/// widened to float (set-up code).
struct Tensor {
  std::vector<std::int64_t> shape;  ///< Dimensions, outermost first.
  std::vector<float> values;        ///< product(shape) values, row-major.

  /// @brief Number of elements implied by the shape.
  std::int64_t element_count() const noexcept {
    std::int64_t n = 1;
    for (std::int64_t d : shape) n *= d;
    return n;
  }
};

/// @brief Tensors by name (PyTorch state_dict names).
using TensorMap = std::map<std::string, Tensor>;

/// @brief Checks a network's tensors against the names and shapes it is made of: every expected
/// tensor present, of its shape, with as many values, all finite, and no other tensor. Throws
/// glovepose::Error naming the tensor; messages start with `who` and say `which` network was
/// expected (e.g. "UNet", "a width-4 U-Net").
inline void check_tensors(const TensorMap& tensors, const std::map<std::string, std::vector<std::int64_t>>& expected,
                          const std::string& who, const std::string& which) {
  for (const auto& [name, shape] : expected) {
    const auto it = tensors.find(name);
    if (it == tensors.end())
      throw Error(who + ": tensor '" + name + "' is missing, expected shape " + io::shape_string(shape) + " (" + which + ")");
    if (it->second.shape != shape)
      throw Error(who + ": tensor '" + name + "' has shape " + io::shape_string(it->second.shape) + ", expected " +
                  io::shape_string(shape) + " (" + which + ")");
    if (static_cast<std::int64_t>(it->second.values.size()) != it->second.element_count())
      throw Error(who + ": tensor '" + name + "' holds " + std::to_string(it->second.values.size()) + " values for shape " +
                  io::shape_string(it->second.shape));
    for (float v : it->second.values)
      if (!std::isfinite(v)) throw Error(who + ": tensor '" + name + "' contains NaN or infinity, expected finite weights");
  }
  for (const auto& [name, t] : tensors)
    if (!expected.count(name)) throw Error(who + ": tensor '" + name + "' is not part of " + which);
}

}  // namespace glovepose::nn
