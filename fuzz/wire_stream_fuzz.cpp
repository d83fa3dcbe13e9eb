/// @file wire_stream_fuzz.cpp
/// @brief Fuzz target: bytes read as a glove's wire stream (device/frame_parser.hpp,
/// docs/wire_protocol.md), fed once whole and once in pieces whose sizes the input's first bytes
/// choose; every frame passed on is read by the payload reader of its kind and its device time goes
/// into a DeviceClock.
///
/// Invariants: both feeds pass on the same frames and count the same (the pieces change nothing);
/// every frame passed on has a known kind, a payload of at most 4096 bytes, a sequence number newer
/// than the last one's unless the counts show a restart; every byte is accounted for (fed = in
/// frames + skipped + truncated at the end); the payload readers answer Ok or SizeMismatch; the
/// clock maps a device time to a finite host time.
#include <fuzzer/FuzzedDataProvider.h>

#include <cstdint>
#include <vector>

#include <glovepose/device/device_clock.hpp>
#include <glovepose/device/frame_parser.hpp>

#include "fuzz_check.hpp"

namespace {

struct Seen {
  glovepose::device::FrameHeader header;
  std::vector<std::uint8_t> payload;
};

bool same(const Seen& a, const Seen& b) {
  return a.header.kind == b.header.kind && a.header.sequence == b.header.sequence && a.header.device_time_us == b.header.device_time_us &&
         a.payload == b.payload;
}

bool same(const glovepose::device::LinkCounts& a, const glovepose::device::LinkCounts& b) {
  return a.bytes == b.bytes && a.frames == b.frames && a.frame_bytes == b.frame_bytes && a.skipped_bytes == b.skipped_bytes &&
         a.bad_headers == b.bad_headers && a.bad_payloads == b.bad_payloads && a.lost == b.lost && a.duplicates == b.duplicates &&
         a.late == b.late && a.restarts == b.restarts && a.truncated_bytes == b.truncated_bytes;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace glovepose;
  FuzzedDataProvider input(data, size);
  const std::uint16_t piece_seed = input.ConsumeIntegral<std::uint16_t>();
  const std::vector<std::uint8_t> stream = input.ConsumeRemainingBytes<std::uint8_t>();

  std::vector<Seen> whole, pieces;
  device::DeviceClock clock;
  std::uint64_t restarts_seen = 0;
  bool have_last = false;
  std::uint32_t last = 0;
  const auto check = [&](const device::Frame& f, const device::FrameParser& parser, std::vector<Seen>& out) {
    GLOVEPOSE_FUZZ_REQUIRE(device::known_kind(static_cast<std::uint8_t>(f.header.kind)));
    GLOVEPOSE_FUZZ_REQUIRE(f.payload.size() == f.header.payload_bytes && f.payload.size() <= device::kMaxPayloadBytes);
    GLOVEPOSE_FUZZ_REQUIRE(f.bytes.size() == device::kHeaderBytes + f.payload.size() + device::kTrailerBytes &&
                           f.bytes.data() + device::kHeaderBytes == f.payload.data());
    out.push_back(Seen{f.header, std::vector<std::uint8_t>(f.payload.begin(), f.payload.end())});
    if (&out == &whole) {
      const bool restarted = parser.counts().restarts != restarts_seen || f.header.kind == device::FrameKind::Hello;
      GLOVEPOSE_FUZZ_REQUIRE(!have_last || restarted || static_cast<std::int32_t>(f.header.sequence - last) > 0);
      restarts_seen = parser.counts().restarts;
      have_last = true;
      last = f.header.sequence;
      float values[1024];
      const Status read = f.header.kind == device::FrameKind::Rows    ? device::read_rows(f, [](const device::RowReading&) {})
                          : f.header.kind == device::FrameKind::Hello ? [&] {
                              device::Hello hello;
                              return device::read_hello(f, hello);
                            }()
                                                                      : device::read_values(f, values, f.payload.size() / 4);
      GLOVEPOSE_FUZZ_REQUIRE(read == Status::Ok || read == Status::SizeMismatch);
      clock.add(f.header.device_time_us, 100.0 + 1e-3 * static_cast<double>(out.size()));
      GLOVEPOSE_FUZZ_REQUIRE(std::isfinite(clock.to_host(f.header.device_time_us)));
    }
  };

  device::FrameParser one;
  one.feed(stream.data(), stream.size(), [&](const device::Frame& f) { check(f, one, whole); });
  one.finish();

  device::FrameParser many;
  std::uint32_t state = piece_seed;
  for (std::size_t at = 0; at < stream.size();) {
    state = state * 1103515245U + 12345U;  // piece sizes 1 .. 64 from the seed
    const std::size_t piece = std::min<std::size_t>(stream.size() - at, 1 + (state >> 16) % 64);
    many.feed(stream.data() + at, piece, [&](const device::Frame& f) { check(f, many, pieces); });
    at += piece;
  }
  many.finish();

  GLOVEPOSE_FUZZ_REQUIRE(whole.size() == pieces.size());
  for (std::size_t i = 0; i < whole.size(); ++i) GLOVEPOSE_FUZZ_REQUIRE(same(whole[i], pieces[i]));
  const device::LinkCounts& c = one.counts();
  GLOVEPOSE_FUZZ_REQUIRE(same(c, many.counts()));
  GLOVEPOSE_FUZZ_REQUIRE(c.bytes == stream.size() && c.frames == whole.size());
  GLOVEPOSE_FUZZ_REQUIRE(c.bytes == c.frame_bytes + c.skipped_bytes + c.truncated_bytes);
  return 0;
}
