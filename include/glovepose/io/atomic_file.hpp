/// @file atomic_file.hpp
/// @brief The one way the library and the tool write a file: whole or not at all. The bytes go to a
/// temporary file beside the target ("<target>.partial-<pid>-<n>"); commit() flushes it to the disk,
/// renames it over the target (an atomic replace on POSIX and Windows) and, on POSIX, flushes the
/// directory so the rename survives a power cut. A write that fails, an exception before commit()
/// or a killed process leaves the target as it was: the temporary file is removed (after a kill, by
/// the next successful write of the same target, which removes the partial files of processes that
/// no longer run). Set-up code: errors are glovepose::Error naming the file and the cause.
#pragma once

#include <atomic>
#include <cerrno>
#include <cstddef>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <ostream>
#include <streambuf>
#include <string>
#include <vector>

#include "../config.hpp"

#ifdef _WIN32
#  include <fcntl.h>
#  include <io.h>
#  include <process.h>
#  include <sys/stat.h>

#  include <filesystem>
#else
#  include <dirent.h>
#  include <fcntl.h>
#  include <signal.h>
#  include <sys/stat.h>
#  include <unistd.h>
#endif

namespace glovepose::io {

/// @brief Writes all `size` bytes to the file descriptor `fd`, again after an interrupted call
/// (EINTR). Returns 0, or the cause it stopped at (an errno value; EIO when a write took nothing).
inline int write_fully(int fd, const void* data, std::size_t size) noexcept {
  const char* p = static_cast<const char*>(data);
  while (size > 0) {
#ifdef _WIN32
    const int n = ::_write(fd, p, static_cast<unsigned>(size));
#else
    const ssize_t n = ::write(fd, p, size);
#endif
    if (n < 0 && errno == EINTR) continue;
    if (n < 0) return errno;
    if (n == 0) return EIO;
    p += n;
    size -= static_cast<std::size_t>(n);
  }
  return 0;
}

/// @brief A file written whole or not at all (see the file's comment). Write through stream() or
/// write(), then commit(); destroyed without commit(), it leaves the target untouched.
class AtomicFile : private std::streambuf {
 public:
  /// @brief Starts writing `path`; `kind` names the file in errors ("model file", "calibration
  /// file"). Throws glovepose::Error when the temporary file cannot be created.
  AtomicFile(std::string path, std::string kind) : path_(std::move(path)), kind_(std::move(kind)), buffer_(kBufferBytes), stream_(this) {
    static std::atomic<unsigned> counter{0};
    temp_ = partial_prefix(path_) + std::to_string(process_id()) + "-" + std::to_string(counter.fetch_add(1));
#ifdef _WIN32
    fd_ = ::_open(temp_.c_str(), _O_WRONLY | _O_CREAT | _O_EXCL | _O_BINARY, _S_IREAD | _S_IWRITE);
#else
    fd_ = ::open(temp_.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0666);
#endif
    if (fd_ < 0) {
      const int err = errno;
      throw failure("cannot open for writing (temporary file '" + temp_ + "')", err);
    }
    setp(buffer_.data(), buffer_.data() + buffer_.size());
  }
  AtomicFile(const AtomicFile&) = delete;
  AtomicFile& operator=(const AtomicFile&) = delete;

  /// @brief Removes the temporary file unless commit() succeeded.
  ~AtomicFile() override {
    if (fd_ >= 0) close_fd();
    if (!committed_) std::remove(temp_.c_str());
  }

  /// @brief A stream onto the file; a failed write shows at commit().
  std::ostream& stream() noexcept { return stream_; }

  /// @brief Appends `size` bytes.
  void write(const void* data, std::size_t size) { stream_.write(static_cast<const char*>(data), static_cast<std::streamsize>(size)); }

  /// @brief Flushes the bytes to the disk and replaces the target with them. Throws glovepose::Error
  /// naming the file and the cause (the target then keeps its previous contents).
  void commit() {
    if (committed_) return;
    if (!flush_buffer() || !stream_) throw failure("cannot write", error_ != 0 ? error_ : EIO);
#ifdef _WIN32
    if (::_commit(fd_) != 0) throw_errno("cannot flush to the disk");
#else
    if (::fsync(fd_) != 0) throw_errno("cannot flush to the disk");
#endif
    if (close_fd() != 0) throw_errno("cannot write");
#ifdef _WIN32
    std::error_code ec;  // MoveFileExW with MOVEFILE_REPLACE_EXISTING in both standard libraries
    std::filesystem::rename(std::filesystem::path(temp_), std::filesystem::path(path_), ec);
    if (ec) throw Error(kind_ + " '" + path_ + "': cannot replace it: " + ec.message() + "; the previous file is unchanged");
#else
    if (std::rename(temp_.c_str(), path_.c_str()) != 0) throw_errno("cannot replace it");
    sync_directory();
#endif
    committed_ = true;
    remove_orphans();
  }

  /// @brief The target's path.
  const std::string& path() const noexcept { return path_; }

  /// @brief The prefix of the temporary files of `path`: "<path>.partial-".
  static std::string partial_prefix(const std::string& path) { return path + ".partial-"; }

 private:
  static constexpr std::size_t kBufferBytes = 1 << 16;

  static long process_id() noexcept {
#ifdef _WIN32
    return static_cast<long>(::_getpid());
#else
    return static_cast<long>(::getpid());
#endif
  }

  // The cause is the errno of the call that failed: read before anything can change it.
  [[noreturn]] void throw_errno(const char* what) const {
    const int err = errno;
    throw failure(what, err);
  }

  Error failure(const std::string& what, int err) const {
    return Error(kind_ + " '" + path_ + "': " + what + ": " + std::strerror(err) + "; the previous file is unchanged");
  }

  // Writes the buffered bytes; false (with error_ set) when the system refuses them.
  bool flush_buffer() noexcept {
    if (error_ == 0) error_ = write_fully(fd_, pbase(), static_cast<std::size_t>(pptr() - pbase()));
    setp(buffer_.data(), buffer_.data() + buffer_.size());
    return error_ == 0;
  }

  int overflow(int_type ch) override {
    if (!flush_buffer()) return traits_type::eof();
    if (traits_type::eq_int_type(ch, traits_type::eof())) return traits_type::not_eof(ch);
    *pptr() = traits_type::to_char_type(ch);
    pbump(1);
    return ch;
  }

  int sync() override { return flush_buffer() ? 0 : -1; }

  int close_fd() noexcept {
#ifdef _WIN32
    const int result = ::_close(fd_);
#else
    const int result = ::close(fd_);
#endif
    fd_ = -1;
    return result;
  }

#ifndef _WIN32
  std::string directory() const {
    const std::size_t slash = path_.rfind('/');
    return slash == std::string::npos ? "." : slash == 0 ? "/" : path_.substr(0, slash);
  }

  // The rename is durable once the directory's entry is on the disk.
  void sync_directory() const noexcept {
    const int dir = ::open(directory().c_str(), O_RDONLY | O_CLOEXEC);
    if (dir < 0) return;
    (void)::fsync(dir);
    (void)::close(dir);
  }
#endif

  // Partial files of this target left by processes that were killed while writing it.
  void remove_orphans() const noexcept {
#ifndef _WIN32
    const std::string dir_path = directory();
    const std::size_t slash = path_.rfind('/');
    const std::string prefix = partial_prefix(slash == std::string::npos ? path_ : path_.substr(slash + 1));
    DIR* dir = ::opendir(dir_path.c_str());
    if (dir == nullptr) return;
    while (const dirent* entry = ::readdir(dir)) {
      const std::string name = entry->d_name;
      if (name.compare(0, prefix.size(), prefix) != 0) continue;
      char* end = nullptr;
      const long pid = std::strtol(name.c_str() + prefix.size(), &end, 10);
      if (end == name.c_str() + prefix.size() || *end != '-' || pid <= 0 || pid == process_id()) continue;
      if (::kill(static_cast<pid_t>(pid), 0) != 0 && errno == ESRCH) ::unlink((dir_path + "/" + name).c_str());
    }
    ::closedir(dir);
#endif
  }

  std::string path_, kind_, temp_;
  std::vector<char> buffer_;
  std::ostream stream_;
  int fd_ = -1;
  int error_ = 0;
  bool committed_ = false;
};

/// @brief Writes `path` whole or not at all: `fill(std::ostream&)` writes the contents, then the
/// file replaces the target. `kind` names the file in errors.
template <typename Fill>
void write_file_whole(const std::string& path, const std::string& kind, Fill&& fill) {
  AtomicFile file(path, kind);
  fill(file.stream());
  file.commit();
}

}  // namespace glovepose::io
