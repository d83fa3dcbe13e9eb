// The simulator as a device (glovepose simulate --stream): a recording's readings written as the
// wire protocol's frames (docs/wire_protocol.md) to a byte stream, at the pace they were recorded or
// faster, so a reader meets what a real glove would send: a Hello, then one frame per readout cycle.
#pragma once

#include <glovepose/device/wire_format.hpp>
#include <glovepose/io/dataset.hpp>

#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <string>
#include <thread>
#include <vector>

#include <fcntl.h>
#ifdef _WIN32
#  include <io.h>
#else
#  include <termios.h>
#  include <unistd.h>
#endif

namespace glovepose::cli {

/// Where a stream of bytes goes: "-" for stdout, else a path opened for writing (a file, a named
/// pipe, a pty or a serial port; a terminal is put in raw mode so no byte is translated).
class ByteSink {
 public:
  explicit ByteSink(const std::string& target) : target_(target) {
    if (target == "-") {
      fd_ = 1;
#ifdef _WIN32
      (void)_setmode(1, _O_BINARY);
#endif
      return;
    }
#ifdef _WIN32
    fd_ = ::_open(target.c_str(), _O_WRONLY | _O_CREAT | _O_TRUNC | _O_BINARY, 0666);
#else
    fd_ = ::open(target.c_str(), O_WRONLY | O_CREAT | O_NOCTTY | O_CLOEXEC, 0666);
#endif
    if (fd_ < 0) throw Error("stream target '" + target + "': cannot open it for writing: " + std::strerror(errno));
    owned_ = true;
#ifndef _WIN32
    termios mode{};
    if (::isatty(fd_) && ::tcgetattr(fd_, &mode) == 0) {  // a pty or serial port: raw, 8 bits, no echo, no line end translation
      ::cfmakeraw(&mode);
      (void)::tcsetattr(fd_, TCSANOW, &mode);
    }
#endif
  }
  ByteSink(const ByteSink&) = delete;
  ByteSink& operator=(const ByteSink&) = delete;
  ~ByteSink() {
    if (owned_) close_fd();
  }

  /// Writes all `size` bytes; throws Error when the other end is gone or refuses them.
  void write(const std::uint8_t* data, std::size_t size) {
    while (size > 0) {
#ifdef _WIN32
      const int n = ::_write(fd_, data, static_cast<unsigned>(size));
#else
      const ssize_t n = ::write(fd_, data, size);
#endif
      if (n < 0 && errno == EINTR) continue;
      if (n <= 0) throw Error("stream target '" + target_ + "': cannot write: " + std::strerror(n < 0 ? errno : EIO));
      data += n;
      size -= static_cast<std::size_t>(n);
    }
  }

 private:
  void close_fd() noexcept {
#ifdef _WIN32
    (void)::_close(fd_);
#else
    (void)::close(fd_);
#endif
  }

  std::string target_;
  int fd_ = -1;
  bool owned_ = false;
};

/// What a simulated device sends.
enum class StreamPayload { Measurements, Rows, Cells };

/// How the simulator streams.
struct DeviceStreamSettings {
  StreamPayload payload = StreamPayload::Measurements;
  double speed = 1.0;         ///< Multiples of real time; 0: as fast as the target takes the bytes.
  std::uint32_t serial = 1;   ///< The device's serial number in its Hello.
  std::string glove_id;       ///< The glove description's id in its Hello.
  int cells = 0;              ///< Cells of that description.
};

/// Frames and bytes sent.
struct DeviceStreamCounts {
  std::uint64_t frames = 0, bytes = 0;
};

/// Streams `data` (its recordings one after another, as the device's clock runs on: each recording
/// continues one readout cycle after the previous one's last frame) to `sink`: a Hello, then one
/// frame per frame of `data` (its raw rows as Measurements or Rows, or its cells).
inline DeviceStreamCounts stream_dataset(const io::Dataset& data, const DeviceStreamSettings& settings, ByteSink& sink) {
  const bool rows = settings.payload != StreamPayload::Cells;
  if (rows && data.row_count == 0) throw Error("streaming raw rows needs a dataset with raw rows, but it has none");
  const io::RowClock clock = data.row_clock();
  const double cycle = 1.0 / clock.frame_rate;
  device::FrameWriter writer;
  DeviceStreamCounts counts;
  const auto send = [&](core::Span<const std::uint8_t> frame) {
    if (frame.empty()) throw Error("a frame too large for the wire protocol (at most 4096 payload bytes)");
    sink.write(frame.data(), frame.size());
    ++counts.frames;
    counts.bytes += frame.size();
  };
  send(writer.hello(0, settings.serial, static_cast<std::uint16_t>(rows ? data.row_count : 0), static_cast<std::uint16_t>(settings.cells),
                    settings.glove_id));
  std::vector<device::RowReading> readings(data.row_count);
  const auto start = std::chrono::steady_clock::now();
  double base = 0.0;  // device seconds at the current recording's time 0
  for (std::size_t f = 0; f < data.frames(); ++f) {
    if (f > 0 && data.timestamps[f] <= data.timestamps[f - 1]) base += data.timestamps[f - 1] - data.timestamps[f] + cycle;  // the next recording
    const double end = base + data.timestamps[f];  // the cycle's end on the device's clock
    if (settings.speed > 0.0)
      std::this_thread::sleep_until(start + std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                                                std::chrono::duration<double>(end / settings.speed)));
    const auto us = [](double seconds) { return static_cast<std::uint64_t>(std::llround(seconds * 1e6)); };
    if (settings.payload == StreamPayload::Cells) {
      send(writer.values(device::FrameKind::Cells, us(end), data.cells.data() + f * data.cell_count, data.cell_count));
    } else if (settings.payload == StreamPayload::Measurements) {
      send(writer.values(device::FrameKind::Measurements, us(end), data.raw_rows.data() + f * data.row_count, data.row_count));
    } else {  // each row at its own time (io::RowClock), as an offset from the cycle's first row
      const std::uint64_t first = us(base + clock.time(data.timestamps[f], 0));
      for (std::size_t r = 0; r < data.row_count; ++r)
        readings[r] = {static_cast<std::uint16_t>(r), static_cast<std::uint16_t>(us(base + clock.time(data.timestamps[f], r)) - first),
                       data.raw_rows[f * data.row_count + r]};
      send(writer.rows(first, readings.data(), readings.size()));
    }
  }
  return counts;
}

}  // namespace glovepose::cli
