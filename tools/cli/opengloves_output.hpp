// glovepose serve's OpenGloves output: each pose as a line of OpenGloves' alpha encoding (the
// input protocol of LucidVR's SteamVR driver and of Monado's OpenGloves driver, which show a hand
// from it in any OpenVR or OpenXR application), its curls and splays from hand/finger_curls.hpp.
// The encoding and the mapping are documented in docs/pose_stream.md ("OpenGloves").
//   pty:LINK             (Linux, macOS) a new pseudo-terminal, its device named by the symlink LINK,
//                        which a driver opens as if it were the glove's serial port
//   serial:PORT[@BAUD]   a serial port (one end of a virtual pair such as com0com's on Windows)
//   pipe:NAME            (Windows) a named pipe that LucidVR's SteamVR driver serves, written one
//                        OpenGlovesPipeMessage per pose
//   PATH                 a terminal as serial:PATH; else a file the lines are written to
// A line the other end cannot take now is skipped (counted), never waited for: a driver that stops
// reading does not hold up the poses.
#pragma once

#include <glovepose/hand/finger_curls.hpp>

#include <array>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>

#include <boost/asio/io_context.hpp>
#include <boost/asio/serial_port.hpp>
#include <boost/asio/write.hpp>
#ifdef _WIN32
#  include <boost/asio/windows/stream_handle.hpp>
#  include <system_error>
#  include <windows.h>
#endif

#include "byte_link.hpp"
#include "device_link.hpp"

#ifndef _WIN32
#  include <boost/asio/posix/stream_descriptor.hpp>
#  include <fcntl.h>
#  include <stdlib.h>
#  include <sys/ioctl.h>
#  include <termios.h>
#  include <unistd.h>
#endif

namespace glovepose::cli {

/// The buttons a LucidGloves glove without buttons derives from its curls, by its firmware's default
/// rules (LucidVR/lucidgloves, firmware src/Controller/Gesture.cpp and src/Encoding/AlphaEncoding.cpp,
/// MIT; on by default in its Config.h): grab when the mean curl of the four fingers passes half,
/// pinch when the mean of the thumb's and the index's does, the trigger button when the index's
/// does, and the trigger's value the index's curl beyond half, stretched to 0..1. SteamVR bindings
/// take grip and trigger from them.
struct OpenGlovesGestures {
  bool grab = false, pinch = false, trigger = false;
  double trigger_value = 0.0;
};

inline OpenGlovesGestures opengloves_gestures(const hand::FingerCurls& c) noexcept {
  OpenGlovesGestures g;
  g.grab = (c.curl[1] + c.curl[2] + c.curl[3] + c.curl[4]) / 4.0 > 0.5;
  g.pinch = (c.curl[0] + c.curl[1]) / 2.0 > 0.5;
  g.trigger = c.curl[1] > 0.5;
  g.trigger_value = g.trigger ? 2.0 * c.curl[1] - 1.0 : 0.0;
  return g;
}

/// One pose as a line of OpenGloves' alpha encoding: each key followed by its value as a whole
/// number from 0 to `most` (the driver's max_analog_value: 4095 in LucidVR's SteamVR driver by
/// default, 1023 in Monado's), the line ended by '\n'. Always the five finger curls A-E, the
/// five splays (AB)-(EB), the trigger's value P and the gestures I (trigger), L (grab) and M
/// (pinch) when on (OpenGlovesGestures), at most 74 bytes; with `joints`, also each joint's curl
/// ((AAA) to (EAD), the thumb's unused 4th left out), up to 233 bytes: more than Monado's driver
/// reads as one packet (150 bytes), so for the SteamVR driver only.
class OpenGlovesLine {
 public:
  OpenGlovesLine(unsigned most, bool joints) : most_(most), joints_(joints) {
    if (most < 1 || most > 9999) throw Error("--opengloves-max " + std::to_string(most) + ": expected 1 to 9999 (the driver's max_analog_value)");
  }

  /// Encodes `curls`; data() and size() are the line.
  void encode(const hand::FingerCurls& curls) noexcept {
    size_ = 0;
    static constexpr char kFinger[hand::kFingerCount] = {'A', 'B', 'C', 'D', 'E'};
    for (std::size_t f = 0; f < hand::kFingerCount; ++f) put(kFinger[f], nullptr, curls.curl[f]);
    for (std::size_t f = 0; f < hand::kFingerCount; ++f) put(kFinger[f], "B", 0.5 * (curls.splay[f] + 1.0));  // splay -1..1 as 0..most
    const OpenGlovesGestures g = opengloves_gestures(curls);
    put('P', nullptr, g.trigger_value);
    if (g.trigger) line_[size_++] = 'I';
    if (g.grab) line_[size_++] = 'L';
    if (g.pinch) line_[size_++] = 'M';
    if (joints_) {
      static constexpr const char* kJoint[hand::kCurlJoints] = {"AA", "AB", "AC", "AD"};
      for (std::size_t f = 0; f < hand::kFingerCount; ++f)
        for (std::size_t j = 0; j < (f == 0 ? 3 : hand::kCurlJoints); ++j) put(kFinger[f], kJoint[j], curls.joints[f][j]);
    }
    line_[size_++] = '\n';
  }
  const char* data() const noexcept { return line_.data(); }
  std::size_t size() const noexcept { return size_; }

 private:
  // Writes the key (a finger's letter, or "(" letter rest ")" for a long key) and `fraction` of most.
  void put(char finger, const char* rest, double fraction) noexcept {
    char* p = line_.data() + size_;
    const long value = std::lround(std::fmin(std::fmax(fraction, 0.0), 1.0) * most_);
    const int n = rest ? std::snprintf(p, 16, "(%c%s)%ld", finger, rest, value) : std::snprintf(p, 16, "%c%ld", finger, value);
    size_ += static_cast<std::size_t>(n);
  }

  std::array<char, 256> line_{};
  std::size_t size_ = 0;
  unsigned most_;
  bool joints_;
};

/// One pose as the message of OpenGloves' named pipe (LucidVR's SteamVR driver on Windows, which
/// serves `\\.\pipe\vrapplication\input\glove\v2\<left|right>` and reads one message of 120 bytes:
/// its NamedPipeInputDataVersion::v2). Little-endian, no padding (docs/pose_stream.md, "OpenGloves"):
/// each joint's curl as float32 (flexion[5][4], fingers thumb to pinky, joints base to tip), each
/// finger's splay in -1..1 (float32 x 5), the joystick x and y (float32, 0), eight one-byte
/// buttons and gestures (the trigger button, grab and pinch from OpenGlovesGestures, the others 0)
/// and the trigger's value (float32).
/// The pipe LucidVR's SteamVR driver serves for a hand's messages, "{hand}" standing for left or
/// right (`--opengloves pipe:` names it).
inline constexpr const char* kDriverPipe = R"(\\.\pipe\vrapplication\input\glove\v2\{hand})";

class OpenGlovesPipeMessage {
 public:
  static constexpr std::size_t kSize = 120;

  /// Encodes `curls`; data() and size() are the message.
  void encode(const hand::FingerCurls& curls) noexcept {
    bytes_.fill(0);
    std::size_t at = 0;
    for (std::size_t f = 0; f < hand::kFingerCount; ++f)
      for (std::size_t j = 0; j < hand::kCurlJoints; ++j) at = put(at, curls.joints[f][j]);
    for (std::size_t f = 0; f < hand::kFingerCount; ++f) at = put(at, curls.splay[f]);
    // The joystick (100-107) and the real buttons stay 0: a glove of stretch sensors has none.
    const OpenGlovesGestures g = opengloves_gestures(curls);
    bytes_[109] = g.trigger;
    bytes_[112] = g.grab;
    bytes_[113] = g.pinch;
    (void)put(116, g.trigger_value);
  }
  const char* data() const noexcept { return reinterpret_cast<const char*>(bytes_.data()); }
  static constexpr std::size_t size() noexcept { return kSize; }

 private:
  // Writes `value` as a little-endian float32 at `at`; the next field's offset.
  std::size_t put(std::size_t at, double value) noexcept {
    const float f = static_cast<float>(value);
    std::uint32_t bits = 0;
    std::memcpy(&bits, &f, sizeof bits);
    for (int b = 0; b < 4; ++b) bytes_[at + static_cast<std::size_t>(b)] = static_cast<std::uint8_t>(bits >> (8 * b));
    return at + 4;
  }

  std::array<std::uint8_t, kSize> bytes_{};
};

/// What became of the lines offered to the OpenGloves output: sent + skipped + failed of them.
struct OpenGlovesCounts {
  std::uint64_t sent = 0;     ///< taken whole by the port or file
  std::uint64_t skipped = 0;  ///< skipped: the port was still taking the line before
  std::uint64_t failed = 0;   ///< refused by the port, or offered while it was lost and being reopened
  std::uint64_t unread = 0;   ///< (a pty) sent, then discarded unread: no driver read them for kUnreadLimit
};

/// Where the OpenGloves lines (or pipe messages) go (the forms at the top of this file). A serial
/// port or named pipe that fails or hangs is closed and reopened with the device links' back-off
/// (LinkTiming); a named pipe need not exist yet (the driver serves it once SteamVR runs). A pty
/// cannot be lost, and what no driver reads is discarded so that a driver that opens it later reads
/// fresh poses.
class OpenGlovesPort {
 public:
  /// How long lines may wait in a pty unread before they are discarded, and a write to a serial
  /// port may wait before the port is taken as hung.
  static constexpr std::chrono::milliseconds kUnreadLimit{500}, kHungLimit{1000};

  explicit OpenGlovesPort(const std::string& target, LinkTiming timing = {}) : timing_(timing), retry_after_(timing.first) {
    const std::string what = "--opengloves '" + target + "'";
    if (target.rfind("pty:", 0) == 0) {
      open_pty(target.substr(4), what);
    } else if (target.rfind("pipe:", 0) == 0) {
      open_first_pipe(target.substr(5), what);
      return;
    } else {
      const LinkAddress a = LinkAddress::parse(target);
      if (a.kind == LinkAddress::Kind::Serial) {
        serial_address_ = a;
        std::string problem;
        if (!open_serial(problem)) throw Error(what + ": cannot open the serial port: " + problem);
        device_ = a.where;
      } else if (a.kind == LinkAddress::Kind::File) {
        file_ = std::make_unique<ByteSink>(a.where);
        device_ = a.where;
      } else {
        throw Error(what + ": expected pty:LINK, a serial port (serial:PORT[@BAUD] or its path) or a file");
      }
    }
    ++events_.connections;
    drain();
  }
  OpenGlovesPort(const OpenGlovesPort&) = delete;
  OpenGlovesPort& operator=(const OpenGlovesPort&) = delete;
  ~OpenGlovesPort() {
#ifndef _WIN32
    if (!link_.empty()) {
      std::error_code e;
      std::filesystem::remove(link_, e);
    }
    if (pty_device_ >= 0) ::close(pty_device_);
#endif
  }

  /// What a driver opens: the pty's device, the serial port or the file; or the pipe it serves.
  const std::string& device() const { return device_; }
  /// True for a named pipe: it takes OpenGlovesPipeMessage's messages, not lines.
  bool takes_messages() const { return !pipe_name_.empty(); }

  /// Sends one line whole, or skips it while the previous one is still being taken.
  void send(const char* line, std::size_t size) {
    poll();
    if (file_) {
      file_->write(reinterpret_cast<const std::uint8_t*>(line), size);
      ++counts_.sent;
      return;
    }
    const auto now = Clock::now();
    if (pty_open()) discard_unread(now);
    if (reopenable() && !port_open() && !reopen(now)) {
      ++counts_.failed;
      return;
    }
    if (writing_) {
      if (port_open() && now - write_started_ > kHungLimit) {
        lose("a line not taken in " + std::to_string(kHungLimit.count()) + " ms", now);
        ++counts_.failed;
      } else {
        ++counts_.skipped;
      }
      return;
    }
    std::copy(line, line + size, out_.data());
    writing_ = true;
    write_started_ = now;
    const auto done = [this, size, generation = generation_](const boost::system::error_code& e, std::size_t n) {
      if (generation != generation_) {  // the port it was written to is gone
        ++counts_.failed;
        return;
      }
      writing_ = false;
      if (!e && n == size) {
        ++counts_.sent;
        remember(size);
      } else {
        ++counts_.failed;
        if (port_open() && e != boost::asio::error::operation_aborted) lose(e ? e.message() : std::string("a line taken in part"), Clock::now());
      }
    };
    if (serial_) boost::asio::async_write(*serial_, boost::asio::buffer(out_.data(), size), done);
#ifdef _WIN32
    if (pipe_) boost::asio::async_write(*pipe_, boost::asio::buffer(out_.data(), size), done);
#else
    if (pty_) boost::asio::async_write(*pty_, boost::asio::buffer(out_.data(), size), done);
#endif
    poll();
  }

  /// Waits up to `wait` for the line being written, then gives it up (counted failed); after it the
  /// counts add up to the lines offered.
  void finish(std::chrono::milliseconds wait = std::chrono::milliseconds(200)) {
    const auto end = Clock::now() + wait;
    while (writing_ && Clock::now() < end) {
      io_.restart();
      io_.run_for(std::chrono::milliseconds(10));
    }
    if (!writing_) return;
    boost::system::error_code ignored;
    if (serial_) serial_->cancel(ignored);
#ifdef _WIN32
    if (pipe_) pipe_->cancel(ignored);
#else
    if (pty_) pty_->cancel(ignored);
#endif
    poll();
  }

  const OpenGlovesCounts& counts() const { return counts_; }
  /// The port's life: losses, reopenings and why it was last lost (a serial port only).
  const LinkEvents& events() const { return events_; }

 private:
  using Clock = std::chrono::steady_clock;

  // Finishes what the port has taken since, and reads what the driver sent. restart(): an
  // io_context that ran out of work (a read ended by a lost port) runs nothing more without it.
  void poll() {
    io_.restart();
    io_.poll();
  }

  // A driver may write to the glove (force feedback: "A0B0C0D0E0\n"); read and dropped, so that its
  // writes never wait for a reader.
  void drain() {
    const auto again = [this, generation = generation_](const boost::system::error_code& e, std::size_t) {
      if (!e && generation == generation_) drain();
    };
    if (serial_) serial_->async_read_some(boost::asio::buffer(in_), again);
#ifndef _WIN32
    if (pty_) pty_->async_read_some(boost::asio::buffer(in_), again);
#endif
  }

  bool open_serial(std::string& problem) {
    boost::system::error_code e;
    auto port = std::make_unique<boost::asio::serial_port>(io_);
    open_serial_port(*port, serial_address_->where, serial_address_->baud, e);
    if (e) {
      problem = e.message();
      return false;
    }
    serial_ = std::move(port);
    return true;
  }

  // A serial port or a named pipe: closed when it fails or hangs, and reopened.
  bool reopenable() const { return serial_address_.has_value() || !pipe_name_.empty(); }
  bool port_open() const {
#ifdef _WIN32
    if (pipe_) return true;
#endif
    return serial_ != nullptr;
  }
  bool open_port(std::string& problem) { return pipe_name_.empty() ? open_serial(problem) : open_pipe(problem); }

  // The pipe's name; opened now if its driver serves it, else by send() once it does.
  void open_first_pipe(const std::string& name, const std::string& what) {
#ifdef _WIN32
    if (name.empty()) throw Error(what + ": no name, expected pipe:NAME (\\\\.\\pipe\\...)");
    pipe_name_ = device_ = name;
    std::string problem;
    if (open_pipe(problem)) {
      ++events_.connections;
    } else {
      ++events_.failed_opens;
      events_.last_problem = problem;
    }
#else
    (void)name;
    throw Error(what + ": a named pipe needs Windows; on Linux and macOS give pty:LINK or a serial port");
#endif
  }

  // A client's end of the pipe, for writing only (the driver writes nothing back).
  bool open_pipe(std::string& problem) {
#ifdef _WIN32
    const HANDLE handle = ::CreateFileA(pipe_name_.c_str(), GENERIC_WRITE, 0, nullptr, OPEN_EXISTING, FILE_FLAG_OVERLAPPED, nullptr);
    if (handle == INVALID_HANDLE_VALUE) {
      problem = std::error_code(static_cast<int>(::GetLastError()), std::system_category()).message();
      return false;
    }
    pipe_ = std::make_unique<boost::asio::windows::stream_handle>(io_, handle);
    return true;
#else
    problem = "a named pipe needs Windows";
    return false;
#endif
  }

  // Closes a failed or hung port; its pending work ends as failed, and send() reopens it.
  void lose(const std::string& problem, Clock::time_point now) {
    ++events_.losses;
    events_.last_problem = problem;
    ++generation_;
    writing_ = false;
    serial_.reset();  // cancels its pending write and read: their handlers see the old generation
#ifdef _WIN32
    pipe_.reset();
#endif
    retry_after_ = timing_.first;
    next_attempt_ = now + retry_after_;
  }

  bool reopen(Clock::time_point now) {
    if (now < next_attempt_) return false;
    std::string problem;
    if (!open_port(problem)) {
      ++events_.failed_opens;
      events_.last_problem = problem;
      retry_after_ = std::min(retry_after_ * 2, timing_.longest);
      next_attempt_ = now + retry_after_;
      return false;
    }
    ++events_.connections;
    drain();
    return true;
  }

  bool pty_open() const {
#ifndef _WIN32
    return pty_ != nullptr;
#else
    return false;
#endif
  }

  // The sizes of the latest lines sent, newest last: what discarding unread bytes threw away.
  void remember(std::size_t size) {
    recent_[recent_next_++ % recent_.size()] = static_cast<std::uint16_t>(size);
  }

  // Lines that wait unread in the pty for kUnreadLimit have no reader: they are discarded (and the
  // write they held up goes through), so that a driver that opens the pty later reads fresh poses.
  void discard_unread(Clock::time_point now) {
#ifndef _WIN32
    int waiting = 0;
    if (::ioctl(pty_device_, FIONREAD, &waiting) != 0 || waiting <= 0) {
      unread_since_.reset();
      return;
    }
    if (!unread_since_) unread_since_ = now;
    if (now - *unread_since_ < kUnreadLimit) return;
    (void)::tcflush(pty_device_, TCIFLUSH);
    // Whole lines among the bytes thrown away (the oldest of them may have been read in part).
    std::size_t bytes = static_cast<std::size_t>(waiting);
    for (std::size_t back = 1; back <= std::min<std::size_t>(recent_next_, recent_.size()) && bytes > 0; ++back) {
      bytes -= std::min<std::size_t>(bytes, recent_[(recent_next_ - back) % recent_.size()]);
      ++counts_.unread;
    }
    unread_since_.reset();
#else
    (void)now;
#endif
  }

  void open_pty(const std::string& link, const std::string& what) {
#ifdef _WIN32
    (void)link;
    throw Error(what + ": a pty needs Linux or macOS; on Windows, give one end of a virtual serial port pair (serial:COM5)");
#else
    if (link.empty()) throw Error(what + ": no link, expected pty:LINK (the path a driver opens, e.g. pty:/tmp/glovepose-right)");
    const int master = ::posix_openpt(O_RDWR | O_NOCTTY);
    if (master < 0 || ::grantpt(master) != 0 || ::unlockpt(master) != 0) throw Error(what + ": cannot make a pty: " + std::strerror(errno));
    pty_ = std::make_unique<boost::asio::posix::stream_descriptor>(io_, master);
    device_ = ::ptsname(master);
    // Held open, in raw mode: the pty stays whole while drivers open and close it, and no byte is
    // echoed back or translated.
    pty_device_ = ::open(device_.c_str(), O_RDWR | O_NOCTTY | O_CLOEXEC);
    if (pty_device_ < 0) throw Error(what + ": cannot open its pty '" + device_ + "': " + std::strerror(errno));
    raw_if_terminal(pty_device_);
    std::error_code e;
    if (std::filesystem::is_symlink(std::filesystem::symlink_status(link, e))) std::filesystem::remove(link, e);
    std::filesystem::create_symlink(device_, link, e);
    if (e) throw Error(what + ": cannot name the pty '" + link + "': " + e.message() + " (an existing file is not replaced)");
    link_ = link;
#endif
  }

  std::string device_, link_, pipe_name_;
  LinkTiming timing_;
  boost::asio::io_context io_;
  std::optional<LinkAddress> serial_address_;
  std::unique_ptr<boost::asio::serial_port> serial_;
  std::unique_ptr<ByteSink> file_;
#ifdef _WIN32
  std::unique_ptr<boost::asio::windows::stream_handle> pipe_;
#else
  std::unique_ptr<boost::asio::posix::stream_descriptor> pty_;
  int pty_device_ = -1;
#endif
  std::array<char, 256> out_{};
  std::array<char, 256> in_{};
  std::array<std::uint16_t, 512> recent_{};
  std::size_t recent_next_ = 0;
  std::optional<Clock::time_point> unread_since_;
  bool writing_ = false;
  std::uint64_t generation_ = 0;  // which port a pending write or read was started on
  Clock::time_point write_started_{}, next_attempt_{};
  std::chrono::milliseconds retry_after_;
  OpenGlovesCounts counts_;
  LinkEvents events_;
};

}  // namespace glovepose::cli
