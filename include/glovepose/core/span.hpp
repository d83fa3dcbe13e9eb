/// @file span.hpp
/// @brief A view of contiguous values (C++17 has no std::span): what the narrow fronts return where
/// the stages hold Eigen vectors, so their users need no Eigen.
#pragma once

#include <cstddef>

namespace glovepose::core {

/// @brief `size()` values of type T at `data()`, owned elsewhere; valid while the owner is unchanged.
template <typename T>
class Span {
 public:
  constexpr Span() noexcept = default;
  constexpr Span(T* data, std::size_t size) noexcept : data_(data), size_(size) {}

  constexpr T* data() const noexcept { return data_; }
  constexpr std::size_t size() const noexcept { return size_; }
  constexpr bool empty() const noexcept { return size_ == 0; }
  constexpr T& operator[](std::size_t i) const noexcept { return data_[i]; }
  constexpr T* begin() const noexcept { return data_; }
  constexpr T* end() const noexcept { return data_ + size_; }

 private:
  T* data_ = nullptr;
  std::size_t size_ = 0;
};

}  // namespace glovepose::core
