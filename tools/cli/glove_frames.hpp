// A glove's stream in the wire protocol (docs/wire_protocol.md), for the tool's commands that read
// one (glovepose predict --raw, glovepose view --stdin), and the one entry that tells it from text
// lines by its first bytes.
#pragma once

#include <glovepose/device/frame_parser.hpp>
#include <glovepose/device/wire_format.hpp>

#include <algorithm>
#include <array>
#include <cstdio>
#include <exception>
#include <string>
#include <vector>

#include "frame_feed.hpp"
#include "glove_lines.hpp"

#ifdef _WIN32
#  include <fcntl.h>
#  include <io.h>
#endif

namespace glovepose::cli {

/// A glove's frames given to an estimator through a GloveFeed (its calibration, counts and end
/// checks), with the device's time as stream time. A Hello must name the model's glove (its id,
/// cells and, for raw rows, the wiring's rows): another glove is an Error. Frames the parser drops
/// (damaged, lost, repeated, late) are counted as skipped, the first told.
class FrameFeed {
 public:
  FrameFeed(GloveFeed& feed, GlovePoseEstimator& estimator, std::string source_name)
      : feed_(feed), estimator_(estimator), source_(std::move(source_name)), values_(device::kMaxPayloadBytes / 4), inputs_(values_.size()) {
    const PoseModel& model = estimator.model();
    rows_ = model.solver() ? model.solver()->layout().row_count() : 0;
  }

  /// One frame the parser passed on.
  void use(const device::Frame& f) {
    const PoseModel& model = estimator_.model();
    const double t = static_cast<double>(f.header.device_time_us) * 1e-6;
    Status status = Status::Ok;
    switch (f.header.kind) {
      case device::FrameKind::Hello: {
        device::Hello hello;
        if (device::read_hello(f, hello) != Status::Ok) {
          feed_.read(true, name(f) + ": a Hello whose length does not match its glove id's");
          return;
        }
        const std::string id = hello.glove_id;
        if (id != model.glove().id() || hello.cells != static_cast<int>(model.cell_count()) || (hello.rows != 0 && hello.rows != rows_))
          throw Error(source_ + " " + name(f) + ": the device (serial " + std::to_string(hello.serial) + ") is glove '" + id + "' with " +
                      std::to_string(hello.cells) + " cells and " + std::to_string(hello.rows) + " rows, expected glove '" +
                      model.glove().id() + "' with " + std::to_string(model.cell_count()) + " cells and " + std::to_string(rows_) +
                      " rows (the model's; another glove needs --model, a model trained for it)");
        feed_.read(false);
        return;
      }
      case device::FrameKind::Rows:
        if (rows_ == 0) {
          feed_.read(true, name(f) + ": raw rows, but the model's glove '" + model.glove().id() + "' has no wiring to solve them");
          return;
        }
        status = device::read_rows(f, [&](const device::RowReading& r) {
          const double at = t + r.offset_us * 1e-6;
          feed_.input(at, [&] { return estimator_.push_row(r.row, r.value, at); }, [&] { return name(f) + ", row " + std::to_string(r.row); });
        });
        break;
      case device::FrameKind::Measurements:
      case device::FrameKind::Cells: {
        const bool cells = f.header.kind == device::FrameKind::Cells;
        const std::size_t count = f.payload.size() / 4;
        status = device::read_values(f, values_.data(), count);
        if (status != Status::Ok) break;
        for (std::size_t i = 0; i < count; ++i) inputs_[i] = values_[i];
        feed_.input(
            t,
            [&] {
              const int n = static_cast<int>(count);
              return cells ? estimator_.push_cells(inputs_.data(), n, t) : estimator_.push_measurements(inputs_.data(), n, t);
            },
            [&] { return name(f); });
        break;
      }
    }
    feed_.read(status != Status::Ok, name(f) + ": " + to_string(status));
  }

  /// Counts the frames the parser dropped since the last call as skipped.
  void count_dropped(const device::LinkCounts& c) {
    const std::uint64_t now = c.bad_headers + c.bad_payloads + c.lost + c.duplicates + c.late;
    for (; dropped_ < now; ++dropped_) feed_.read(true, "a frame damaged, lost or out of order (" + link_summary(c) + " so far)");
  }

 private:
  static std::string name(const device::Frame& f) { return "frame " + std::to_string(f.header.sequence); }

  GloveFeed& feed_;
  GlovePoseEstimator& estimator_;
  std::string source_;
  int rows_ = 0;
  std::vector<float> values_;
  std::vector<double> inputs_;
  std::uint64_t dropped_ = 0;
};

/// Feeds the wire frames of `source` to `estimator` as read_glove_lines feeds lines (the same
/// calibration, counts and end checks; FrameFeed); `link` receives the parser's counts.
/// `first_bytes`: the stream's start, already read.
inline void read_glove_frames(const GloveLineSource& source, const GloveLineFormat& format, GlovePoseEstimator& estimator,
                              std::optional<double> calibration_seconds, GloveLineCounts& counts, const std::function<void(Status)>& pushed,
                              const std::atomic<bool>* stop, const std::string& first_bytes, device::LinkCounts& link) {
  const auto stopped = [&] { return stop != nullptr && stop->load(); };
  GloveFeed feed(source, format, estimator, calibration_seconds, counts, pushed, "frame");
  FrameFeed frames(feed, estimator, source.name);
  device::FrameParser parser;
  const auto parse = [&](const char* bytes, std::size_t size) {
    feed_frames(parser, reinterpret_cast<const std::uint8_t*>(bytes), size, [&](const device::Frame& f) { frames.use(f); });
    frames.count_dropped(parser.counts());
  };
  parse(first_bytes.data(), first_bytes.size());
  std::array<char, 4096> buffer{};
  // Whatever has arrived is parsed at once: a frame becomes a pose as soon as its last byte is in.
  std::streambuf& in = *source.in.rdbuf();
  while (!stopped()) {
    const int c = in.sgetc();
    if (c == std::char_traits<char>::eof()) break;
    std::streamsize n = std::min<std::streamsize>(std::max<std::streamsize>(in.in_avail(), 1), buffer.size());
    n = in.sgetn(buffer.data(), n);
    if (n <= 0) break;
    parse(buffer.data(), static_cast<std::size_t>(n));
  }
  parser.finish();
  link = parser.counts();
  if (stopped()) return;
  feed.end();
}

/// Reads a glove's stream, wire frames or text lines as its first bytes say ("GP" and version 1:
/// frames); `link` receives the frames' link counts (all zero for lines). On Windows a binary
/// stream needs stdin in binary mode: binary_stdin() before anything reads it.
inline void read_glove_stream(const GloveLineSource& source, const GloveLineFormat& format, GlovePoseEstimator& estimator,
                              std::optional<double> calibration_seconds, GloveLineCounts& counts, const std::function<void(Status)>& pushed,
                              device::LinkCounts& link, const std::atomic<bool>* stop = nullptr) {
  std::string start;  // as far as it matches a frame's first three bytes; never a line end
  const int expected[3] = {device::kMagic[0], device::kMagic[1], device::kWireVersion};
  while (start.size() < 3 && source.in.peek() == expected[start.size()]) start += static_cast<char>(source.in.get());
  link = device::LinkCounts{};
  if (start.size() == 3)
    read_glove_frames(source, format, estimator, calibration_seconds, counts, pushed, stop, start, link);
  else
    read_glove_lines(source, format, estimator, calibration_seconds, counts, pushed, stop, start);
}

/// Puts stdin in binary mode (Windows; elsewhere there is no other), so wire frames arrive as sent.
inline void binary_stdin() {
#ifdef _WIN32
  (void)_setmode(_fileno(stdin), _O_BINARY);
#endif
}

}  // namespace glovepose::cli
