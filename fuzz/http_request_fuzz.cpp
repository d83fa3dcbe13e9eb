/// @file http_request_fuzz.cpp
/// @brief Fuzz target: bytes sent as a request to `glovepose view`'s server, read by its request
/// reader (tools/cli/loopback_socket.hpp: read_request_head over a socket pair, the writer closed
/// after the bytes; head limit 512 bytes) and parsed by its request-line parser on its own.
///
/// Invariants: no exception; the status is 0 (closed before a blank line), 200, 400, 408 or 431; a
/// head that does not end within the limit is 431 (0 when the bytes end first); otherwise the
/// reader's answer is the parser's on the bytes before the blank line; a 200 has a method of capitals and a target that starts with '/' and
/// holds visible ASCII only, and the bytes start with "METHOD target ".
#include <sys/socket.h>
#include <unistd.h>

#include <atomic>
#include <cstdint>
#include <string>

#include "fuzz_check.hpp"
#include "loopback_socket.hpp"

using glovepose::cli::RequestHead;

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string bytes(reinterpret_cast<const char*>(data), size);
  constexpr std::size_t kLimit = 512;
  const RequestHead parsed = glovepose::cli::parse_request_head(bytes);
  GLOVEPOSE_FUZZ_REQUIRE(parsed.status == 200 || parsed.status == 400);
  if (parsed.status == 200) {
    GLOVEPOSE_FUZZ_REQUIRE(!parsed.method.empty() && parsed.method.find_first_not_of("ABCDEFGHIJKLMNOPQRSTUVWXYZ") == std::string::npos);
    GLOVEPOSE_FUZZ_REQUIRE(!parsed.target.empty() && parsed.target[0] == '/');
    for (char c : parsed.target) GLOVEPOSE_FUZZ_REQUIRE(c > ' ' && c < 0x7f);
    GLOVEPOSE_FUZZ_REQUIRE(bytes.compare(0, parsed.method.size() + parsed.target.size() + 2, parsed.method + " " + parsed.target + " ") == 0);
  }
  int pair[2];
  if (::socketpair(AF_UNIX, SOCK_STREAM, 0, pair) != 0) return 0;
  std::size_t sent = 0;
  while (sent < size) {  // a socket pair holds far more than libFuzzer's inputs
    const ssize_t n = ::send(pair[1], data + sent, size - sent, MSG_NOSIGNAL);
    if (n <= 0) break;
    sent += static_cast<std::size_t>(n);
  }
  ::close(pair[1]);
  const std::atomic<bool> stop{false};
  const RequestHead read = glovepose::cli::read_request_head(pair[0], kLimit, 1000, stop);
  ::close(pair[0]);
  GLOVEPOSE_FUZZ_REQUIRE(read.status == 0 || read.status == 200 || read.status == 400 || read.status == 408 || read.status == 431);
  if (read.status == 408) return 0;  // a machine too slow for the second the reader waits
  // The reader holds at most the limit and one byte: a blank line beyond that is a head too long.
  const std::size_t end = bytes.find("\r\n\r\n");
  if (end != std::string::npos && end + 4 <= kLimit + 1) {
    const RequestHead expected = glovepose::cli::parse_request_head(bytes.substr(0, end));
    GLOVEPOSE_FUZZ_REQUIRE(read.status == expected.status && read.method == expected.method && read.target == expected.target);
  } else {
    GLOVEPOSE_FUZZ_REQUIRE(read.status == (size > kLimit ? 431 : 0));
  }
  return 0;
}
