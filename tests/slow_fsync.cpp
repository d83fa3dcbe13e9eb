// A library to preload (LD_PRELOAD) into the tool: every fsync() first sleeps, by default 200 ms
// (GLOVEPOSE_FSYNC_DELAY_MS). A file the tool writes then stays a temporary file long enough for
// tests/python/test_crash_writes.py to kill the process while it is being written, even when the
// file is a few hundred bytes that would otherwise be written, flushed and renamed in microseconds.
#include <cstdlib>
#include <ctime>

#include <sys/syscall.h>
#include <unistd.h>

extern "C" int fsync(int fd) {
  const char* text = std::getenv("GLOVEPOSE_FSYNC_DELAY_MS");
  const long ms = text != nullptr ? std::strtol(text, nullptr, 10) : 200;
  timespec delay{ms / 1000, (ms % 1000) * 1000000L};
  while (nanosleep(&delay, &delay) != 0) {
  }
  return static_cast<int>(syscall(SYS_fsync, fd));
}
