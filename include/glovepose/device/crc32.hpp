/// @file crc32.hpp
/// @brief CRC-32 as zlib, PNG and Ethernet compute it (reflected polynomial 0xEDB88320, initial and
/// final XOR 0xFFFFFFFF; check value 0xCBF43926 for "123456789"): the wire protocol's frame check.
/// A table of 256 words, built at compile time; no allocation.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>

namespace glovepose::device {

namespace detail {
constexpr std::array<std::uint32_t, 256> crc32_table() noexcept {
  std::array<std::uint32_t, 256> table{};
  for (std::uint32_t i = 0; i < 256; ++i) {
    std::uint32_t c = i;
    for (int bit = 0; bit < 8; ++bit) c = (c & 1U) != 0 ? 0xEDB88320U ^ (c >> 1) : c >> 1;
    table[i] = c;
  }
  return table;
}
inline constexpr std::array<std::uint32_t, 256> kCrc32Table = crc32_table();
}  // namespace detail

/// @brief The CRC-32 of `size` bytes at `data`; `crc` continues a previous call's result.
inline std::uint32_t crc32(const std::uint8_t* data, std::size_t size, std::uint32_t crc = 0) noexcept {
  crc = ~crc;
  for (std::size_t i = 0; i < size; ++i) crc = detail::kCrc32Table[(crc ^ data[i]) & 0xFFU] ^ (crc >> 8);
  return ~crc;
}

}  // namespace glovepose::device
