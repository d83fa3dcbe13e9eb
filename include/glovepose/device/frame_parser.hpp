/// @file frame_parser.hpp
/// @brief Finds the wire protocol's frames (device/wire_format.hpp) in a byte stream that arrives in
/// pieces of any size, checks them and their order, and counts what it could not use: bytes that
/// were no frame, broken headers and payloads, frames lost, duplicated or late. Only whole, checked,
/// new frames reach the caller, in increasing sequence order: a duplicate or a frame overtaken by a
/// later one is counted and dropped, so no pose is ever made of it. The per-frame path: noexcept,
/// no allocation after construction.
#pragma once

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <vector>

#include "../config.hpp"
#include "wire_format.hpp"

namespace glovepose::device {

/// @brief What a FrameParser saw, since its construction.
struct LinkCounts {
  std::uint64_t bytes = 0;           ///< Bytes fed: frame_bytes + skipped_bytes + truncated_bytes + pending_bytes().
  std::uint64_t frames = 0;          ///< Frames passed on (whole, checked, new).
  std::uint64_t frame_bytes = 0;     ///< Bytes of whole, checked frames (passed on, or dropped for their order).
  std::uint64_t skipped_bytes = 0;   ///< Bytes that began no valid frame (noise, the rest of a broken frame).
  std::uint64_t bad_headers = 0;     ///< Headers found broken: CRC, version, kind or length.
  std::uint64_t bad_payloads = 0;    ///< Frames whose payload CRC failed (corrupted or cut short by the next frame).
  std::uint64_t lost = 0;            ///< Sequence numbers skipped and not seen since.
  std::uint64_t duplicates = 0;      ///< Frames whose sequence number was already passed on.
  std::uint64_t late = 0;            ///< Frames that arrived after a later one (reordered): dropped.
  std::uint64_t restarts = 0;        ///< The device began a new sequence (a Hello, or a jump back beyond the window).
  std::uint64_t truncated_bytes = 0; ///< Bytes of an unfinished frame at finish().
};

/// @brief Incremental frame finder and order checker for one device's stream.
class FrameParser {
 public:
  /// @brief Frames further back than this many sequence numbers count as a restart, not as late.
  static constexpr std::uint32_t kWindow = 64;

  FrameParser() : buffer_(2 * kMaxFrameBytes) {}

  /// @brief Takes `size` more bytes; calls `on_frame(const Frame&)` for each whole, checked, new frame.
  template <typename OnFrame>
  GLOVEPOSE_REALTIME void feed(const std::uint8_t* data, std::size_t size, OnFrame&& on_frame) noexcept {
    counts_.bytes += size;
    while (size > 0) {
      const std::size_t take = std::min(size, buffer_.size() - used_);
      std::memcpy(buffer_.data() + used_, data, take);
      used_ += take;
      data += take;
      size -= take;
      scan(on_frame);
    }
  }

  /// @brief The stream ended (or the link was lost): what is left of an unfinished frame is counted
  /// and dropped; the sequence history is kept, so frames lost across a reconnection are counted.
  void finish() noexcept {
    counts_.truncated_bytes += used_;
    used_ = 0;
  }

  /// @brief Forgets the device's sequence history (a new device on the link); the counts stay.
  void forget_sequence() noexcept { started_ = false; }

  /// @brief Bytes held for a frame not yet whole.
  std::size_t pending_bytes() const noexcept { return used_; }

  /// @brief What the parser has seen.
  const LinkCounts& counts() const noexcept { return counts_; }

 private:
  template <typename OnFrame>
  void scan(OnFrame& on_frame) noexcept {
    std::size_t at = 0;
    while (used_ > at) {
      const std::uint8_t* p = buffer_.data() + at;
      if (p[0] == kMagic[0] && used_ - at < 2) break;  // a lone 'G' may begin a frame: wait for the next byte
      if (p[0] != kMagic[0] || p[1] != kMagic[1]) {  // not a frame's start: skip to the next candidate
        const void* next = std::memchr(p + 1, kMagic[0], used_ - at - 1);
        const std::size_t skip = next != nullptr ? static_cast<std::size_t>(static_cast<const std::uint8_t*>(next) - p) : used_ - at;
        counts_.skipped_bytes += skip;
        at += skip;
        continue;
      }
      if (used_ - at < kHeaderBytes) break;
      FrameHeader header;
      if (!read_header(p, header)) {
        ++counts_.bad_headers;
        ++counts_.skipped_bytes;
        ++at;
        continue;
      }
      const std::size_t whole = kHeaderBytes + header.payload_bytes + kTrailerBytes;
      if (used_ - at < whole) break;
      const std::uint8_t* payload = p + kHeaderBytes;
      if (wire::get_u32(payload + header.payload_bytes) != crc32(payload, header.payload_bytes)) {
        ++counts_.bad_payloads;  // the rest of it is searched again: a frame cut short hides the next one's start
        ++counts_.skipped_bytes;
        ++at;
        continue;
      }
      at += whole;
      counts_.frame_bytes += whole;
      if (admit(header)) {
        ++counts_.frames;
        on_frame(Frame{header, {payload, header.payload_bytes}, {p, whole}});
      }
    }
    if (at > 0) {
      std::memmove(buffer_.data(), buffer_.data() + at, used_ - at);
      used_ -= at;
    }
  }

  // Sequence numbers in serial-number arithmetic with a window of the last 64, as a replay
  // window does: true for a frame newer than every one before it.
  bool admit(const FrameHeader& header) noexcept {
    const auto ahead = static_cast<std::int32_t>(header.sequence - highest_);
    // A Hello ahead in sequence and in device time is the same device after a reconnection: its
    // sequence goes on and the frames sent meanwhile are lost. Any other Hello is a restart.
    if (header.kind == FrameKind::Hello && started_ && (ahead <= 0 || header.device_time_us < highest_time_us_)) {
      ++counts_.restarts;
      started_ = false;
    }
    if (!started_) {
      started_ = true;
      highest_ = header.sequence;
      highest_time_us_ = header.device_time_us;
      seen_ = 1;
      return true;
    }
    if (ahead > 0) {
      counts_.lost += static_cast<std::uint32_t>(ahead) - 1;
      seen_ = static_cast<std::uint32_t>(ahead) >= kWindow ? 1 : (seen_ << ahead) | 1;
      highest_ = header.sequence;
      highest_time_us_ = header.device_time_us;
      return true;
    }
    const auto behind = static_cast<std::uint32_t>(-static_cast<std::int64_t>(ahead));
    if (behind < kWindow) {
      const std::uint64_t bit = std::uint64_t{1} << behind;
      if ((seen_ & bit) != 0) {
        ++counts_.duplicates;
      } else {  // it was counted lost when the later frame came
        ++counts_.late;
        if (counts_.lost > 0) --counts_.lost;
        seen_ |= bit;
      }
      return false;
    }
    ++counts_.restarts;  // far behind: the device began again without a Hello
    highest_ = header.sequence;
    highest_time_us_ = header.device_time_us;
    seen_ = 1;
    return true;
  }

  std::vector<std::uint8_t> buffer_;
  std::size_t used_ = 0;
  LinkCounts counts_;
  bool started_ = false;
  std::uint32_t highest_ = 0;
  std::uint64_t highest_time_us_ = 0;  // the device time of the frame with the highest sequence
  std::uint64_t seen_ = 0;
};

}  // namespace glovepose::device
