/// @file wire_format.hpp
/// @brief The glove wire protocol, version 1 (docs/wire_protocol.md): a frame is a 24-byte header
/// with its own CRC-32, a payload of at most 4096 bytes and the payload's CRC-32, little-endian.
/// This file holds the layout, the encoder a device (or the simulator) writes frames with, and the
/// readers of each payload kind; device/frame_parser.hpp finds frames in a byte stream.
#pragma once

#include <cstddef>
#include <cstdint>
#include <cstring>
#include <string>
#include <vector>

#include "../config.hpp"
#include "../core/span.hpp"
#include "../status.hpp"
#include "crc32.hpp"

namespace glovepose::device {

/// @brief The first two bytes of every frame: 'G', 'P'.
inline constexpr std::uint8_t kMagic[2] = {0x47, 0x50};
/// @brief The protocol version this code writes and reads.
inline constexpr std::uint8_t kWireVersion = 1;
/// @brief Header bytes (magic to header CRC).
inline constexpr std::size_t kHeaderBytes = 24;
/// @brief The payload's CRC after the payload.
inline constexpr std::size_t kTrailerBytes = 4;
/// @brief The largest payload a frame may carry.
inline constexpr std::size_t kMaxPayloadBytes = 4096;
/// @brief The largest frame.
inline constexpr std::size_t kMaxFrameBytes = kHeaderBytes + kMaxPayloadBytes + kTrailerBytes;
/// @brief The longest glove id a hello carries.
inline constexpr std::size_t kMaxGloveIdBytes = 64;

/// @brief What a frame's payload holds.
enum class FrameKind : std::uint8_t {
  Hello = 1,         ///< The device names itself: serial number, rows, cells, glove id.
  Rows = 2,          ///< Readings of single rows: (row u16, offset_us u16, value f32) each.
  Measurements = 3,  ///< One whole measurement cycle: every row's reading, f32, in row order.
  Cells = 4,         ///< The glove description's inputs, f32 in its order: the cells (solved by the device) and its extra inputs.
};

/// @brief True for a kind this version defines.
constexpr bool known_kind(std::uint8_t kind) noexcept { return kind >= 1 && kind <= 4; }

/// @brief A frame's header fields.
struct FrameHeader {
  FrameKind kind = FrameKind::Hello;
  std::uint32_t sequence = 0;        ///< +1 per frame the device sends (any kind), wrapping at 2^32.
  std::uint64_t device_time_us = 0;  ///< The device's clock, microseconds since its start.
  std::uint16_t payload_bytes = 0;
};

/// @brief A whole, checked frame; the payload points into the parser's buffer, valid during the
/// callback that receives it.
struct Frame {
  FrameHeader header;
  core::Span<const std::uint8_t> payload;
  core::Span<const std::uint8_t> bytes;  ///< The whole frame as it arrived, header to payload CRC.
};

/// @brief A single row's reading in a Rows frame: taken `offset_us` after the frame's device time.
struct RowReading {
  std::uint16_t row = 0;
  std::uint16_t offset_us = 0;
  float value = 0.0F;
};
/// @brief Bytes of one RowReading on the wire.
inline constexpr std::size_t kRowReadingBytes = 8;

/// @brief What a Hello frame says.
struct Hello {
  std::uint32_t serial = 0;  ///< The device's serial number.
  std::uint16_t rows = 0;    ///< Rows of its readout (0: it sends cells).
  std::uint16_t cells = 0;   ///< Cells of its glove description.
  char glove_id[kMaxGloveIdBytes + 1] = {};  ///< The glove description's id, NUL-terminated.
};

namespace wire {
inline void put_u16(std::uint8_t* p, std::uint16_t v) noexcept {
  p[0] = static_cast<std::uint8_t>(v);
  p[1] = static_cast<std::uint8_t>(v >> 8);
}
inline void put_u32(std::uint8_t* p, std::uint32_t v) noexcept {
  for (int i = 0; i < 4; ++i) p[i] = static_cast<std::uint8_t>(v >> (8 * i));
}
inline void put_u64(std::uint8_t* p, std::uint64_t v) noexcept {
  for (int i = 0; i < 8; ++i) p[i] = static_cast<std::uint8_t>(v >> (8 * i));
}
inline void put_f32(std::uint8_t* p, float v) noexcept {
  std::uint32_t bits = 0;
  std::memcpy(&bits, &v, 4);
  put_u32(p, bits);
}
inline void put_f64(std::uint8_t* p, double v) noexcept {
  std::uint64_t bits = 0;
  std::memcpy(&bits, &v, 8);
  put_u64(p, bits);
}
inline std::uint16_t get_u16(const std::uint8_t* p) noexcept { return static_cast<std::uint16_t>(p[0] | (p[1] << 8)); }
inline std::uint32_t get_u32(const std::uint8_t* p) noexcept {
  return static_cast<std::uint32_t>(p[0]) | (static_cast<std::uint32_t>(p[1]) << 8) | (static_cast<std::uint32_t>(p[2]) << 16) |
         (static_cast<std::uint32_t>(p[3]) << 24);
}
inline std::uint64_t get_u64(const std::uint8_t* p) noexcept {
  return static_cast<std::uint64_t>(get_u32(p)) | (static_cast<std::uint64_t>(get_u32(p + 4)) << 32);
}
inline float get_f32(const std::uint8_t* p) noexcept {
  const std::uint32_t bits = get_u32(p);
  float v = 0.0F;
  std::memcpy(&v, &bits, 4);
  return v;
}
}  // namespace wire

/// @brief Reads a header from `kHeaderBytes` bytes: false unless the magic, the version, the kind,
/// the payload length and the header's CRC are all valid.
inline bool read_header(const std::uint8_t* p, FrameHeader& out) noexcept {
  if (p[0] != kMagic[0] || p[1] != kMagic[1] || p[2] != kWireVersion || !known_kind(p[3])) return false;
  if (wire::get_u32(p + 20) != crc32(p, 20)) return false;
  const std::uint16_t length = wire::get_u16(p + 16);
  if (length > kMaxPayloadBytes || wire::get_u16(p + 18) != 0) return false;
  out.kind = static_cast<FrameKind>(p[3]);
  out.sequence = wire::get_u32(p + 4);
  out.device_time_us = wire::get_u64(p + 8);
  out.payload_bytes = length;
  return true;
}

/// @brief Writes frames: the device side (a micro-controller's firmware does the same in C; the
/// simulator's stream uses this). Holds one frame's buffer and the sequence counter; set-up
/// allocates, each frame then writes into the buffer.
class FrameWriter {
 public:
  /// @brief `first_sequence`: the sequence number of the first frame.
  explicit FrameWriter(std::uint32_t first_sequence = 0) : buffer_(kMaxFrameBytes), sequence_(first_sequence) {}

  /// @brief A Hello frame; throws Error for a glove id longer than 64 bytes.
  core::Span<const std::uint8_t> hello(std::uint64_t device_time_us, std::uint32_t serial, std::uint16_t rows, std::uint16_t cells,
                                       const std::string& glove_id) {
    if (glove_id.size() > kMaxGloveIdBytes)
      throw Error("wire hello: glove id '" + glove_id + "' has " + std::to_string(glove_id.size()) + " bytes, expected at most 64");
    std::uint8_t* p = begin(FrameKind::Hello, device_time_us, 9 + glove_id.size());
    wire::put_u32(p, serial);
    wire::put_u16(p + 4, rows);
    wire::put_u16(p + 6, cells);
    p[8] = static_cast<std::uint8_t>(glove_id.size());
    std::memcpy(p + 9, glove_id.data(), glove_id.size());
    return finish();
  }

  /// @brief A Measurements or Cells frame of `count` values (at most 1024); an empty span
  /// for more values or another kind.
  core::Span<const std::uint8_t> values(FrameKind kind, std::uint64_t device_time_us, const float* values, std::size_t count) noexcept {
    if (count * 4 > kMaxPayloadBytes || kind == FrameKind::Hello || kind == FrameKind::Rows) return {};
    std::uint8_t* p = begin(kind, device_time_us, count * 4);
    for (std::size_t i = 0; i < count; ++i) wire::put_f32(p + 4 * i, values[i]);
    return finish();
  }

  /// @brief A Rows frame of `count` readings (at most 512); an empty span for more.
  core::Span<const std::uint8_t> rows(std::uint64_t device_time_us, const RowReading* readings, std::size_t count) noexcept {
    if (count * kRowReadingBytes > kMaxPayloadBytes) return {};
    std::uint8_t* p = begin(FrameKind::Rows, device_time_us, count * kRowReadingBytes);
    for (std::size_t i = 0; i < count; ++i, p += kRowReadingBytes) {
      wire::put_u16(p, readings[i].row);
      wire::put_u16(p + 2, readings[i].offset_us);
      wire::put_f32(p + 4, readings[i].value);
    }
    return finish();
  }

  /// @brief The sequence number the next frame gets.
  std::uint32_t next_sequence() const noexcept { return sequence_; }

 private:
  std::uint8_t* begin(FrameKind kind, std::uint64_t device_time_us, std::size_t payload_bytes) noexcept {
    std::uint8_t* h = buffer_.data();
    h[0] = kMagic[0];
    h[1] = kMagic[1];
    h[2] = kWireVersion;
    h[3] = static_cast<std::uint8_t>(kind);
    wire::put_u32(h + 4, sequence_++);
    wire::put_u64(h + 8, device_time_us);
    wire::put_u16(h + 16, static_cast<std::uint16_t>(payload_bytes));
    wire::put_u16(h + 18, 0);
    wire::put_u32(h + 20, crc32(h, 20));
    payload_bytes_ = payload_bytes;
    return h + kHeaderBytes;
  }

  core::Span<const std::uint8_t> finish() noexcept {
    std::uint8_t* payload = buffer_.data() + kHeaderBytes;
    wire::put_u32(payload + payload_bytes_, crc32(payload, payload_bytes_));
    return {buffer_.data(), kHeaderBytes + payload_bytes_ + kTrailerBytes};
  }

  std::vector<std::uint8_t> buffer_;
  std::uint32_t sequence_;
  std::size_t payload_bytes_ = 0;
};

/// @brief The `count` f32 values of a Measurements or Cells frame into `out`; SizeMismatch
/// unless the payload holds exactly `count` values. Values are copied as sent (a NaN stays a NaN:
/// the estimator answers it).
GLOVEPOSE_REALTIME inline Status read_values(const Frame& frame, float* out, std::size_t count) noexcept {
  if (frame.payload.size() != count * 4) return Status::SizeMismatch;
  for (std::size_t i = 0; i < count; ++i) out[i] = wire::get_f32(frame.payload.data() + 4 * i);
  return Status::Ok;
}

/// @brief The readings of a Rows frame, in order, to `on_row(const RowReading&)`; SizeMismatch for
/// a payload that is not a whole number of readings (nothing is passed on then).
template <typename OnRow>
GLOVEPOSE_REALTIME Status read_rows(const Frame& frame, OnRow&& on_row) noexcept {
  if (frame.payload.size() % kRowReadingBytes != 0) return Status::SizeMismatch;
  for (std::size_t at = 0; at < frame.payload.size(); at += kRowReadingBytes) {
    const std::uint8_t* p = frame.payload.data() + at;
    on_row(RowReading{wire::get_u16(p), wire::get_u16(p + 2), wire::get_f32(p + 4)});
  }
  return Status::Ok;
}

/// @brief A Hello frame's fields; SizeMismatch when its length does not match its id's length.
GLOVEPOSE_REALTIME inline Status read_hello(const Frame& frame, Hello& out) noexcept {
  const core::Span<const std::uint8_t>& p = frame.payload;
  if (p.size() < 9 || p[8] > kMaxGloveIdBytes || p.size() != 9U + p[8]) return Status::SizeMismatch;
  out.serial = wire::get_u32(p.data());
  out.rows = wire::get_u16(p.data() + 4);
  out.cells = wire::get_u16(p.data() + 6);
  std::memcpy(out.glove_id, p.data() + 9, p[8]);
  out.glove_id[p[8]] = '\0';
  return Status::Ok;
}

}  // namespace glovepose::device
