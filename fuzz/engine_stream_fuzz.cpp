/// @file engine_stream_fuzz.cpp
/// @brief Fuzz target: bytes a service sends to the engine stream's C client
/// (bindings/c/glovepose_stream.h, docs/pose_stream.md), written into a socket pair in pieces whose
/// sizes the input's first two bytes choose, the client reading after each piece without waiting.
///
/// Invariants: the client gives, in order, exactly the poses of the stream's consecutive 248-byte
/// messages up to the first bad one, each field equal to the message's bytes (little-endian, read
/// here by memcpy on this little-endian host); a message is bad exactly when its magic, version,
/// hand, count or CRC (the library's device::crc32) is wrong, and the client then says so; bytes that
/// end mid-message are never a pose; the end of the stream is told as closed.
#include <fuzzer/FuzzedDataProvider.h>

#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <cstdint>
#include <cstring>
#include <vector>

#include <glovepose/device/crc32.hpp>

#define GLOVEPOSE_STREAM_IMPLEMENTATION
#include "glovepose_stream.h"

#include "fuzz_check.hpp"

namespace {

// Whether `m` (248 bytes) is a good message, by docs/pose_stream.md's table.
bool good_message(const std::uint8_t* m) {
  std::uint16_t count = 0;
  std::uint32_t crc = 0;
  std::memcpy(&count, m + 40, 2);
  std::memcpy(&crc, m + 244, 4);
  return m[0] == 'G' && m[1] == 'H' && m[2] == 1 && m[3] <= 1 && count == 25 && crc == glovepose::device::crc32(m, 244);
}

bool same_pose(const gp_stream_pose& p, const std::uint8_t* m) {
  std::uint32_t flags = 0;
  std::uint64_t sequence = 0;
  double times[3] = {};
  double angles[GP_STREAM_ANGLES] = {};
  std::memcpy(&flags, m + 4, 4);
  std::memcpy(&sequence, m + 8, 8);
  std::memcpy(times, m + 16, sizeof times);
  std::memcpy(angles, m + 44, sizeof angles);
  // Bit for bit (NaNs included): compare the bytes, not the values.
  return p.hand == m[3] && p.flags == flags && p.sequence == sequence && std::memcmp(&p.stream_time, &times[0], 8) == 0 &&
         std::memcmp(&p.host_time, &times[1], 8) == 0 && std::memcmp(&p.published, &times[2], 8) == 0 &&
         std::memcmp(p.angles, angles, sizeof angles) == 0;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  FuzzedDataProvider input(data, size);
  const std::uint16_t piece_seed = input.ConsumeIntegral<std::uint16_t>();
  const std::vector<std::uint8_t> bytes = input.ConsumeRemainingBytes<std::uint8_t>();

  // The poses the client must give: the good messages before the first bad one.
  std::vector<const std::uint8_t*> expected;
  bool bad_at_end = false;
  for (std::size_t at = 0; at + GP_STREAM_MESSAGE_BYTES <= bytes.size(); at += GP_STREAM_MESSAGE_BYTES) {
    if (!good_message(bytes.data() + at)) {
      bad_at_end = true;
      break;
    }
    expected.push_back(bytes.data() + at);
  }

  int pair[2];
  GLOVEPOSE_FUZZ_REQUIRE(socketpair(AF_UNIX, SOCK_STREAM, 0, pair) == 0);
  gp_stream stream;
  stream.socket = pair[0];
  stream.have = 0;
  std::size_t got = 0, sent = 0;
  bool stopped = false;  // the client said a message was bad: it would reconnect
  gp_stream_pose pose;
  // Reads what has arrived; the status that ended the reading (NONE, CLOSED or BAD_MESSAGE).
  const auto read_waiting = [&] {
    for (;;) {
      const gp_stream_status s = gp_stream_read(&stream, &pose, 0);
      if (s == GP_STREAM_NONE || s == GP_STREAM_CLOSED) return s;
      if (s == GP_STREAM_BAD_MESSAGE) {
        GLOVEPOSE_FUZZ_REQUIRE(bad_at_end && got == expected.size());
        stopped = true;
        return s;
      }
      GLOVEPOSE_FUZZ_REQUIRE(s == GP_STREAM_POSE);
      GLOVEPOSE_FUZZ_REQUIRE(got < expected.size() && same_pose(pose, expected[got]));
      ++got;
    }
  };
  unsigned seed = piece_seed;
  while (sent < bytes.size() && !stopped) {
    const std::size_t piece = std::min<std::size_t>(bytes.size() - sent, 1 + seed % 300);
    seed = seed * 1103515245u + 12345u;
    GLOVEPOSE_FUZZ_REQUIRE(write(pair[1], bytes.data() + sent, piece) == static_cast<ssize_t>(piece));
    sent += piece;
    GLOVEPOSE_FUZZ_REQUIRE(read_waiting() != GP_STREAM_CLOSED);  // the service is still there
  }
  close(pair[1]);
  if (!stopped) {
    const gp_stream_status end = read_waiting();
    GLOVEPOSE_FUZZ_REQUIRE(stopped || end == GP_STREAM_CLOSED);  // the end is told as closed, never as a pose
  }
  GLOVEPOSE_FUZZ_REQUIRE(got == expected.size());
  GLOVEPOSE_FUZZ_REQUIRE(stopped == bad_at_end);
  gp_stream_close(&stream);
  return 0;
}
