// The simulator as a device (glovepose simulate --stream): a recording's readings written as the
// wire protocol's frames (docs/wire_protocol.md) to a byte stream, at the pace they were recorded or
// faster, so a reader meets what a real glove would send: a Hello, then one frame per readout cycle
// (on UDP, a Hello again every second of device time).
#pragma once

#include <glovepose/device/wire_format.hpp>
#include <glovepose/io/dataset.hpp>

#include <chrono>
#include <cmath>
#include <string>
#include <thread>
#include <vector>

#include "device_link.hpp"

namespace glovepose::cli {

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
inline DeviceStreamCounts stream_dataset(const io::Dataset& data, const DeviceStreamSettings& settings, FrameSink& sink) {
  const bool rows = settings.payload != StreamPayload::Cells;
  if (rows && data.row_count == 0) throw Error("streaming raw rows needs a dataset with raw rows, but it has none");
  const io::RowClock clock = data.row_clock();
  const double cycle = 1.0 / clock.frame_rate;
  device::FrameWriter writer;
  DeviceStreamCounts counts;
  const auto send = [&](core::Span<const std::uint8_t> frame) {
    if (frame.empty()) throw Error("a frame too large for the wire protocol (at most 4096 payload bytes)");
    sink.send(frame);
    ++counts.frames;
    counts.bytes += frame.size();
  };
  const auto hello = [&](std::uint64_t device_us) {
    send(writer.hello(device_us, settings.serial, static_cast<std::uint16_t>(rows ? data.row_count : 0),
                      static_cast<std::uint16_t>(settings.cells), settings.glove_id));
  };
  hello(0);
  std::uint64_t said_at_us = 0;
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
    if (sink.datagrams() && us(end) >= said_at_us + 1000000) hello(said_at_us = us(end));
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
