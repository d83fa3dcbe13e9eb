// The few socket calls glovepose view's loopback server makes, on POSIX and on Windows (Winsock 2),
// so that the tool builds and serves the same page on both, and the reading of a request's head
// within limits. Why our own and not an HTTP library: Debian's cpp-httplib (libcpp-httplib-dev)
// ships a compiled Linux library only, which the mingw-w64 cross build for Windows cannot link,
// and the server needs little: GET of a few embedded files, a JSON state and an event stream on
// 127.0.0.1, one thread per connection.
#pragma once

#include <glovepose/config.hpp>

#ifdef _WIN32
#  include <winsock2.h>
#  include <ws2tcpip.h>
#else
#  include <arpa/inet.h>
#  include <netinet/in.h>
#  include <poll.h>
#  include <sys/socket.h>
#  include <unistd.h>
#endif

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstddef>
#include <cstdint>
#include <string>
#include <utility>

namespace glovepose::cli {

#ifdef _WIN32
using Socket = SOCKET;
inline constexpr Socket kNoSocket = INVALID_SOCKET;
#else
using Socket = int;
inline constexpr Socket kNoSocket = -1;
#endif

/// @brief Winsock's start and end (WSAStartup, WSACleanup) around a server's life; nothing on POSIX.
class SocketLibrary {
 public:
  SocketLibrary() {
#ifdef _WIN32
    WSADATA data;
    if (WSAStartup(MAKEWORD(2, 2), &data) != 0) throw Error("cannot start Winsock 2.2, expected a Windows with TCP/IP");
#endif
  }
  ~SocketLibrary() {
#ifdef _WIN32
    WSACleanup();
#endif
  }
  SocketLibrary(const SocketLibrary&) = delete;
  SocketLibrary& operator=(const SocketLibrary&) = delete;
};

inline void close_socket(Socket s) noexcept {
#ifdef _WIN32
  (void)::closesocket(s);
#else
  (void)::close(s);
#endif
}

/// @brief Whether `s` has a connection or data to read within `milliseconds`.
inline bool wait_readable(Socket s, int milliseconds) noexcept {
#ifdef _WIN32
  WSAPOLLFD waiting{s, POLLRDNORM, 0};
  return ::WSAPoll(&waiting, 1, milliseconds) > 0;
#else
  pollfd waiting{s, POLLIN, 0};
  return ::poll(&waiting, 1, milliseconds) > 0;
#endif
}

/// @brief Sends all of `data`; false when the peer went away or took nothing for the send time-out
/// (no SIGPIPE on Linux).
inline bool send_all(Socket s, const std::string& data) noexcept {
  std::size_t sent = 0;
  while (sent < data.size()) {
#ifdef _WIN32
    const int n = ::send(s, data.data() + sent, static_cast<int>(data.size() - sent), 0);
#else
    const ssize_t n = ::send(s, data.data() + sent, data.size() - sent, MSG_NOSIGNAL);
#endif
    if (n <= 0) return false;
    sent += static_cast<std::size_t>(n);
  }
  return true;
}

/// @brief A send that waits longer than `milliseconds` fails (a reader that stopped reading).
inline void set_send_timeout(Socket s, int milliseconds) noexcept {
#ifdef _WIN32
  const DWORD wait = static_cast<DWORD>(milliseconds);
  (void)::setsockopt(s, SOL_SOCKET, SO_SNDTIMEO, reinterpret_cast<const char*>(&wait), sizeof wait);
#else
  timeval wait{milliseconds / 1000, (milliseconds % 1000) * 1000};
  (void)::setsockopt(s, SOL_SOCKET, SO_SNDTIMEO, &wait, sizeof wait);
#endif
}

/// @brief Up to `size` bytes received from `s` (empty when the peer closed or failed).
inline std::string receive_some(Socket s, std::size_t size) {
  std::string buffer(size, '\0');
#ifdef _WIN32
  const int n = ::recv(s, buffer.data(), static_cast<int>(size), 0);
#else
  const ssize_t n = ::recv(s, buffer.data(), size, 0);
#endif
  buffer.resize(n > 0 ? static_cast<std::size_t>(n) : 0);
  return buffer;
}

/// @brief The head of an HTTP/1.x request: status 200 when it was read and its request line is
/// well formed; else the status to answer with (400 malformed, 408 not complete within the time,
/// 431 longer than allowed); 0 when the peer closed first or the server is stopping.
struct RequestHead {
  int status = 0;
  std::string method, target;
};

/// @brief The request line of a request's head (the bytes up to its blank line): status 200 with the
/// method and target when it reads METHOD SP target SP HTTP/1.x (the method in capitals, the target
/// a path of visible ASCII without quotes, angle brackets, backslashes or tabs), else 400.
inline RequestHead parse_request_head(const std::string& head) {
  RequestHead out;
  const std::string line = head.substr(0, head.find("\r\n"));
  const std::size_t a = line.find(' '), b = a == std::string::npos ? a : line.find(' ', a + 1);
  out.status = 400;
  if (a == std::string::npos || b == std::string::npos || line.find(' ', b + 1) != std::string::npos) return out;
  out.method = line.substr(0, a);
  out.target = line.substr(a + 1, b - a - 1);
  const std::string version = line.substr(b + 1);
  if (out.method.empty() || out.method.find_first_not_of("ABCDEFGHIJKLMNOPQRSTUVWXYZ") != std::string::npos) return out;
  if (out.target.empty() || out.target[0] != '/' || out.target.find_first_of("\t\"<>\\") != std::string::npos) return out;
  for (char c : out.target)
    if (static_cast<unsigned char>(c) < 0x21 || static_cast<unsigned char>(c) > 0x7e) return out;
  if (version != "HTTP/1.1" && version != "HTTP/1.0") return out;
  out.status = 200;
  return out;
}

/// @brief Reads a request's head (up to the blank line) from `s`: at most `max_bytes`, within
/// `milliseconds`, giving up when `stop` is set; its request line as parse_request_head() reads it.
inline RequestHead read_request_head(Socket s, std::size_t max_bytes, int milliseconds, const std::atomic<bool>& stop) {
  using Clock = std::chrono::steady_clock;
  const Clock::time_point deadline = Clock::now() + std::chrono::milliseconds(milliseconds);
  std::string head;
  RequestHead out;
  std::size_t end = std::string::npos;
  while ((end = head.find("\r\n\r\n")) == std::string::npos) {
    if (head.size() > max_bytes) {
      out.status = 431;
      return out;
    }
    const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - Clock::now()).count();
    if (left <= 0) {
      out.status = 408;
      return out;
    }
    if (stop) return out;
    if (!wait_readable(s, static_cast<int>(std::min<long long>(left, 100)))) continue;
    const std::string more = receive_some(s, max_bytes + 1 - head.size());
    if (more.empty()) return out;  // closed
    head += more;
  }
  if (end > max_bytes) {
    out.status = 431;
    return out;
  }
  return parse_request_head(head.substr(0, end));
}

/// @brief Answers with an error status and a one-line reason, then the connection closes.
inline void send_error(Socket s, int status) noexcept {
  const char* reason = status == 400   ? "Bad Request"
                       : status == 404 ? "Not Found"
                       : status == 405 ? "Method Not Allowed"
                       : status == 408 ? "Request Timeout"
                       : status == 431 ? "Request Header Fields Too Large"
                       : status == 503 ? "Service Unavailable"
                                       : "Error";
  try {
    const std::string body = std::to_string(status) + " " + reason + "\n";
    (void)send_all(s, "HTTP/1.1 " + body.substr(0, body.size() - 1) +
                          "\r\nContent-Type: text/plain\r\nContent-Length: " + std::to_string(body.size()) +
                          (status == 405 ? "\r\nAllow: GET, HEAD" : "") + "\r\nConnection: close\r\n\r\n" + body);
  } catch (...) {  // out of memory for a few dozen bytes: the client sees the connection close
  }
}

/// @brief A listening socket on 127.0.0.1:port (0: any free port) and the port it got.
inline std::pair<Socket, int> listen_on_loopback(int port) {
  const Socket s = ::socket(AF_INET, SOCK_STREAM, 0);
  if (s == kNoSocket) throw Error("cannot create a socket");
#ifndef _WIN32
  // A restarted view may take its port back at once. (On Windows SO_REUSEADDR would let another
  // program take a port in use: its default already refuses that and frees ports promptly.)
  const int yes = 1;
  (void)::setsockopt(s, SOL_SOCKET, SO_REUSEADDR, &yes, sizeof yes);
#endif
  sockaddr_in address{};
  address.sin_family = AF_INET;
  address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  address.sin_port = htons(static_cast<std::uint16_t>(port));
  // The system's longest queue of connections not yet accepted: pages that connect in a burst are
  // not made to wait for their SYN to be sent again.
  if (::bind(s, reinterpret_cast<sockaddr*>(&address), sizeof address) != 0 || ::listen(s, SOMAXCONN) != 0) {
    close_socket(s);
    throw Error("cannot listen on 127.0.0.1:" + std::to_string(port) + ", expected a free port (--port)");
  }
  socklen_t length = sizeof address;
  (void)::getsockname(s, reinterpret_cast<sockaddr*>(&address), &length);
  return {s, ntohs(address.sin_port)};
}

}  // namespace glovepose::cli
