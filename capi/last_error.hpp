// How the C libraries of capi/ report a failure (internal: not installed): a result code returned,
// the message in a thread-local buffer that the library's *_last_error() function returns. Shared by
// glovepose_c (glovepose_last_error) and glovepose_eval (glovepose_eval_last_error); each shared
// library has its own buffer (hidden visibility, one copy per library), so neither exports a way into
// the other's.
#ifndef GLOVEPOSE_CAPI_LAST_ERROR_HPP
#define GLOVEPOSE_CAPI_LAST_ERROR_HPP

#include "glovepose_c.h"  // glovepose_result and the GLOVEPOSE_ERROR_* codes

#include <glovepose/config.hpp>

#include <cstdarg>
#include <cstddef>
#include <cstdio>
#include <cstring>
#include <exception>
#include <new>

namespace glovepose::capi {

// Fixed-size and trivially constructed: setting it never allocates, and a thread-local of a
// trivial type needs no per-thread constructor or destructor.
inline constexpr std::size_t kLastErrorCapacity = 2048;
inline thread_local char last_error_text[kLastErrorCapacity] = "";

// Copies a message into the buffer: the per-frame calls' path (no formatting, no allocation).
inline glovepose_result fail(glovepose_result code, const char* message) noexcept {
  std::size_t n = std::strlen(message);
  if (n >= kLastErrorCapacity) n = kLastErrorCapacity - 1;
  std::memcpy(last_error_text, message, n);
  last_error_text[n] = '\0';
  return code;
}

// Set-up paths only: the message is formatted into the fixed buffer.
#if defined(__GNUC__) || defined(__clang__)
__attribute__((format(printf, 2, 3)))
#endif
inline glovepose_result
failf(glovepose_result code, const char* format, ...) noexcept {
  std::va_list args;
  va_start(args, format);
  std::vsnprintf(last_error_text, kLastErrorCapacity, format, args);
  va_end(args);
  return code;
}

inline bool readable(const char* path) noexcept {
  std::FILE* file = std::fopen(path, "rb");
  if (file == nullptr) return false;
  std::fclose(file);
  return true;
}

// Maps the exception in flight to a code. `reading` is the file a glovepose::Error may be about:
// unopenable means not found, otherwise its contents were refused.
inline glovepose_result fail_from_exception(const char* reading, glovepose_result error_code) noexcept {
  try {
    throw;
  } catch (const std::bad_alloc&) {
    return fail(GLOVEPOSE_ERROR_OUT_OF_MEMORY, "out of memory");
  } catch (const glovepose::Error& e) {
    if (reading != nullptr && !readable(reading)) return fail(GLOVEPOSE_ERROR_FILE_NOT_FOUND, e.what());
    return fail(error_code, e.what());
  } catch (const std::exception& e) {
    return fail(GLOVEPOSE_ERROR_INTERNAL, e.what());
  } catch (...) {
    return fail(GLOVEPOSE_ERROR_INTERNAL, "unknown exception");
  }
}

}  // namespace glovepose::capi

#endif  // GLOVEPOSE_CAPI_LAST_ERROR_HPP
