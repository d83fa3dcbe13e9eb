// A take recorded in the wire protocol (glovepose record, docs/wire_protocol.md) read by glovepose
// import as the CSV take it stands for: a header naming the time and the glove's cells, then one line
// per frame. Cells frames give their values; raw rows (Measurements or Rows frames) are solved by the
// glove's wiring (the built-in glove's), with the estimator's readout, one line per frame that
// completed a solve.
#pragma once

#include <glovepose/device/frame_parser.hpp>
#include <glovepose/grid/glove_description.hpp>
#include <glovepose/sensor/layout.hpp>
#include <glovepose/sensor/readout.hpp>

#include <cstdio>
#include <fstream>
#include <iterator>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "glove_frames.hpp"

namespace glovepose::cli {

/// The CSV text of the take at `path` when it is a wire recording (it starts with a frame's first
/// three bytes), else nothing. Throws Error naming the file: a Hello of another glove, raw rows of a
/// glove without wiring, or no frame with readings.
inline std::optional<std::string> wire_take_as_csv(const std::string& path, const grid::GloveDescription& glove) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return std::nullopt;  // the CSV reader says why
  const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  if (bytes.size() < 3 || static_cast<std::uint8_t>(bytes[0]) != device::kMagic[0] || static_cast<std::uint8_t>(bytes[1]) != device::kMagic[1] ||
      static_cast<std::uint8_t>(bytes[2]) != device::kWireVersion)
    return std::nullopt;
  const std::string at = "recording '" + path + "'";
  std::unique_ptr<sensor::Readout> readout;  // for raw rows: the built-in glove's wiring
  if (glove.id() == grid::GloveDescription::glauser2019().id())
    readout = std::make_unique<sensor::Readout>(std::make_shared<const sensor::CapacitanceSolver>(sensor::TraceLayout::glauser2019()));
  std::string csv = "timestamp";
  for (const std::string& name : glove.cell_names()) csv += "," + name;
  csv += "\n";
  const auto add_line = [&](double t, const auto& value, int count) {
    char number[40];
    std::snprintf(number, sizeof number, "%.17g", t);
    csv += number;
    for (int c = 0; c < count; ++c) {
      std::snprintf(number, sizeof number, ",%.9g", static_cast<double>(value(c)));
      csv += number;
    }
    csv += "\n";
  };
  const auto cells = static_cast<std::size_t>(glove.cell_count());
  long lines = 0;
  std::vector<float> values(device::kMaxPayloadBytes / 4);
  sensor::Readout::Measurements measurements;
  device::FrameParser parser;
  feed_frames(parser, reinterpret_cast<const std::uint8_t*>(bytes.data()), bytes.size(), [&](const device::Frame& f) {
    const double t = static_cast<double>(f.header.device_time_us) * 1e-6;
    if (f.header.kind == device::FrameKind::Hello) {
      device::Hello hello;
      if (device::read_hello(f, hello) == Status::Ok && hello.glove_id != glove.id())
        throw Error(at + ": recorded from glove '" + std::string(hello.glove_id) + "', expected glove '" + glove.id() +
                    "' (import --glove names another glove's description)");
      return;
    }
    if (f.header.kind == device::FrameKind::Cells) {
      if (device::read_values(f, values.data(), cells) == Status::Ok) {
        add_line(t, [&](int c) { return values[static_cast<std::size_t>(c)]; }, static_cast<int>(cells));
        ++lines;
      }
      return;
    }
    if (!readout)
      throw Error(at + ": raw rows, but glove '" + glove.id() + "' has no wiring to solve them, expected a recording of its cells");
    bool solved = false;
    if (f.header.kind == device::FrameKind::Measurements) {
      const std::size_t rows = static_cast<std::size_t>(readout->solver().layout().row_count());
      if (device::read_values(f, values.data(), rows) != Status::Ok) return;
      measurements.resize(static_cast<Eigen::Index>(rows));
      for (std::size_t r = 0; r < rows; ++r) measurements(static_cast<Eigen::Index>(r)) = values[r];
      solved = readout->push_frame(measurements, t) == Status::Solved;
    } else {
      (void)device::read_rows(f, [&](const device::RowReading& r) { solved |= readout->push_row(r.row, r.value, t + r.offset_us * 1e-6) == Status::Solved; });
    }
    if (solved) {
      const sensor::CapacitanceFrame& frame = readout->frame();
      add_line(frame.timestamp, [&](int c) { return frame.cells(c); }, static_cast<int>(frame.cells.size()));
      ++lines;
    }
  });
  parser.finish();
  if (lines == 0)
    throw Error(at + ": no frame of readings (" + link_summary(parser.counts()) + "), expected frames of the glove's cells or raw rows");
  return csv;
}

}  // namespace glovepose::cli
