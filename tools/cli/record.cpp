// glovepose record: a glove's wire stream (docs/wire_protocol.md) kept in a recording file as it
// arrives, with the link's and the readings' health per second of device time. The recording is the
// stream's checked frames, in order, in the wire format itself: predict --raw, view --stdin and
// import read it. It never replaces a file; each frame is written when it arrives and flushed to
// the disk within a second of that, so a kill loses nothing written and a power cut at most the last
// second, and what is left is a valid recording (a frame cut off at the end is ignored). A
// serial port, pty or socket that goes away is reopened (glove_link.hpp) and the recording goes on,
// with what was lost meanwhile counted.
#include <glovepose/device/frame_parser.hpp>

#include <atomic>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#ifdef _WIN32
#  include <sys/stat.h>
#endif

#include "byte_link.hpp"
#include "commands.hpp"
#include "glove_frames.hpp"
#include "glove_link.hpp"

namespace glovepose::cli {
namespace {

struct RecordOptions {
  std::string in = "-", out;
  bool quiet = false;
};

std::atomic<bool> record_stop{false};
extern "C" void record_on_signal(int) { record_stop = true; }

// The recording file: created new, appended to, flushed to the disk on request.
class RecordingFile {
 public:
  explicit RecordingFile(std::string path) : path_(std::move(path)) {
#ifdef _WIN32
    fd_ = ::_open(path_.c_str(), _O_WRONLY | _O_CREAT | _O_EXCL | _O_BINARY, _S_IREAD | _S_IWRITE);
#else
    fd_ = ::open(path_.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0666);
#endif
    if (fd_ < 0)
      throw Error("recording '" + path_ + "': cannot create it: " + std::strerror(errno) +
                  (errno == EEXIST ? " (a recording never replaces a file: name a new one)" : ""));
  }
  RecordingFile(const RecordingFile&) = delete;
  RecordingFile& operator=(const RecordingFile&) = delete;
  ~RecordingFile() {
    if (fd_ >= 0) close_fd(fd_);
  }

  void write(core::Span<const std::uint8_t> bytes) { write_all(fd_, bytes.data(), bytes.size(), "recording '" + path_ + "'"); }

  void flush() {
#ifdef _WIN32
    const int failed = ::_commit(fd_);
#else
    const int failed = ::fsync(fd_);
#endif
    if (failed != 0) throw Error("recording '" + path_ + "': cannot flush it to the disk: " + std::strerror(errno));
  }

  // A recording that holds no frame is not kept.
  void discard() {
    close_fd(fd_);
    fd_ = -1;
    std::remove(path_.c_str());
  }

 private:
  std::string path_;
  int fd_ = -1;
};

// One second of device time: what came, what was missing.
struct HealthSecond {
  long second = -1;
  long frames = 0, readings = 0, missing = 0;  // missing: readings sent as NaN (the device could not take them)
  device::LinkCounts link_before;
};

void print_health(const HealthSecond& h, const device::LinkCounts& now) {
  std::fprintf(stderr, "glovepose record: %ld s: %ld frames, %ld readings (%ld missing); %llu lost, %llu damaged, %llu bytes skipped\n",
               h.second, h.frames, h.readings, h.missing, static_cast<unsigned long long>(now.lost - h.link_before.lost),
               static_cast<unsigned long long>(now.bad_headers + now.bad_payloads - h.link_before.bad_headers - h.link_before.bad_payloads),
               static_cast<unsigned long long>(now.skipped_bytes - h.link_before.skipped_bytes));
}

int record(const RecordOptions& o) {
  GloveLink link(o.in);
  RecordingFile file(o.out);
  stop_on_signals(record_on_signal);
  const auto counts = [&] { return link.counts(); };
  HealthSecond health;
  double first_time = std::nan(""), last_time = std::nan("");
  long kept = 0;
  // A frame reaches the disk within a second of its write: the oldest one not yet flushed waits at
  // most kFlushAge, plus one poll's wait (kPollWait), plus the flush.
  using Clock = std::chrono::steady_clock;
  constexpr std::chrono::milliseconds kFlushAge{750}, kPollWait{150};
  std::optional<Clock::time_point> unflushed;  // when the oldest frame not yet flushed was written
  const auto on_frame = [&](const device::Frame& f, double, double) {
    file.write(f.bytes);
    if (!unflushed) unflushed = Clock::now();
    ++kept;
    const double t = static_cast<double>(f.header.device_time_us) * 1e-6;
    if (std::isnan(first_time)) first_time = t;
    last_time = t;
    const long second = static_cast<long>(std::floor(t));
    if (second != health.second) {
      if (health.second >= 0 && !o.quiet) print_health(health, counts());
      health = HealthSecond{second, 0, 0, 0, counts()};
    }
    ++health.frames;
    if (f.header.kind == device::FrameKind::Rows) {
      (void)device::read_rows(f, [&](const device::RowReading& r) {
        ++health.readings;
        health.missing += !std::isfinite(r.value);
      });
    } else if (f.header.kind != device::FrameKind::Hello) {
      for (std::size_t at = 0; at + 4 <= f.payload.size(); at += 4) {
        ++health.readings;
        health.missing += !std::isfinite(device::wire::get_f32(f.payload.data() + at));
      }
    }
  };
  LinkEvents told = link.events();
  while (!record_stop) {
    if (!link.poll(kPollWait, on_frame)) break;
    if (unflushed && Clock::now() - *unflushed >= kFlushAge) {
      file.flush();
      unflushed.reset();
    }
    const LinkEvents& now = link.events();
    if (now.losses != told.losses && !o.quiet)
      std::fprintf(stderr, "glovepose record: link '%s' lost (%s); reopening it\n", o.in.c_str(), now.last_problem.c_str());
    if (now.connections != told.connections && !o.quiet)
      std::fprintf(stderr, "glovepose record: link '%s' open again (%llu attempts failed so far)\n", o.in.c_str(),
                   static_cast<unsigned long long>(now.failed_opens));
    told = now;
  }
  if (kept == 0) {
    file.discard();
    throw Error("no frame of the wire protocol in " + (o.in == "-" ? std::string("stdin") : "'" + o.in + "'") + " (" +
                link_summary(counts()) + "), expected a glove's frames (docs/wire_protocol.md); nothing recorded");
  }
  file.flush();
  if (!o.quiet) print_health(health, counts());
  std::fprintf(stderr, "glovepose record: %s: %ld frames, %.1f s of device time%s; link: %s; %s\n", o.out.c_str(), kept,
               last_time - first_time, record_stop ? " (stopped by a signal)" : "", link_summary(counts()).c_str(),
               link_events_summary(link).c_str());
  return 0;
}

}  // namespace

Command add_record(CLI::App& tool) {
  auto o = std::make_shared<RecordOptions>();
  CLI::App* command = tool.add_subcommand(
      "record",
      "Records a glove's wire stream (docs/wire_protocol.md) into a new file as it arrives, each frame flushed to the disk within a second, with the "
      "link's health per second on stderr; predict --raw, view --stdin and import read the recording.");
  command->add_option("--in", o->in, std::string(kLinkHelp) + " (default: stdin)")->type_name("SOURCE");
  command->add_option("--out", o->out, "the recording, a new file (never replaces one)")->type_name("FILE")->required();
  command->add_flag("--quiet", o->quiet, "no health line per second, only the summary");
  return {command, [o] { return record(*o); }};
}

}  // namespace glovepose::cli
