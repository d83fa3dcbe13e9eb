// The glove wire protocol (docs/wire_protocol.md): CRC-32 against its published check values, a
// frame against the bytes the document lays out, the parser on streams cut, corrupted, duplicated
// and reordered against what was sent, and the device clock against a known true clock.
#include <doctest/doctest.h>

#include <glovepose/core/random.hpp>
#include <glovepose/device/device_clock.hpp>
#include <glovepose/device/frame_parser.hpp>
#include <glovepose/device/wire_format.hpp>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <map>
#include <string>
#include <vector>

#include "alloc_counter.hpp"

namespace {

using namespace glovepose;
using Bytes = std::vector<std::uint8_t>;

Bytes as_bytes(core::Span<const std::uint8_t> frame) { return Bytes(frame.begin(), frame.end()); }

// A sent frame as the parser should pass it on.
struct Sent {
  device::FrameKind kind;
  std::uint64_t time;
  Bytes payload;
};

// Frames of every kind with random contents, and the stream of all of them.
struct Stream {
  std::map<std::uint32_t, Sent> sent;
  std::vector<Bytes> frames;
};

Stream make_stream(int count, std::uint64_t seed, std::uint32_t first_sequence = 0) {
  core::Rng rng(seed);
  device::FrameWriter writer(first_sequence);
  Stream s;
  for (int i = 0; i < count; ++i) {
    const std::uint64_t time = 1000000 + 16667ULL * static_cast<std::uint64_t>(i);
    const std::uint32_t sequence = writer.next_sequence();
    core::Span<const std::uint8_t> frame;
    const int kind = rng.index(3);
    if (kind == 0) {
      std::vector<device::RowReading> rows(static_cast<std::size_t>(1 + rng.index(16)));
      for (auto& r : rows) r = {static_cast<std::uint16_t>(rng.index(180)), static_cast<std::uint16_t>(rng.index(2000)), static_cast<float>(rng.uniform(0, 40))};
      frame = writer.rows(time, rows.data(), rows.size());
    } else {
      const device::FrameKind k = kind == 1 ? device::FrameKind::Measurements : device::FrameKind::Cells;
      std::vector<float> values(static_cast<std::size_t>(kind == 1 ? 180 : 44));
      for (float& v : values) v = static_cast<float>(rng.uniform(-5, 40));
      frame = writer.values(k, time, values.data(), values.size());
    }
    REQUIRE(frame.size() > 0);
    s.frames.push_back(as_bytes(frame));
    s.sent[sequence] = Sent{static_cast<device::FrameKind>(frame[3]), time, Bytes(frame.begin() + 24, frame.end() - 4)};
  }
  return s;
}

// Feeds `bytes` in random pieces of 1 to 300 bytes; every frame passed on must be one sent, unchanged.
std::vector<std::uint32_t> parse(device::FrameParser& parser, const Bytes& bytes, const Stream& s, std::uint64_t seed) {
  core::Rng rng(seed);
  std::vector<std::uint32_t> got;
  std::size_t at = 0;
  while (at < bytes.size()) {
    const std::size_t piece = std::min<std::size_t>(bytes.size() - at, static_cast<std::size_t>(1 + rng.index(300)));
    parser.feed(bytes.data() + at, piece, [&](const device::Frame& f) {
      const auto it = s.sent.find(f.header.sequence);  // CHECK, not REQUIRE: feed() is noexcept
      if (it == s.sent.end()) {
        FAIL_CHECK("a frame that was never sent: sequence ", f.header.sequence);
        return;
      }
      CHECK(f.header.kind == it->second.kind);
      CHECK(f.header.device_time_us == it->second.time);
      CHECK(Bytes(f.payload.begin(), f.payload.end()) == it->second.payload);
      CHECK(f.bytes.size() == 28 + it->second.payload.size());
      CHECK(Bytes(f.bytes.begin() + 24, f.bytes.end() - 4) == it->second.payload);
      got.push_back(f.header.sequence);
    });
    at += piece;
  }
  return got;
}

Bytes join(const std::vector<Bytes>& frames) {
  Bytes all;
  for (const Bytes& f : frames) all.insert(all.end(), f.begin(), f.end());
  return all;
}

}  // namespace

TEST_CASE("CRC-32 gives the published check values") {
  const std::string check = "123456789", fox = "The quick brown fox jumps over the lazy dog";
  CHECK(device::crc32(reinterpret_cast<const std::uint8_t*>(check.data()), check.size()) == 0xCBF43926U);
  CHECK(device::crc32(reinterpret_cast<const std::uint8_t*>(fox.data()), fox.size()) == 0x414FA339U);
  CHECK(device::crc32(nullptr, 0) == 0U);
  // continued over two pieces, as over one
  CHECK(device::crc32(reinterpret_cast<const std::uint8_t*>(check.data()) + 4, 5,
                      device::crc32(reinterpret_cast<const std::uint8_t*>(check.data()), 4)) == 0xCBF43926U);
}

TEST_CASE("a frame is the bytes docs/wire_protocol.md lays out") {
  device::FrameWriter writer(7);
  const float values[2] = {1.0F, -2.5F};
  const Bytes frame = as_bytes(writer.values(device::FrameKind::Measurements, 1000000, values, 2));
  // magic 'G' 'P', version 1, kind 3; sequence 7; device time 1,000,000 us; 8 payload bytes; 0
  Bytes expected = {0x47, 0x50, 0x01, 0x03, 0x07, 0x00, 0x00, 0x00, 0x40, 0x42, 0x0F, 0x00,
                    0x00, 0x00, 0x00, 0x00, 0x08, 0x00, 0x00, 0x00};
  const std::uint32_t header_crc = device::crc32(expected.data(), 20);
  for (int i = 0; i < 4; ++i) expected.push_back(static_cast<std::uint8_t>(header_crc >> (8 * i)));
  const Bytes payload = {0x00, 0x00, 0x80, 0x3F, 0x00, 0x00, 0x20, 0xC0};  // IEEE 754 binary32, little-endian
  expected.insert(expected.end(), payload.begin(), payload.end());
  const std::uint32_t payload_crc = device::crc32(payload.data(), payload.size());
  for (int i = 0; i < 4; ++i) expected.push_back(static_cast<std::uint8_t>(payload_crc >> (8 * i)));
  CHECK(frame == expected);
  CHECK(writer.next_sequence() == 8);

  // a row reading: row 179, 1250 us after the frame's time, 12.5
  const device::RowReading row{179, 1250, 12.5F};
  const Bytes rows = as_bytes(writer.rows(5, &row, 1));
  CHECK(Bytes(rows.begin() + 24, rows.end() - 4) == Bytes{0xB3, 0x00, 0xE2, 0x04, 0x00, 0x00, 0x48, 0x41});
  CHECK(rows[3] == 2);

  const Bytes hello = as_bytes(writer.hello(0, 0x01020304U, 180, 44, "glauser2019"));
  CHECK(Bytes(hello.begin() + 24, hello.begin() + 33) == Bytes{0x04, 0x03, 0x02, 0x01, 0xB4, 0x00, 0x2C, 0x00, 11});
  CHECK(std::string(hello.begin() + 33, hello.end() - 4) == "glauser2019");
  CHECK_THROWS_WITH_AS(writer.hello(0, 1, 180, 44, std::string(65, 'x')), doctest::Contains("expected at most 64"), Error);
  std::vector<float> too_many(1025, 0.0F);
  CHECK(writer.values(device::FrameKind::Cells, 0, too_many.data(), too_many.size()).empty());
}

TEST_CASE("the payload readers give back what was written and refuse a wrong size") {
  device::FrameWriter writer;
  device::FrameParser parser;
  std::vector<device::Frame> frames;
  Bytes all;
  const float cells[3] = {0.25F, std::nanf(""), 7.0F};
  const device::RowReading rows[2] = {{3, 0, 1.5F}, {4, 700, 2.5F}};
  for (const Bytes& f : {as_bytes(writer.hello(0, 42, 0, 3, "my-glove")), as_bytes(writer.values(device::FrameKind::Cells, 10, cells, 3)),
                         as_bytes(writer.rows(20, rows, 2))})
    all.insert(all.end(), f.begin(), f.end());
  int seen = 0;
  parser.feed(all.data(), all.size(), [&](const device::Frame& f) {
    ++seen;
    if (f.header.kind == device::FrameKind::Hello) {
      device::Hello hello;
      CHECK(device::read_hello(f, hello) == Status::Ok);
      CHECK(hello.serial == 42);
      CHECK(hello.rows == 0);
      CHECK(hello.cells == 3);
      CHECK(std::string(hello.glove_id) == "my-glove");
    } else if (f.header.kind == device::FrameKind::Cells) {
      float out[3] = {};
      CHECK(device::read_values(f, out, 2) == Status::SizeMismatch);
      CHECK(device::read_values(f, out, 3) == Status::Ok);
      CHECK(out[0] == 0.25F);
      CHECK(std::isnan(out[1]));
      CHECK(out[2] == 7.0F);
    } else {
      std::vector<device::RowReading> got;
      CHECK(device::read_rows(f, [&](const device::RowReading& r) { got.push_back(r); }) == Status::Ok);
      CHECK(got.size() == 2);
      CHECK((got.size() == 2 && got[1].row == 4 && got[1].offset_us == 700 && got[1].value == 2.5F));
      device::Frame cut = f;
      cut.payload = {f.payload.data(), 12};
      CHECK(device::read_rows(cut, [&](const device::RowReading&) { FAIL_CHECK("a reading of a cut payload"); }) == Status::SizeMismatch);
      device::Hello hello;
      CHECK(device::read_hello(f, hello) == Status::SizeMismatch);
    }
  });
  CHECK(seen == 3);
}

TEST_CASE("a whole stream fed in pieces of any size comes out frame for frame, without allocating") {
  const Stream s = make_stream(3000, 11);
  const Bytes all = join(s.frames);
  device::FrameParser parser;
  std::vector<std::uint32_t> got;
  got.reserve(s.frames.size());
  const std::size_t allocations = test::allocations_during([&] {
    core::Rng rng(5);
    std::size_t at = 0;
    while (at < all.size()) {
      const std::size_t piece = std::min<std::size_t>(all.size() - at, static_cast<std::size_t>(1 + rng.index(5000)));
      parser.feed(all.data() + at, piece, [&](const device::Frame& f) { got.push_back(f.header.sequence); });
      at += piece;
    }
  });
  CHECK(allocations == 0);
  REQUIRE(got.size() == 3000);
  for (std::uint32_t i = 0; i < 3000; ++i) CHECK(got[i] == i);
  const device::LinkCounts& c = parser.counts();
  CHECK(c.frames == 3000);
  CHECK(c.bytes == all.size());
  CHECK(c.skipped_bytes + c.bad_headers + c.bad_payloads + c.lost + c.duplicates + c.late + c.restarts == 0);
  CHECK(c.frame_bytes == all.size());
}

TEST_CASE("one byte in 10,000 flipped: every damaged frame is dropped and counted, no other is lost") {
  const Stream s = make_stream(20000, 12);
  Bytes all = join(s.frames);
  core::Rng rng(13);
  // flip bytes at random (never in the last frame, whose loss no later frame could reveal)
  const std::size_t last_start = all.size() - s.frames.back().size();
  std::vector<bool> damaged(s.frames.size(), false);
  std::size_t flips = 0, frame = 0, frame_end = s.frames[0].size();
  for (std::size_t i = 0; i < last_start; ++i) {
    while (i >= frame_end) frame_end += s.frames[++frame].size();
    if (rng.bernoulli(1e-4)) {
      all[i] ^= static_cast<std::uint8_t>(1 + rng.index(255));
      damaged[frame] = true;
      ++flips;
    }
  }
  std::size_t damaged_frames = 0;
  for (bool d : damaged) damaged_frames += d;
  REQUIRE(flips > 100);
  device::FrameParser parser;
  const std::vector<std::uint32_t> got = parse(parser, all, s, 14);  // every frame passed on equals the one sent
  std::vector<bool> delivered(s.frames.size(), false);
  for (std::uint32_t q : got) delivered[q] = true;
  for (std::size_t i = 0; i < s.frames.size(); ++i) CHECK_MESSAGE(delivered[i] == !damaged[i], "frame ", i);
  const device::LinkCounts& c = parser.counts();
  CHECK(c.frames == s.frames.size() - damaged_frames);
  CHECK(c.lost == damaged_frames);
  CHECK(c.bad_headers + c.bad_payloads > 0);  // a frame whose magic was hit is skipped as noise, with no bad header
  CHECK(c.skipped_bytes > 0);
  CHECK(c.duplicates + c.late + c.restarts == 0);
  MESSAGE(flips, " bytes flipped, ", damaged_frames, " frames damaged; bad headers ", c.bad_headers, ", bad payloads ", c.bad_payloads,
          ", skipped bytes ", c.skipped_bytes);
}

TEST_CASE("cut, duplicated and reordered frames are counted and never passed on") {
  const Stream s = make_stream(12, 21);
  std::vector<Bytes> frames = s.frames;
  frames[3].resize(frames[3].size() / 2);  // frame 3 cut short: frame 4 follows straight after
  // sent order: 0 1 2 3(cut) 4 5 5 7 6 8 9 10 11 ... 11 cut at the end
  std::vector<Bytes> order = {frames[0], frames[1], frames[2], frames[3], frames[4], frames[5], frames[5],
                              frames[7], frames[6], frames[8], frames[9], frames[10]};
  order.push_back(Bytes(frames[11].begin(), frames[11].begin() + 30));
  device::FrameParser parser;
  const std::vector<std::uint32_t> got = parse(parser, join(order), s, 22);
  CHECK(got == std::vector<std::uint32_t>{0, 1, 2, 4, 5, 7, 8, 9, 10});
  parser.finish();
  const device::LinkCounts& c = parser.counts();
  CHECK(c.lost == 1);        // 3 (6 came late, so it is not lost)
  CHECK(c.duplicates == 1);  // the second 5
  CHECK(c.late == 1);        // 6, after 7
  CHECK(c.bad_payloads >= 1);
  CHECK(c.truncated_bytes == 30);
  CHECK(c.bytes == c.frame_bytes + c.skipped_bytes + c.truncated_bytes);  // every byte accounted for
  CHECK(c.restarts == 0);
}

TEST_CASE("sequence numbers wrap, a Hello or a jump far back restarts the sequence") {
  const Stream s = make_stream(200, 31, 0xFFFFFFD0U);  // wraps after 48 frames, ends at 151
  device::FrameParser parser;
  std::vector<std::uint32_t> got = parse(parser, join(s.frames), s, 32);
  CHECK(got.size() == 200);
  CHECK(parser.counts().lost == 0);

  // the device restarts: sequence 0 again, first without a Hello (151 behind, beyond the window of
  // 64: a restart), then with one
  const Stream again = make_stream(5, 33, 0);
  got = parse(parser, join(again.frames), again, 34);
  CHECK(got.size() == 5);
  CHECK(parser.counts().restarts == 1);
  device::FrameWriter writer(1000);
  const Bytes hello = as_bytes(writer.hello(0, 9, 180, 44, "glauser2019"));
  int hellos = 0;
  parser.feed(hello.data(), hello.size(), [&](const device::Frame&) { ++hellos; });
  CHECK(hellos == 1);
  CHECK(parser.counts().restarts == 2);
  CHECK(parser.counts().lost == 0);  // a new sequence is not a gap
  CHECK(parser.counts().duplicates == 0);
}

TEST_CASE("a Hello after a reconnection continues the sequence: the frames sent meanwhile are lost") {
  const Stream s = make_stream(10, 35, 0);  // sequences 0-9, device times 1.0 s to 1.15 s
  device::FrameParser parser;
  CHECK(parse(parser, join(s.frames), s, 36).size() == 10);
  // The link was down while the device sent 7 frames (10-16); on the new connection it says Hello
  // (sequence 17, a later time), then goes on with 18.
  device::FrameWriter writer(17);
  const Bytes hello = as_bytes(writer.hello(2000000, 9, 180, 44, "glauser2019"));
  const float value = 1.0F;
  const Bytes next = as_bytes(writer.values(device::FrameKind::Cells, 2016667, &value, 1));
  std::vector<std::uint32_t> got;
  for (const Bytes* b : {&hello, &next}) parser.feed(b->data(), b->size(), [&](const device::Frame& f) { got.push_back(f.header.sequence); });
  CHECK(got == std::vector<std::uint32_t>{17, 18});
  CHECK(parser.counts().lost == 7);
  CHECK(parser.counts().restarts == 0);
  // A Hello ahead in sequence but with an earlier time is a device that began again.
  device::FrameWriter restarted(40);
  const Bytes again = as_bytes(restarted.hello(1000, 9, 180, 44, "glauser2019"));
  parser.feed(again.data(), again.size(), [&](const device::Frame&) {});
  CHECK(parser.counts().restarts == 1);
  CHECK(parser.counts().lost == 7);
}

TEST_CASE("bytes that are no frame are skipped, a header claiming too long a payload is refused") {
  const Stream s = make_stream(4, 41);
  Bytes noise = {'G', 'P', 'G', 'x', 0, 'G'};
  Bytes all = noise;
  const Bytes frames = join(s.frames);
  all.insert(all.end(), frames.begin(), frames.end());
  // a header with a valid CRC but 5000 payload bytes: refused at once, not waited for
  Bytes big = {0x47, 0x50, 0x01, 0x03, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0x88, 0x13, 0, 0};
  const std::uint32_t crc = device::crc32(big.data(), 20);
  for (int i = 0; i < 4; ++i) big.push_back(static_cast<std::uint8_t>(crc >> (8 * i)));
  all.insert(all.end(), big.begin(), big.end());
  device::FrameParser parser;
  int passed = 0;
  parser.feed(all.data(), all.size(), [&](const device::Frame&) { ++passed; });
  CHECK(passed == 4);
  CHECK(parser.counts().bad_headers == 2);  // the noise's "GP" and the big header, at once
  parser.finish();  // every byte outside the frames was skipped or is a tail left unfinished
  CHECK(parser.counts().skipped_bytes + parser.counts().truncated_bytes == noise.size() + big.size());
}

TEST_CASE("the device clock: offset and drift from frames that arrive late by a random delay") {
  // a device clock 150 ppm slow against the host, 1234.5 s behind it; each frame arrives after 0.4 ms
  // plus an exponential delay of 2 ms mean, and one in fifty after 30 ms more (a stall)
  const double true_drift = 150e-6, true_offset = 1234.5, shortest = 0.4e-3;
  core::Rng rng(51);
  device::DeviceClock clock;
  double worst = 0.0;
  for (int i = 0; i < 60 * 120; ++i) {  // two minutes at 60 Hz
    const std::uint64_t device_us = 5000000 + static_cast<std::uint64_t>(i) * 16667;
    const double sent = true_offset + static_cast<double>(device_us) * 1e-6 * (1.0 + true_drift);
    const double arrived = sent + shortest + rng.exponential(2e-3) + (rng.bernoulli(0.02) ? 30e-3 : 0.0);
    clock.add(device_us, arrived);
    if (i >= 60 * 40) worst = std::max(worst, std::abs(clock.to_host(device_us) - (sent + shortest)));
  }
  CHECK(std::abs(clock.drift() - true_drift) < 5e-6);
  CHECK(worst < 0.25e-3);  // after 40 s: the frame's send time plus the shortest delay, within a quarter millisecond
  MESSAGE("drift ", clock.drift() * 1e6, " ppm (true 150), worst mapping error after 40 s ", worst * 1e3, " ms");

  // a device that restarts (its time goes back) starts a new mapping
  clock.add(1000, 2000.0);
  CHECK(clock.frames() == 1);
  CHECK(clock.to_host(1000) == doctest::Approx(2000.0));
  CHECK(clock.drift() == 0.0);
  CHECK_THROWS_AS(device::DeviceClock(0.0), Error);
  CHECK_THROWS_AS(device::DeviceClock(1.0, 1), Error);
}

TEST_CASE("the pieces a stream arrives in change nothing: fed byte by byte, it is parsed and counted as whole") {
  // noise, a damaged frame, whole frames, a lone byte that begins no frame, more frames and three such
  // bytes (the parser once counted the last skipped when whole and truncated when it came alone)
  const Stream s = make_stream(40, 61);
  Bytes all = {'x', 'G', 'P', 'G', 0x01};
  Bytes frames = join(s.frames);
  frames[30] ^= 0x10;
  all.insert(all.end(), frames.begin(), frames.begin() + 2000);
  all.push_back('q');
  all.insert(all.end(), frames.begin() + 2000, frames.end());
  all.insert(all.end(), {'x', 'y', 'z'});
  device::FrameParser whole, bytes;
  std::vector<std::uint32_t> from_whole, from_bytes;
  whole.feed(all.data(), all.size(), [&](const device::Frame& f) { from_whole.push_back(f.header.sequence); });
  for (std::uint8_t b : all) bytes.feed(&b, 1, [&](const device::Frame& f) { from_bytes.push_back(f.header.sequence); });
  whole.finish();
  bytes.finish();
  CHECK(from_whole == from_bytes);
  CHECK(from_whole.size() >= 30);
  const device::LinkCounts &a = whole.counts(), &b = bytes.counts();
  CHECK(a.skipped_bytes == b.skipped_bytes);
  CHECK(a.truncated_bytes == b.truncated_bytes);
  CHECK(a.frame_bytes == b.frame_bytes);
  CHECK(a.bad_headers == b.bad_headers);
  CHECK(a.bad_payloads == b.bad_payloads);
  CHECK(a.lost == b.lost);
  CHECK(a.bytes == a.frame_bytes + a.skipped_bytes + a.truncated_bytes);
}
