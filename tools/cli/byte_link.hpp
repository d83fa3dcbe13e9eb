// The tool's byte links to a device: a sink it writes (glovepose simulate --stream) and a source it
// reads (glovepose record), each stdin/stdout or a path: a file, a named pipe, a pty or a serial
// port, which is put in raw mode so that no byte is translated or echoed.
#pragma once

#include <glovepose/config.hpp>
#include <glovepose/io/atomic_file.hpp>

#include <cerrno>
#include <chrono>
#include <csignal>
#include <cstdint>
#include <cstring>
#include <string>

#include <fcntl.h>
#ifdef _WIN32
#  include <io.h>
#  include <windows.h>
#  include <thread>
#else
#  include <poll.h>
#  include <termios.h>
#  include <unistd.h>
#endif

namespace glovepose::cli {

/// A pty or serial port in raw mode: 8 bits, no echo, no line-end translation; anything else as it is.
inline void raw_if_terminal(int fd) noexcept {
#ifndef _WIN32
  termios mode{};
  if (::isatty(fd) && ::tcgetattr(fd, &mode) == 0) {
    ::cfmakeraw(&mode);
    (void)::tcsetattr(fd, TCSANOW, &mode);
  }
#else
  (void)fd;
#endif
}

/// Writes all `size` bytes to `fd`; throws Error "<what>: cannot write: <cause>" when refused.
inline void write_all(int fd, const std::uint8_t* data, std::size_t size, const std::string& what) {
  if (const int cause = io::write_fully(fd, data, size)) throw Error(what + ": cannot write: " + std::strerror(cause));
}

inline void close_fd(int fd) noexcept {
#ifdef _WIN32
  (void)::_close(fd);
#else
  (void)::close(fd);
#endif
}

/// SIGINT and SIGTERM call `handler` (which sets a flag the command checks); on POSIX they also
/// interrupt a read that waits (no SA_RESTART), so a command blocked on stdin or a pipe stops too.
inline void stop_on_signals(void (*handler)(int)) {
#ifdef _WIN32
  std::signal(SIGINT, handler);
  std::signal(SIGTERM, handler);
#else
  struct sigaction action {};
  action.sa_handler = handler;
  sigemptyset(&action.sa_mask);
  sigaction(SIGINT, &action, nullptr);
  sigaction(SIGTERM, &action, nullptr);
#endif
}

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
    raw_if_terminal(fd_);
  }
  ByteSink(const ByteSink&) = delete;
  ByteSink& operator=(const ByteSink&) = delete;
  ~ByteSink() {
    if (owned_) close_fd(fd_);
  }

  /// Writes all `size` bytes; throws Error when the other end is gone or refuses them.
  void write(const std::uint8_t* data, std::size_t size) { write_all(fd_, data, size, "stream target '" + target_ + "'"); }

 private:
  std::string target_;
  int fd_ = -1;
  bool owned_ = false;
};

/// Where a stream of bytes comes from: "-" for stdin, else a path opened for reading.
class ByteSource {
 public:
  explicit ByteSource(const std::string& source) : source_(source) {
    if (source == "-") {
      fd_ = 0;
#ifdef _WIN32
      (void)_setmode(0, _O_BINARY);
#endif
      return;
    }
#ifdef _WIN32
    fd_ = ::_open(source.c_str(), _O_RDONLY | _O_BINARY);
#else
    fd_ = ::open(source.c_str(), O_RDONLY | O_NOCTTY | O_CLOEXEC);
#endif
    if (fd_ < 0) throw Error("source '" + source + "': cannot open it for reading: " + std::strerror(errno));
    owned_ = true;
    raw_if_terminal(fd_);
  }
  ByteSource(const ByteSource&) = delete;
  ByteSource& operator=(const ByteSource&) = delete;
  ~ByteSource() {
    if (owned_) close_fd(fd_);
  }

  /// read()'s answer when `wait` passed with no byte.
  static constexpr long kNothingYet = -2;

  /// Up to `size` bytes as soon as any arrive: the count, 0 at the end, -1 when interrupted by a
  /// signal (EINTR), kNothingYet when none came within `wait` (a pipe or terminal that pauses; on
  /// Windows a pipe, whose pauses record must outlast to flush, while a console waits for bytes);
  /// throws Error for another failure.
  long read(std::uint8_t* data, std::size_t size, std::chrono::milliseconds wait) {
#ifndef _WIN32
    pollfd ready{fd_, POLLIN, 0};
    const int polled = ::poll(&ready, 1, static_cast<int>(wait.count()));
    if (polled < 0 && errno == EINTR) return -1;
    if (polled == 0) return kNothingYet;
#else
    // An anonymous or named pipe cannot be waited on: its unread bytes are peeked every 2 ms.
    const HANDLE handle = reinterpret_cast<HANDLE>(::_get_osfhandle(fd_));
    if (handle != INVALID_HANDLE_VALUE && ::GetFileType(handle) == FILE_TYPE_PIPE) {
      const auto until = std::chrono::steady_clock::now() + wait;
      DWORD unread = 0;
      // A failed peek is a closed writer: read() then says 0 (the end) or the error.
      while (::PeekNamedPipe(handle, nullptr, 0, nullptr, &unread, nullptr) && unread == 0) {
        if (std::chrono::steady_clock::now() >= until) return kNothingYet;
        std::this_thread::sleep_for(std::chrono::milliseconds(2));
      }
    }
#endif
    return read(data, size);
  }

  /// Up to `size` bytes, waiting for them: as read() above, without kNothingYet.
  long read(std::uint8_t* data, std::size_t size) {
#ifdef _WIN32
    const int n = ::_read(fd_, data, static_cast<unsigned>(size));
#else
    const ssize_t n = ::read(fd_, data, size);
#endif
    if (n < 0 && errno == EINTR) return -1;
    if (n < 0 && errno == EIO) return 0;  // a pty whose other side closed
    if (n < 0) throw Error("source '" + source_ + "': cannot read: " + std::strerror(errno));
    return static_cast<long>(n);
  }

 private:
  std::string source_;
  int fd_ = -1;
  bool owned_ = false;
};

}  // namespace glovepose::cli
