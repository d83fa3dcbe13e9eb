// Frames out of a byte stream for the tool's commands: the parser fed with work that may throw, and
// the link's counts in one line.
#pragma once

#include <glovepose/device/frame_parser.hpp>

#include <cstddef>
#include <cstdint>
#include <exception>
#include <string>

namespace glovepose::cli {

/// Feeds `size` bytes to `parser`, calling `use(const device::Frame&)` for each frame passed on.
/// The parser's callback is noexcept, so an exception `use` throws waits there (later frames of the
/// same bytes are not used) and is thrown again once feed() returns.
template <typename Use>
void feed_frames(device::FrameParser& parser, const std::uint8_t* data, std::size_t size, Use&& use) {
  std::exception_ptr failed;
  parser.feed(data, size, [&](const device::Frame& f) noexcept {
    if (failed) return;
    try {
      use(f);
    } catch (...) {
      failed = std::current_exception();
    }
  });
  if (failed) std::rethrow_exception(failed);
}

/// The link's counts as one line ("1200 frames; 0 bytes skipped, ...").
inline std::string link_summary(const device::LinkCounts& c) {
  return std::to_string(c.frames) + " frames passed on; " + std::to_string(c.skipped_bytes) + " bytes skipped, " +
         std::to_string(c.bad_headers) + " bad headers, " + std::to_string(c.bad_payloads) + " bad payloads, " + std::to_string(c.lost) +
         " lost, " + std::to_string(c.duplicates) + " duplicated, " + std::to_string(c.late) + " late, " + std::to_string(c.restarts) +
         " restarts, " + std::to_string(c.truncated_bytes) + " bytes of a frame cut off at the end";
}

}  // namespace glovepose::cli
